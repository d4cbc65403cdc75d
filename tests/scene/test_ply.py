"""PLY: ASCII and binary against known counts, lists of mixed length, hostile headers."""
import time

import numpy as np
import pytest

from glrender.errors import SceneError
from glrender.scene.loaders.ply import read_ply

from conftest import DATA


def _header(fmt, nv, nf, extra_vertex="", face="property list uchar int vertex_indices"):
    return (f"ply\nformat {fmt} 1.0\ncomment test\nelement vertex {nv}\nproperty float x\n"
            f"property float y\nproperty float z\n{extra_vertex}element face {nf}\n{face}\nend_header\n")


@pytest.mark.parametrize("name, vertices, triangles", [("teapot.ply", 1177, 2256),
                                                        ("bunny_lowres.ply", 453, 948)])
def test01_ascii_counts_match_the_sources(name, vertices, triangles):
    mesh = read_ply(DATA / "meshes" / name)
    assert mesh.vertices.shape == (vertices, 3) and mesh.triangles.shape == (triangles, 3)
    length = np.linalg.norm(mesh.normals, axis=1)
    # unit, or 0 where the faces around a vertex cancel (a fold in the scan): the renderer
    # uses the face normal there
    assert np.all(np.isclose(length, 1.0) | (length == 0)) and np.mean(length == 0) < 0.01


@pytest.mark.parametrize("order", ["<", ">"])
def test02_binary_with_normals_uvs_and_polygons(write, order):
    fmt = "binary_little_endian" if order == "<" else "binary_big_endian"
    extra = "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
    v = np.array([[0, 0, 0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0, 1, 1, 0], [1, 1, 0, 0, 0, 1, 1, 1],
                  [0, 1, 0, 0, 0, 1, 0, 1]], order + "f4")
    faces = (np.array([4], "u1").tobytes() + np.array([0, 1, 2, 3], order + "i4").tobytes() +
             np.array([3], "u1").tobytes() + np.array([0, 2, 3], order + "i4").tobytes())
    path = write("q.ply", _header(fmt, 4, 2, extra).encode() + v.tobytes() + faces)
    mesh = read_ply(path)
    np.testing.assert_array_equal(mesh.triangles, [[0, 1, 2], [0, 2, 3], [0, 2, 3]])
    np.testing.assert_allclose(mesh.uvs, v[:, 6:8])          # PLY uv used as written
    np.testing.assert_allclose(mesh.normals, v[:, 3:6])


def test03_uniform_binary_faces_read_in_one_view(write):
    n = 20000
    v = np.random.default_rng(0).random((n, 3)).astype("<f4")
    f = np.random.default_rng(1).integers(0, n, (n, 3)).astype("<i4")
    rec = np.zeros(n, [("n", "u1"), ("i", "<i4", (3,))])
    rec["n"], rec["i"] = 3, f
    path = write("u.ply", _header("binary_little_endian", n, n).encode() + v.tobytes() + rec.tobytes())
    mesh = read_ply(path)
    assert len(mesh.triangles) <= n and np.array_equal(mesh.vertices, v.astype(np.float64))


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test04_header_claiming_a_trillion_vertices_fails_before_allocating(write, fmt):
    body = b"0 0 0\n" if fmt == "ascii" else np.zeros(3, "<f4").tobytes()
    path = write("huge.ply", _header(fmt, 10 ** 12, 1).encode() + body)
    start = time.perf_counter()
    with pytest.raises(SceneError, match="declares 1000000000000 records"):
        read_ply(path)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test05_truncated_file(write, fmt):
    if fmt == "ascii":
        body = b"0 0 0\n1 0 0\n0 1 0\n3 0 1"
    else:
        body = np.zeros(9, "<f4").tobytes() + b"\x03" + np.array([0, 1], "<i4").tobytes()
    path = write("t.ply", _header(fmt, 3, 1).encode() + body)
    with pytest.raises(SceneError, match="truncated"):
        read_ply(path)


@pytest.mark.parametrize("body, message", [
    ("0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "outside [0, 3)"),
    ("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "NaN"),
    ("0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "not a number"),
])
def test06_bad_values(write, body, message):
    path = write("b.ply", _header("ascii", 3, 1) + body)
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace(")", r"\)")):
        read_ply(path)


def test07_not_a_ply(write):
    with pytest.raises(SceneError, match="not a PLY file"):
        read_ply(write("x.ply", "hello\n"))


def test08_a_large_file_is_finished_once(write, tmp_path, monkeypatch):
    """A file of meshes.CACHE_MIN_FILE_BYTES or more is kept finished under its bytes: read
    again, it is neither parsed nor checked, its arrays and its warning about zero-area
    triangles are the same, and its SHA-256 (taken once) is what the scene records; a damaged
    entry is finished again, a changed byte is another file."""
    import hashlib
    import warnings

    import glrender
    from glrender.accel import disk_cache
    from glrender.scene.loaders import meshes, ply

    cache = tmp_path / "cache"
    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(cache))
    monkeypatch.delenv("GLRENDER_CACHE", raising=False)
    monkeypatch.setattr(ply, "CACHE_MIN_FILE_BYTES", 0)
    rng = np.random.default_rng(3)
    v = rng.random((50, 3)).astype("<f4")
    f = np.array([rng.choice(50, 3, replace=False) for _ in range(80)] + [[1, 1, 2]], "<i4")   # one zero-area
    faces = np.zeros(len(f), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    faces["n"], faces["i"] = 3, f
    path = write("blob.ply", _header("binary_little_endian", 50, len(f)).encode() + v.tobytes() +
                 faces.tobytes())

    def load():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = glrender.load(path)
        dropped = [str(w.message) for w in caught if "zero-area" in str(w.message)]
        return scene.shapes[0], dropped, scene.files

    first, warned, files = load()
    assert warned == [f"{path}: dropped 1 zero-area triangle of {len(f)}"]
    assert files[str(path)] == hashlib.sha256(path.read_bytes()).hexdigest()
    [entry] = cache.glob("bvh/mesh-*.bin")
    parse, finish = ply._parse, meshes._finish
    monkeypatch.setattr(ply, "_parse", lambda *a: pytest.fail("parsed again"))
    monkeypatch.setattr(meshes, "_finish", lambda *a: pytest.fail("finished again"))
    again, warned_again, files_again = load()
    assert warned_again == warned and files_again == files
    for name in ("vertices", "triangles", "normals"):
        a, b = getattr(again, name), getattr(first, name)
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    monkeypatch.setattr(ply, "_parse", parse)
    monkeypatch.setattr(meshes, "_finish", finish)
    damaged = bytearray(entry.read_bytes())
    damaged[-1] ^= 0x40                               # the last byte of the payload
    entry.write_bytes(bytes(damaged))
    rebuilt, _, _ = load()
    np.testing.assert_array_equal(rebuilt.normals, first.normals)
    assert disk_cache.load("mesh", entry.name[5:-4], meshes.FINISH_VERSION) is not None   # replaced
    v[0, 0] += 1                                      # another vertex: another file
    write("blob.ply", _header("binary_little_endian", 50, len(f)).encode() + v.tobytes() +
          faces.tobytes())
    assert load()[2][str(path)] != files[str(path)]
    assert len(list(cache.glob("bvh/mesh-*.bin"))) == 2
