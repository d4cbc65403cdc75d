"""OBJ + MTL: the own parser against known counts, its traps, the MTL mapping, bad input."""
import math

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m
from glrender.scene.loaders.obj import obj_material, phong_alpha, read_obj

from conftest import SCENES

MCGUIRE = SCENES / "cornellbox-mcguire-obj" / "CornellBox-Original.obj"


def test01_mcguire_cornell_box_counts_and_bounds(caught):
    # negative indices, tab-separated vertices, quads: trimesh reads 24 of 72 vertices
    with caught as messages:
        scene = glrender.load(MCGUIRE)
    tris = sum(len(s.triangles) for s in scene.shapes)
    assert tris == 36 and len(scene.shapes) == 8
    lo = np.min([s.vertices.min(axis=0) for s in scene.shapes], axis=0)
    hi = np.max([s.vertices.max(axis=0) for s in scene.shapes], axis=0)
    np.testing.assert_allclose(lo, [-1.02, 0.0, -1.04], atol=1e-6)
    np.testing.assert_allclose(hi, [1.0, 1.99, 0.99], atol=1e-6)
    light = [s for s in scene.shapes if s.emission is not None]
    assert len(light) == 1 and light[0].emission.radiance == (17.0, 12.0, 4.0)
    kinds = {scene.materials[s.material].name: scene.materials[s.material].kind for s in scene.shapes}
    assert kinds["shortBox"] == "roughconductor" and kinds["leftWall"] == "diffuse"
    assert any("no camera" in w for w in messages)     # the default camera frames it


def test02_relative_indices_polygons_and_groups(write):
    path = write("a.obj", "o first\nv 0 0 0\nv\t1 0 0\nv 1 1 0  \nv 0 1 0\nf -4 -3 -2 -1\n"
                          "o second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
                          "f -3/-3 -2/-2 -1/-1\n")
    obj = read_obj(path)
    assert len(obj.triangles) == 3
    mesh = obj.merged()
    assert len(mesh.triangles) == 3 and len(mesh.vertices) == 7
    # a quad became a fan, and the second triangle uses the last three vertices
    v = mesh.vertices[mesh.triangles]
    np.testing.assert_allclose(v[2, :, 2], [1, 1, 1])
    # uv flipped to Mitsuba's convention v' = 1 - v
    second = mesh.uvs[mesh.triangles[2]]
    np.testing.assert_allclose(second, [[0, 1], [1, 1], [0, 0]])


def test03_missing_normals_are_angle_weighted(write):
    # a tetrahedron corner: three faces meet at vertex 0 with different angles
    path = write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n")
    mesh = read_obj(path).merged()
    n0 = mesh.normals[np.argmin(np.linalg.norm(mesh.vertices, axis=1))]
    np.testing.assert_allclose(n0, -np.ones(3) / math.sqrt(3), atol=1e-12)


def test04_mtl_mapping(write):
    write("tex.png", b"")
    from PIL import Image

    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(write("t.png", b""))
    path = write("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glass\nf 1 2 3\n")
    write("m.mtl", "newmtl glass\nKd 0 0 0\nNi 1.33\nillum 7\n"
                   "newmtl shiny\nKd 0.5 0.4 0.3\nKs 0.2 0.2 0.2\nNs 198\n"
                   "newmtl metal\nKd 0 0 0\nKs 0.9 0.9 0.9\nNs 1000\n"
                   "newmtl lamp\nKd 0.1 0.1 0.1\nKe 5 4 3\n"
                   "newmtl wood\nKd 1 1 1\nmap_Kd -s 2 3 1 t.png\n")
    mtl = read_obj(path).materials
    glass, _ = obj_material(mtl["glass"], "glass")
    assert glass.kind == "dielectric" and glass.int_ior == 1.33
    shiny, _ = obj_material(mtl["shiny"], "shiny")
    assert shiny.kind == "roughplastic" and shiny.alpha == pytest.approx((0.1, 0.1))   # sqrt(2 / 200)
    metal, _ = obj_material(mtl["metal"], "metal")
    assert metal.kind == "roughconductor" and metal.alpha[0] == pytest.approx(phong_alpha(1000))
    _, emission = obj_material(mtl["lamp"], "lamp")
    assert emission.radiance == (5.0, 4.0, 3.0)
    wood, _ = obj_material(mtl["wood"], "wood")
    tex = wood.reflectance
    assert isinstance(tex, m.Texture) and tex.image.shape == (2, 2, 3)
    # -s 2 3 in OBJ's v-up space becomes v' -> 3 v' + (1 - 3) in the flipped convention
    np.testing.assert_allclose(tex.uv_transform, [[2, 0, 0], [0, 3, -2], [0, 0, 1]])
    np.testing.assert_allclose(tex.image, ((128 / 255 + 0.055) / 1.055) ** 2.4, rtol=1e-6)


