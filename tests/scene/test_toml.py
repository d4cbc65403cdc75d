"""The native TOML format: every bundled scene loads, errors name file, key path and
expectation, includes, parameters, textures, disks; fuzzing of TOML and OBJ input."""
import re
import string
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m

SCENES_DIR = Path(__file__).parents[2] / "scenes"
BASE = ('[camera]\nlook_at = { origin = [0, 0, 5], target = [0, 0, 0] }\n'
        '[materials.white]\nreflectance = 0.5\n')
SPHERE = '[[shapes]]\ntype = "sphere"\nmaterial = "white"\nemission = { radiance = 1 }\n'


@pytest.mark.parametrize("path", sorted(SCENES_DIR.glob("*/scene.toml")), ids=lambda p: p.parent.name)
def test01_every_bundled_scene_loads(path, caught):
    with caught as messages:
        scene = glrender.load(path)
    assert scene.shapes and not messages


@pytest.mark.parametrize("text, message", [
    (BASE + '[materials.floor]\nalpha = "rough"\ntype = "roughconductor"\n' + SPHERE,
     'materials.floor.alpha: expected a number in [0.0001, 10], got "rough"'),
    (BASE + '[materials.x]\ntype = "velvet"\n' + SPHERE, "materials.x.type: expected one of"),
    (BASE + '[film]\nwidth = "wide"\n' + SPHERE, 'film.width: expected an integer in [1, 65536], got "wide"'),
    (BASE + SPHERE + '[[shapes]]\ntype = "mesh"\nmaterial = "white"\nfile = "gone.ply"\n',
     "shapes[1].file: no such file 'gone.ply'"),
    (BASE + SPHERE + 'foo = 1\n', "shapes[0].foo: unknown field"),
    (BASE + SPHERE + '[[shapes]]\ntype = "sphere"\nmaterial = "white"\nradius = [1]\n', "shapes[1].radius"),
    ("[film\n", "invalid TOML"),
])
def test02_errors_name_file_key_and_expectation(write, text, message):
    path = write("x.toml", text)
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    assert str(info.value).startswith(str(path)) and message in str(info.value)


def test03_includes_params_and_textures(write):
    write("materials.toml", '[params]\nshade = 0.25\n[materials.grey]\nreflectance = "$shade"\n'
                            '[textures.checks]\ntype = "checkerboard"\ncolor0 = [1, 0, 0]\nuv_scale = 8\n')
    path = write("main.toml", 'include = "materials.toml"\n[params]\nspp = 4\nshade = 0.5\n'
                              '[sampler]\nspp = "$spp"\n'
                              '[materials.floor]\nreflectance = "checks"\n'
                              '[[shapes]]\ntype = "disk"\nmaterial = "floor"\n'
                              '[[shapes]]\ntype = "rectangle"\nmaterial = "grey"\nemission = { radiance = 1 }\n'
                              '[camera]\nfov = 30\n')
    scene = glrender.load(path, spp="16")
    assert scene.sampler.spp == 16                           # the caller's value, typed as the default
    assert scene.materials[0].reflectance == (0.5, 0.5, 0.5)  # the including file's default wins
    tex = scene.materials[1].reflectance
    assert isinstance(tex, m.Texture) and tex.kind == "checkerboard" and tex.uv_transform[0, 0] == 8
    assert scene.shapes[0].kind == "mesh" and len(scene.shapes[0].triangles) == 32


def test04_include_cycle_and_unknown_parameter(write):
    write("a.toml", 'include = "b.toml"\n')
    b = write("b.toml", 'include = "a.toml"\n')
    with pytest.raises(SceneError, match="include cycle"):
        glrender.load(b)
    with pytest.raises(SceneError, match=r"sampler.spp: unknown parameter \$spp"):
        glrender.load(write("p.toml", BASE + SPHERE + '[sampler]\nspp = "$spp"\n'))


def test05_no_camera_and_no_lights(write, caught):
    path = write("n.toml", '[materials.white]\nreflectance = 0.5\n'
                           '[[shapes]]\ntype = "sphere"\nmaterial = "white"\ncenter = [10, 0, 0]\n')
    with caught as messages:
        scene = glrender.load(path)
    assert any("no camera; a default camera frames it" in w for w in messages)
    assert any("no lights" in w and "renders black" in w for w in messages)
    # the default camera looks at the sphere
    direction = scene.camera.world_from_camera[:3, 2]
    to_center = [10, 0, 0] - scene.camera.world_from_camera[:3, 3]
    assert direction @ to_center / (to_center @ to_center) ** 0.5 > 0.999
    film = glrender.render(scene, spp=1)
    assert film.mean.max() == 0.0


