"""The on-disk cache of built BVHs and recomputed normals (glrender/accel/disk_cache.py,
bvh_cache.py): a hit gives the bytes a build gives, an entry is trusted only whole and of the
same builder and parameters, the folder stays under its cap by LRU, and a cache that is off
or unwritable changes nothing but the time."""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from bvh_reference import icosphere, random_soup

from glrender.accel import MotionInstance, build_bvh, bvh_cache, disk_cache
from glrender.scene.loaders import meshes


@pytest.fixture
def cache(tmp_path, monkeypatch, request):
    """An empty cache folder of its own, and every mesh large enough to be cached: every BVH,
    and every finished mesh (normals) unless the test's module sets
    ``CACHE_FINISHED_MESHES = False`` (tests/gpu/test_mesh_cache.py imports this fixture)."""
    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GLRENDER_CACHE", raising=False)
    monkeypatch.delenv("GLRENDER_CACHE_SIZE", raising=False)
    monkeypatch.setattr(bvh_cache, "MIN_TRIANGLES", 0)
    if getattr(request.module, "CACHE_FINISHED_MESHES", True):
        monkeypatch.setattr(meshes, "CACHE_MIN_TRIANGLES", 0)
    monkeypatch.setattr(disk_cache, "_warned", set())
    return tmp_path / "cache" / "bvh"


def soup(seed=1, count=600):
    return random_soup(np.random.default_rng(seed), count, spread=3.0, size=0.4)


def moving():
    v, f = icosphere(2)
    open_ = np.hstack([np.eye(3), [[0.5], [2.5], [1.0]]])
    close = np.hstack([np.diag([1.0, 0.6, 1.4]), [[2.5], [2.5], [1.0]]])
    return [MotionInstance(v * 0.4, f, open_, close)]


def assert_same(a, b):
    assert sorted(a.packed) == sorted(b.packed)
    for name in a.packed:
        assert a.packed[name].dtype == b.packed[name].dtype, name
        np.testing.assert_array_equal(a.packed[name], b.packed[name], err_msg=name)
    assert len(a.prim_orders) == len(b.prim_orders)
    for x, y in zip(a.prim_orders, b.prim_orders):
        assert x.dtype == y.dtype
        np.testing.assert_array_equal(x, y)
    assert (a.width, a.depth) == (b.width, b.depth)
    timeless = [{k: v for k, v in x.build_stats.items() if k != "build_seconds"} for x in (a, b)]
    assert timeless[0] == timeless[1]


def entries(folder):
    return sorted(folder.glob("*.bin")) if folder.exists() else []


@pytest.mark.parametrize("width", [4, 8])
def test01_a_hit_gives_the_build_bit_for_bit(cache, width):
    v, f = soup()
    fresh = build_bvh(v, f, motion=moving(), width=width).buffers()
    first, how = bvh_cache.build_bvh_buffers(v, f, motion=moving(), width=width)
    assert how == "miss" and len(entries(cache)) == 1
    again, how = bvh_cache.build_bvh_buffers(v, f, motion=moving(), width=width)
    assert how == "hit"
    for result in (first, again):
        assert_same(result, fresh)
    assert not list(cache.glob("*.tmp"))          # the temporary file became the entry