def test04b_pbr_extension_pr_pm(write):
    """MTL's PBR extension: Pr and Pm pick the material as glTF's metallic-roughness does
    (conductor from Pm >= 0.5 reflecting Kd, else plastic; GGX alpha = Pr^2; smooth below
    0.03); a missing Pr is the roughness whose alpha matches Ns; glass stays glass; a value
    outside [0, 1] names the file and line."""
    path = write("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl gold\nf 1 2 3\n")
    write("m.mtl", "newmtl gold\nKd 1 0.8 0.3\nPr 0.4\nPm 1\n"
                   "newmtl paint\nKd 0.2 0.3 0.6\nPr 0.5\nPm 0\n"
                   "newmtl mirror\nKd 0.9 0.9 0.9\nPm 0.9\nPr 0.01\n"
                   "newmtl lacquer\nKd 0.5 0.1 0.1\nNs 198\nPm 0.2\n"
                   "newmtl glass\nKd 1 1 1\nillum 7\nPr 0.3\n")
    mtl = read_obj(path).materials
    gold, _ = obj_material(mtl["gold"], "gold")
    assert gold.kind == "roughconductor" and gold.distribution == "ggx"
    assert gold.alpha == pytest.approx((0.16, 0.16)) and gold.specular_reflectance == (1.0, 0.8, 0.3)
    paint, _ = obj_material(mtl["paint"], "paint")
    assert paint.kind == "roughplastic" and paint.alpha == pytest.approx((0.25, 0.25))
    assert paint.reflectance == (0.2, 0.3, 0.6)
    mirror, _ = obj_material(mtl["mirror"], "mirror")
    assert mirror.kind == "conductor"
    lacquer, _ = obj_material(mtl["lacquer"], "lacquer")
    assert lacquer.kind == "roughplastic" and lacquer.alpha == pytest.approx((0.1, 0.1))   # sqrt(2 / 200)
    glass, _ = obj_material(mtl["glass"], "glass")
    assert glass.kind == "dielectric"
    write("bad.mtl", "newmtl a\nKd 1 1 1\nPr 1.5\n")
    bad = write("bad.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
    with pytest.raises(SceneError, match=r"bad\.mtl:3: Pr: expected a number in \[0, 1\], got 1.5"):
        read_obj(bad)


@pytest.mark.parametrize("text, message", [
    ("v 0 0 0\nv 1 0 0\nf 1 2\n", ":3: a face needs at least 3 vertices"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "refers to vertex 4"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", ":4: relative index -4"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4: index 0"),
    ("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", ":2: vertex with a NaN"),
    ("v 0 0 0\nv 1 0\n", ":2: v needs at least 3 numbers"),          # truncated mid-file
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n", ":4: malformed face vertex"),
    ("# nothing\n", "no faces found"),
])
def test05_bad_input_names_file_and_line(write, text, message):
    path = write("bad.obj", text)
    with pytest.raises(SceneError, match="bad.obj") as info:
        glrender.load(path)
    assert message in str(info.value)


def test06_zero_area_triangles_dropped_with_a_count(write, caught):
    path = write("z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n")
    with caught as messages:
        mesh = read_obj(path).merged()
    assert len(mesh.triangles) == 1
    assert any("dropped 2 zero-area triangles of 3" in w for w in messages)


def test07_missing_texture_names_the_mtl_file_and_line(write):
    path = write("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
    write("m.mtl", "newmtl a\nKd 1 1 1\nmap_Kd missing.png\n")
    with pytest.raises(SceneError, match=r"m\.mtl:3: texture 'missing.png' not found"):
        glrender.load(path)


def test08_missing_mtl_is_a_warning_and_unknown_statements_one_warning(write, caught):
    path = write("m.obj", "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\ncurv 0 1\nl 2 3\nf 1 2 3\n")
    with caught as messages:
        scene = glrender.load(path)
    assert len(scene.shapes) == 1
    ignored = [w for w in messages if "ignored OBJ statements" in w]
    assert len(ignored) == 1 and "'l' (lines 5, 7)" in ignored[0] and "'curv' (line 6)" in ignored[0]
    assert any("none.mtl" in w and "not found" in w for w in messages)
    assert any("no lights" in w for w in messages)


def test09_bulk_parser_agrees_with_the_general_one(write, monkeypatch):
    from glrender.scene.loaders import obj as obj_module

    rng = np.random.default_rng(3)
    n = 3000
    lines = [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in rng.random((n, 3))]
    lines += [f"vt {u:.4f} {v:.4f}" for u, v in rng.random((n, 2))]
    lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in rng.normal(size=(n, 3))]
    for k, (a, b, c) in enumerate(rng.integers(1, n + 1, (4000, 3))):
        if k % 1000 == 0:
            lines += [f"o part{k // 2000}", f"usemtl m{k // 1000 % 3}"]
        lines.append(f"f {a}/{b}/{c} {b}/{c}/{a} {c}/{a}/{b}")
    path = write("big.obj", "\n".join(lines) + "\n")
    assert path.stat().st_size > obj_module.FAST_PATH_BYTES
    assert obj_module._read_obj_fast(path.read_bytes(), path) is not None   # the bulk path runs
    fast = read_obj(path)
    monkeypatch.setattr(obj_module, "FAST_PATH_BYTES", 1 << 40)
    slow = read_obj(path)
    for name in ("positions", "texcoords", "normals", "corners", "triangles", "tri_material", "tri_object"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name), err_msg=name)
    assert fast.material_names == slow.material_names and fast.object_names == slow.object_names