# ---- property-based fuzzing: any input loads or raises SceneError ---------------------------------
_SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                     suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
_TOML_PIECES = st.sampled_from([
    "[film]\n", "[camera]\n", "[materials.a]\n", "[[shapes]]\n", "[[lights]]\n", "[params]\n",
    "[textures.t]\n", "[integrator]\n", "[sampler]\n", 'type = "sphere"\n', 'type = "mesh"\n',
    'type = "roughconductor"\n', 'type = "checkerboard"\n', 'material = "a"\n', "width = 0\n",
    "width = 99999999999\n", "fov = 1e308\n", "radius = -1\n", "alpha = nan\n", "reflectance = [1, 2]\n",
    'reflectance = "t"\n', 'reflectance = "$x"\n', "x = 1\n", 'include = "self.toml"\n',
    "transform = { scale = 0 }\n", "transform = [1, 2]\n", "emission = { radiance = inf }\n",
    'type = "point"\n', 'type = "envmap"\n', "max_depth = 0\n", "spp = -3\n", 'file = "/etc/passwd"\n',
    "center = [1, 2, 3]\n", "look_at = { origin = [0, 0, 0], target = [0, 0, 0] }\n",
])


@_SETTINGS
@given(pieces=st.lists(_TOML_PIECES, max_size=12), noise=st.text(string.printable, max_size=20))
def test06_fuzz_toml(tmp_path_factory, pieces, noise):
    folder = tmp_path_factory.mktemp("fuzz")
    path = folder / "self.toml"
    path.write_text("".join(pieces) + noise)
    try:
        glrender.load(path)
    except SceneError:
        pass


_OBJ_LINES = st.sampled_from([
    "v 0 0 0", "v 1 0 0", "v 0 1 0", "v 1e39 0 0", "v nan 0 0", "v 1", "vt 0.5 0.5", "vn 0 0 1",
    "f 1 2 3", "f -1 -2 -3", "f 1/1 2/1 3/1", "f 1//1 2//1 3//1", "f 1 2", "f 0 1 2", "f 9 1 2",
    "f 1/2/3/4 1 1", "f -9 1 2", "usemtl x", "mtllib none.mtl", "o thing", "g", "s off", "f 1 1 1",
    "f 1 2 3 4 5 6", "#", "", "\t", "vt", "f a b c",
])


@_SETTINGS
@given(lines=st.lists(_OBJ_LINES, max_size=20), noise=st.text(string.printable, max_size=12))
def test07_fuzz_obj(tmp_path_factory, lines, noise):
    path = tmp_path_factory.mktemp("fuzz") / "f.obj"
    path.write_text("\n".join(lines) + "\n" + noise)
    try:
        glrender.load(path)
    except SceneError:
        pass


def test08_include_depth_is_bounded_and_paths_outside_are_refused(write):
    for i in range(20):
        write(f"d{i}.toml", f'include = "d{i + 1}.toml"\n' if i < 19 else BASE + SPHERE)
    with pytest.raises(SceneError, match="deeper than 16"):
        glrender.load(write("d0.toml", 'include = "d1.toml"\n'))
    outer = write("shared.toml", BASE + SPHERE)
    inner = write("scene/main.toml", 'include = "../shared.toml"\n')
    with pytest.raises(SceneError, match=r"main\.toml: include\[0\]: file '\.\./shared\.toml' "
                                         rf"resolves to {re.escape(str(outer))}, outside"):
        glrender.load(inner)
    assert glrender.load(inner, search_path=[outer.parent]).shapes


def test10_translation_only_transforms_equal_the_matrix_product_bitwise():
    """transform_points / transform_normals skip the product for translation-only matrices;
    the result is the product's, bit for bit (signed zeros, tiny and huge values)."""
    rng = np.random.default_rng(0)
    p = rng.choice([0.0, -0.0, 1.5, -2.0, 1e-300, -3e300], size=(5000, 3))
    for t in ([0.0, 0.0, 0.0], [-0.0, -0.0, 0.0], [1.0, -0.0, 2.0]):
        M = np.eye(4)
        M[:3, 3] = t
        expected = p @ M[:3, :3].T + M[:3, 3]
        assert np.array_equal(m.transform_points(M, p).view(np.uint64), expected.view(np.uint64))
        with np.errstate(over="ignore"):
            n = p @ np.linalg.inv(M[:3, :3])
            length = np.linalg.norm(n, axis=-1, keepdims=True)
            expected = n / np.where(length > 0, length, 1.0)
            got = m.transform_normals(M, p)
        assert np.array_equal(got.view(np.uint64), expected.view(np.uint64))


def test11_metallicroughness_material(write):
    """type = "metallicroughness" with a metallic_roughness colour (blue metallic, green
    roughness): the device meets the kinds the rule can pick, and the plastic's IOR is the
    rule's 1.5 whatever int_ior says."""
    from glrender.gpu.pack import pack_scene

    path = write("mr.toml", """
[materials.metal]
type = "metallicroughness"
reflectance = [0.8, 0.5, 0.3]
metallic_roughness = [0.0, 0.4, 1.0]
[materials.plastic]
type = "metallicroughness"
metallic_roughness = [0.0, 0.01, 0.2]
[[shapes]]
type = "rectangle"
material = "metal"
[[shapes]]
type = "rectangle"
material = "plastic"
transform = [{ translate = [0, 0, 1] }]
""")
    scene = glrender.load(path)
    packed = pack_scene(scene)
    assert packed.material_kinds == {"metallicroughness", "roughconductor", "plastic"}
    np.testing.assert_allclose(packed.materials["params"][:, 2], 1.5)
    np.testing.assert_allclose(packed.materials["color1"][0], [0.0, 0.4, 1.0], rtol=1e-6)