def damage(path, how):
    data = bytearray(path.read_bytes())
    if how == "truncated":
        data = data[:len(data) // 2]
    elif how == "empty":
        data = data[:0]
    else:   # one byte flipped: in the magic, the CRC, the header, the payload or its last byte
        _, _, header_bytes = disk_cache.PREFIX.unpack_from(data)
        payload = -(-(disk_cache.PREFIX.size + header_bytes) // disk_cache.ALIGN) * disk_cache.ALIGN
        at = {"magic": 0, "crc": 9, "header": disk_cache.PREFIX.size + 10, "payload": payload + 100,
              "last": len(data) - 1}[how]
        data[at] ^= 0x40
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("how", ["truncated", "empty", "magic", "crc", "header", "payload", "last"])
def test02_a_damaged_entry_is_rebuilt_and_replaced(cache, how):
    v, f = soup()
    good, _ = bvh_cache.build_bvh_buffers(v, f)
    [path] = entries(cache)
    damage(path, how)
    rebuilt, status = bvh_cache.build_bvh_buffers(v, f)
    assert status == "miss"
    assert_same(rebuilt, good)
    again, status = bvh_cache.build_bvh_buffers(v, f)
    assert status == "hit" and entries(cache) == [path]
    assert_same(again, good)


def test03_another_builder_version_parameter_or_input_misses(cache, monkeypatch):
    v, f = soup()
    bvh_cache.build_bvh_buffers(v, f)
    assert bvh_cache.build_bvh_buffers(v, f, threads=1)[1] == "hit"   # threads: the same tree
    for options in ({"max_leaf_size": 2}, {"width": 8}, {"method": "binned_sah"}, {"radius": 8},
                    {"remove_duplicates": False}, {"c_tri": 1.5}, {"motion": moving()}):
        assert bvh_cache.build_bvh_buffers(v, f, **options)[1] == "miss", options
    moved = v.copy()
    moved[7, 1] = np.nextafter(moved[7, 1], np.float32(np.inf))   # one vertex, one ulp
    assert bvh_cache.build_bvh_buffers(moved, f)[1] == "miss"
    assert bvh_cache.build_bvh_buffers(v, f.astype(np.int32))[1] == "miss"   # another dtype
    turned = moving()
    turned[0].world_from_object_close[0, 3] += 1e-9
    assert bvh_cache.build_bvh_buffers(v, f, motion=turned)[1] == "miss"
    count = len(entries(cache))
    monkeypatch.setattr(bvh_cache, "BUILDER_VERSION", bvh_cache.BUILDER_VERSION + 1)
    assert bvh_cache.build_bvh_buffers(v, f)[1] == "miss"
    assert len(entries(cache)) == count + 1


def test04_an_entry_under_another_version_or_key_is_not_trusted(cache):
    """The file name is not the proof: an entry copied to another key's name, or read as
    another version, is a miss."""
    arrays = {"x": np.arange(10.0)}
    disk_cache.store("normals", "a" * 64, 1, arrays, {})
    [path] = entries(cache)
    assert disk_cache.load("normals", "a" * 64, 1) is not None
    assert disk_cache.load("normals", "a" * 64, 2) is None
    os.replace(path, cache / f"normals-{'b' * 64}.bin")
    assert disk_cache.load("normals", "b" * 64, 1) is None


@pytest.mark.parametrize("value", ["off", "OFF", "0", "false"])
def test05_off_reads_and_writes_nothing(cache, monkeypatch, tmp_path, value):
    monkeypatch.setenv("GLRENDER_CACHE", value)
    v, f = soup()
    result, status = bvh_cache.build_bvh_buffers(v, f)
    assert status == "uncached"
    mesh = meshes.finish_mesh(meshes.MeshData(*icosphere(3)), "sphere")
    assert mesh.normals is not None
    assert not (tmp_path / "cache").exists()


def test06_the_cap_evicts_the_least_recently_used(cache, monkeypatch):
    block = np.zeros(1 << 16, np.uint8)            # 64 KiB and a header: one entry
    monkeypatch.setenv("GLRENDER_CACHE_SIZE", str(3 * block.nbytes + 3 * 4096))
    past = 1_000_000_000
    for k, name in enumerate("abc"):
        disk_cache.store("normals", name * 64, 1, {"x": block}, {})
        os.utime(cache / f"normals-{name * 64}.bin", (past + k, past + k))   # a, then b, then c
    assert disk_cache.load("normals", "a" * 64, 1) is not None            # a used: now newest
    disk_cache.store("normals", "d" * 64, 1, {"x": block}, {})
    assert [p.name[8] for p in entries(cache)] == ["a", "c", "d"]          # b went
    monkeypatch.setenv("GLRENDER_CACHE_SIZE", "100K")
    disk_cache.store("normals", "e" * 64, 1, {"x": block}, {})
    assert [p.name[8] for p in entries(cache)] == ["e"]
    disk_cache.store("normals", "f" * 64, 1, {"x": np.zeros(1 << 17, np.uint8)}, {})   # over the cap alone
    assert [p.name[8] for p in entries(cache)] == ["e"]


@pytest.mark.parametrize("text, limit", [("2G", 2 << 30), ("500M", 500 << 20), ("1048576", 1 << 20),
                                         ("1.5 GiB", 3 << 29), ("64k", 64 << 10)])
def test07_size_limit_reads_sizes(monkeypatch, text, limit):
    monkeypatch.setenv("GLRENDER_CACHE_SIZE", text)
    assert disk_cache.size_limit() == limit


def test08_an_unreadable_size_or_unwritable_folder_warns_once_and_renders_on(cache, tmp_path,
                                                                               monkeypatch):
    monkeypatch.setenv("GLRENDER_CACHE_SIZE", "lots")
    with pytest.warns(RuntimeWarning, match="GLRENDER_CACHE_SIZE='lots'"):
        assert disk_cache.size_limit() == disk_cache.DEFAULT_SIZE
    monkeypatch.delenv("GLRENDER_CACHE_SIZE")
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(blocker))
    v, f = soup()
    fresh = build_bvh(v, f).buffers()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(2):
            result, status = bvh_cache.build_bvh_buffers(v, f)
            assert status == "miss"
        meshes.finish_mesh(meshes.MeshData(*icosphere(3)), "sphere")
    assert len(caught) == 1 and "cannot write the BVH cache" in str(caught[0].message)
    assert_same(result, fresh)


def test09_recomputed_normals_are_cached(cache):
    v, f = icosphere(3)
    first = meshes.finish_mesh(meshes.MeshData(v, f), "sphere")
    [path] = entries(cache)
    assert path.name.startswith("normals-")
    again = meshes.finish_mesh(meshes.MeshData(v, f), "sphere")
    np.testing.assert_array_equal(again.normals, first.normals)
    np.testing.assert_array_equal(first.normals, meshes.vertex_normals(v, f))
    damage(path, "payload")
    rebuilt = meshes.finish_mesh(meshes.MeshData(v, f), "sphere")
    np.testing.assert_array_equal(rebuilt.normals, first.normals)
    given = meshes.finish_mesh(meshes.MeshData(v, f, normals=-first.normals), "sphere")
    np.testing.assert_array_equal(given.normals, -first.normals)     # a file's own normals win


def write_ply(path, v, f):
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(f), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    faces["n"], faces["i"] = 3, f
    path.write_bytes(header.encode() + np.asarray(v, "<f4").tobytes() + faces.tobytes())


def test10_a_cached_scene_uploads_the_same_bytes_and_renders_the_same_image(cache, gl_ctx,
                                                                              tmp_path, monkeypatch):
    """A small mesh scene (a PLY without normals, so both kinds of entry are made) rendered
    with the cache off, on and empty (misses), and on again (hits): the same device buffers
    and the same image, bit for bit."""
    import glrender
    from glrender.gpu.device_scene import DeviceScene
    from glrender.scene import model as m

    v, f = icosphere(4)
    v = v * (1 + 0.1 * np.sin(7 * v[:, :1]))       # not a sphere: normals that differ per vertex
    mesh = tmp_path / "blob.ply"
    write_ply(mesh, v, f)

    def run(setting):
        monkeypatch.setenv("GLRENDER_CACHE", setting)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")       # no camera, no lights: both added here
            scene = glrender.load(mesh)
        scene.film.width = scene.film.height = 16
        scene.lights.append(m.Light("constant", radiance=(1.0, 1.0, 1.0)))
        device = DeviceScene(gl_ctx, scene)
        try:
            textures = [part for kinds in (device.bvh.textures, device.shading) for t in kinds.values()
                        for part in t.parts] + [device.bvh.instances]
            uploaded = [t.buffer.read() for t in textures]
            status = device.bvh_cache
        finally:
            device.release()
        film = glrender.render(scene, spp=4, seed=7, progress=False)
        return status, uploaded, film.mean.copy()

    off = run("off")
    miss = run("on")
    assert sorted(p.name.rsplit("-", 1)[0] for p in entries(cache)) == ["bvh", "device-mesh", "normals"]
    hit = run("on")
    assert (off[0], miss[0], hit[0]) == ("uncached", "miss", "hit")
    for other in (miss, hit):
        assert len(other[1]) == len(off[1]) == 6
        assert all(a == b for a, b in zip(other[1], off[1]))
        np.testing.assert_array_equal(other[2], off[2])


def test11_stats_say_where_the_bvh_came_from(tmp_path):
    """``--stats`` records ``bvh_cache``: built and stored, then read back; built with the
    cache off; none for a scene without BVH triangles. The command runs as users run it, in
    its own process, on a mesh large enough to be cached (81,920 triangles)."""
    import json
    import subprocess
    import sys

    mesh = tmp_path / "ball.ply"
    write_ply(mesh, *icosphere(6))
    stats = tmp_path / "stats.json"
    env = {**os.environ, "GLRENDER_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("GLRENDER_CACHE", None)

    def bvh_cache_of(scene, **extra):
        subprocess.run([sys.executable, "-m", "glrender", "render", str(scene), "--spp", "1",
                        "--width", "8", "-o", str(tmp_path / "o.png"), "--stats", str(stats),
                        "--quiet"], env={**env, **extra}, check=True, timeout=300)
        return json.loads(stats.read_text())["bvh_cache"]

    assert [bvh_cache_of(mesh) for _ in range(2)] == ["miss", "hit"]
    assert bvh_cache_of(mesh, GLRENDER_CACHE="off") == "uncached"
    cornell = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"
    assert bvh_cache_of(cornell) == "none"