def _same_obj(fast, slow):
    """The bulk parser's result read as the general parser's: the same meshes (corners may
    differ by unused vertices, see obj._corners), materials, objects and per-triangle ids."""
    assert fast.material_names == slow.material_names and fast.object_names == slow.object_names
    np.testing.assert_array_equal(fast.tri_material, slow.tri_material)
    np.testing.assert_array_equal(fast.tri_object, slow.tri_object)
    for name in ("positions", "texcoords", "normals"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name), err_msg=name)
    np.testing.assert_array_equal(fast.corners[fast.triangles], slow.corners[slow.triangles])


def _general(path):
    from glrender.scene.loaders import obj as obj_module

    size = obj_module.FAST_PATH_BYTES
    obj_module.FAST_PATH_BYTES = 1 << 40
    try:
        return read_obj(path, read_materials=False)
    finally:
        obj_module.FAST_PATH_BYTES = size


_BULK_LINES = [
    "v 0 0 0", "v 1 0 0", "v 0 1 0", "v 0 0 1 1", "v 1e39 0 0", "v nan 0 0", "v 1", "v\t0 1 1",
    "vt 0.5 0.5", "vt 0.25", "vt 0.1 0.2 0.3", "vn 0 0 1", "vn 0 1", "f 1 2 3", "f -1 -2 -3",
    "f 1/1 2/1 3/1", "f 1//1 2//1 3//1", "f 1/1/1 2/1/1 3/1/1", "f 1 2", "f 0 1 2", "f 9 1 2",
    "f 1/2/3/4 1 1", "f 1/1 2 3//1", "f 1/1/1 2/1 3//1//", "f /1 2 3", "f 1/ 2/ 3/", "f -9 1 2",
    "usemtl x", "usemtl y z", "mtllib none.mtl", "mtllib a/b.mtl", "o thing", "g", "s off", "vp 1",
    "f 1 1 1", "f 1 2 3 4 5 6", "f 1 2 3 #", "#", "# a/b 1 2", "", "\t", "  v 1 1 1", "vt",
    "f a b c", "f 1.0 2 3", "f +1 2 3", "v 1_0 0 0", "v nan(1) 0 0", "vn inf 0 0", "\u00a0",
    "g caf\u00e9", "v 0x1 0 0", "f 99999999999999999999 1 2",
]


def test10_bulk_parser_equals_the_general_one_or_declines(tmp_path):
    """On the fuzzed inputs (the OBJ lines of tests/scene/test_toml.py and more), forced
    whatever the size: the bulk parser returns what the general parser returns, or None
    (declines) wherever the general parser reports an error."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from glrender.scene.loaders import obj as obj_module

    path = tmp_path / "f.obj"
    accepted, loaded = [], []

    common = st.sampled_from(["v 0 0 1", "v 1 0 0.5", "v 0 1 0", "vt 0.5 0.5", "vn 0 0 1",
                              "f 1 2 3", "f -1 -2 -3", "f 3 1 2", "usemtl x", "o thing", "#", ""])

    @settings(max_examples=400, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(head=st.sampled_from(["", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n"]),
           lines=st.lists(st.one_of(common, common, common, common, st.sampled_from(_BULK_LINES)),
                          max_size=20),
           eol=st.sampled_from(["\n", "\r\n"]),
           noise=st.one_of(st.just(""), st.just(""), st.text(max_size=8)))
    def check(head, lines, eol, noise):
        data = (head.replace("\n", eol) + eol.join(lines) + eol + noise).encode("utf-8", errors="replace")
        path.write_bytes(data)
        fast = obj_module._read_obj_fast(data, path)
        try:
            slow = _general(path)
        except SceneError:
            assert fast is None, data
            return
        loaded.append(1)
        if fast is not None:
            accepted.append(1)
            _same_obj(fast[0], slow)

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check()
    assert len(accepted) > 20 and 3 * len(accepted) > len(loaded)   # a good share of those that load


def test11_bulk_parser_on_the_vendored_and_test_obj_files(write):
    """Every OBJ file the tests read (the third-party scenes of tests/data/scenes, a generated
    mixed file with relative indices, quads and groups): the bulk parser (forced) equals the
    general one."""
    from glrender.scene.loaders import obj as obj_module

    rng = np.random.default_rng(5)
    lines = ["mtllib none.mtl", "o a"]
    for block in range(3):
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rng.random((200, 3))]
        lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in rng.normal(size=(200, 3))]
        lines += [f"usemtl m{block % 2}", f"g part{block}", "s 1"]
        lines += ["f " + " ".join(f"{a}//{b}" for a, b in zip(q, rng.integers(-200, 0, 4)))
                  for q in rng.integers(-200, 0, (300, 4))]
    paths = [write("mixed.obj", "\n".join(lines) + "\n")]
    paths += sorted(SCENES.glob("**/*.obj"))
    taken = 0
    for path in paths:
        fast = obj_module._read_obj_fast(path.read_bytes(), path)
        if fast is not None:
            taken += 1
            _same_obj(fast[0], _general(path))
    assert obj_module._read_obj_fast(paths[0].read_bytes(), paths[0]) is not None
    assert taken >= 1


def _face(form: str, ids) -> str:
    """One face line in ``form`` ("v", "v/vt", "v//vn", "v/vt/vn"), every index used for
    each attribute."""
    pattern = {"v": "{}", "v/vt": "{}/{}", "v//vn": "{}//{}", "v/vt/vn": "{}/{}/{}"}[form]
    return "f " + " ".join(pattern.format(*[i] * pattern.count("{}")) for i in ids)


@pytest.mark.parametrize("form", ["v", "v/vt", "v//vn", "v/vt/vn"])
@pytest.mark.parametrize("shape", ["triangles", "quads", "mixed"])
@pytest.mark.parametrize("relative", [False, True])
def test12_bulk_parser_equals_the_general_one_on_each_face_form(write, form, shape, relative):
    """Small files of each corner form, of triangles, quads or both (and a pentagon),
    indices absolute or relative, with comments, blank lines and tabs: the bulk
    parser (forced) reads what the general parser reads."""
    from glrender.scene.loaders import obj as obj_module

    rng = np.random.default_rng(len(form) + 7 * len(shape) + relative)
    lines = ["# made by a test", "", "o blob"]
    total = 0
    for block in range(3):
        n = 12
        lines += [f"v {x:.5f}\t{y:.5f} {z:.5f}" for x, y, z in rng.random((n, 3))]
        lines += [f"vt {u:.4f} {v:.4f}" for u, v in rng.random((n, 2))]
        lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in rng.normal(size=(n, 3))]
        total += n
        lines += ["", "# faces of this block", f"usemtl m{block % 2}"]
        sizes = {"triangles": [3] * 6, "quads": [4] * 6, "mixed": [3, 4, 4, 3, 5, 3]}[shape]
        for size in sizes:
            ids = rng.choice(n, size, replace=False) + total - n      # this block's vertices
            ids = ids - total if relative else ids + 1
            lines.append(_face(form, ids))
        lines.append("   ")
    path = write("forms.obj", "\n".join(lines) + "\n")
    fast = obj_module._read_obj_fast(path.read_bytes(), path)
    assert fast is not None
    slow = _general(path)
    _same_obj(fast[0], slow)
    expected = {"triangles": 6, "quads": 12, "mixed": 10}[shape] * 3
    assert len(fast[0].triangles) == len(slow.triangles) == expected


def test13_a_large_file_with_a_bad_line_names_that_line(write):
    """The bulk parser declines a file with one bad face; the general parser's one line
    names the file and the line."""
    lines = [f"v {k}.25 {k % 7}.5 {k % 3}.75" for k in range(3000)]
    lines += [f"f {k + 1} {k + 2} {k + 3}" for k in range(0, 2997, 3)]
    lines[3500] = "f 1 2 x"
    path = write("big.obj", "\n".join(lines) + "\n")
    from glrender.scene.loaders import obj as obj_module

    assert path.stat().st_size > obj_module.FAST_PATH_BYTES
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    assert str(info.value).startswith(f"{path}:3501: malformed face vertex 'x'")


def test14_a_parsed_file_is_cached_by_its_bytes(write, tmp_path, monkeypatch):
    """The bulk parser's result is kept in the cache under the file's bytes: read again, it
    comes back without parsing, the same arrays and names; a changed byte parses again;
    GLRENDER_CACHE=off writes nothing."""
    from glrender.scene.loaders import obj as obj_module

    cache = tmp_path / "cache"
    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(cache))
    monkeypatch.delenv("GLRENDER_CACHE", raising=False)
    monkeypatch.setattr(obj_module, "CACHE_MIN_BYTES", 0)
    rng = np.random.default_rng(9)
    lines = ["mtllib none.mtl", "o thing"]
    lines += [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in rng.random((2000, 3))]
    lines += [f"vt {u:.4f} {v:.4f}" for u, v in rng.random((2000, 2))]
    lines += ["usemtl a"] + [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in rng.integers(1, 2001, (1500, 3))]
    lines += ["usemtl b"] + [f"f {a}/{a} {b}/{b} {c}/{c} {d}/{d}"
                             for a, b, c, d in rng.integers(1, 2001, (1500, 4))]
    path = write("cached.obj", "\n".join(lines) + "\n")
    parsed = read_obj(path, read_materials=False)
    assert len(list((cache / "bvh").glob("obj-*.bin"))) == 1

    parse = obj_module._read_obj_fast
    monkeypatch.setattr(obj_module, "_read_obj_fast", lambda *a: pytest.fail("parsed again"))
    mtl_files = []
    monkeypatch.setattr(obj_module, "_read_materials",
                        lambda obj, files, *a: mtl_files.extend(files))
    cached = read_obj(path)
    for name in obj_module._OBJ_ARRAYS:
        a, b = getattr(cached, name), getattr(parsed, name)
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert (cached.material_names, cached.object_names) == (parsed.material_names, parsed.object_names)
    assert cached.path == path and mtl_files == [("none.mtl", 1)]

    monkeypatch.setattr(obj_module, "_read_obj_fast", parse)
    changed = write("cached.obj", path.read_text().replace("v 0.", "v 1.", 1))
    assert read_obj(changed, read_materials=False).positions[:, 0].max() > 1
    assert len(list((cache / "bvh").glob("obj-*.bin"))) == 2
    monkeypatch.setenv("GLRENDER_CACHE", "off")
    write("cached.obj", path.read_text() + "# one more line\n")
    read_obj(path, read_materials=False)
    assert len(list((cache / "bvh").glob("obj-*.bin"))) == 2


def test15_finished_meshes_of_a_cached_file_are_cached(write, tmp_path, monkeypatch):
    """The meshes of a large file (one per object and material) are kept finished under the
    file's bytes: loaded again, none is assembled or checked, and each is the same."""
    import glrender
    from glrender.scene.loaders import meshes
    from glrender.scene.loaders import obj as obj_module

    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GLRENDER_CACHE", raising=False)
    monkeypatch.setattr(obj_module, "CACHE_MIN_BYTES", 0)
    rng = np.random.default_rng(5)
    lines = [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in rng.random((2000, 3))]
    for name in ("a", "b"):
        lines += [f"usemtl {name}"] + [f"f {a} {b} {c}" for a, b, c in
                                       (rng.choice(2000, 3, replace=False) + 1 for _ in range(3000))]
    path = write("parts.obj", "\n".join(lines) + "\n")
    first = glrender.load(path).shapes
    monkeypatch.setattr(obj_module.ObjFile, "_assemble", lambda *a: pytest.fail("assembled again"))
    monkeypatch.setattr(meshes, "_finish", lambda *a: pytest.fail("finished again"))
    again = glrender.load(path).shapes
    assert [s.name for s in again] == [s.name for s in first] and len(first) == 2
    for a, b in zip(again, first):
        for name in ("vertices", "triangles", "normals"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
