"""The device-ready mesh cache (glrender/gpu/mesh_cache.py): a hit uploads the bytes packing
and gathering give, skips the shapes it holds and nothing else, is keyed by every input that
decides the arrays, and a damaged or foreign entry is packed afresh and replaced."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

from glrender.accel import bvh_cache, disk_cache
from glrender.gpu import codegen, mesh_cache, pack
from glrender.gpu.device_scene import DeviceScene
from glrender.scene import model as m

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "accel"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))
from bvh_reference import icosphere  # noqa: E402
from render_scenes import base  # noqa: E402
from test_bvh_cache import cache, damage, entries  # noqa: E402, F401 (cache: a fixture)

# the cache fixture: every BVH cached, finished meshes (normals) at their own threshold
CACHE_FINISHED_MESHES = False


def mesh_scene() -> m.Scene:
    """Two BVH meshes (one with uvs and its own normals, one flat-shaded and mirrored)
    between a rectangle, a sphere and a two-triangle mesh that is compiled into the kernel."""
    scene = base(16, 16)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5)))
    red = scene.add_material(m.Material("roughconductor", alpha=0.2))
    v, f = icosphere(3)
    v = v * (1 + 0.1 * np.sin(7 * v[:, :1]))
    uv = np.stack([v[:, 0], v[:, 2]], axis=1)
    scene.shapes.append(m.Shape("rectangle", material=grey, emission=m.Emission((4.0, 4.0, 4.0)),
                                world_from_object=m.translate((0.0, 0.0, 3.0))))
    scene.shapes.append(m.Shape("mesh", material=red, vertices=v, triangles=f, normals=v, uvs=uv))
    scene.shapes.append(m.Shape("sphere", material=grey, radius=0.3, center=(1.5, 0.0, 0.0)))
    scene.shapes.append(m.Shape("mesh", material=grey, vertices=v, triangles=f, face_normals=True,
                                world_from_object=m.translate((-2.0, 0.0, 0.0)) @ np.diag([-1.0, 1, 1, 1])))
    scene.shapes.append(m.Shape("mesh", material=grey, vertices=v[:4], triangles=np.array([[0, 1, 2], [0, 2, 3]])))
    return scene


def device_data(gl_ctx, scene):
    """What a device scene of ``scene`` uploads and generates, and whether the mesh cache
    held its BVH triangles."""
    device = DeviceScene(gl_ctx, scene)
    try:
        p = device.packed
        parted = list(device.bvh.textures.values()) + list(device.shading.values())
        textures = [part for t in parted for part in t.parts] + [t for t in device._owned if hasattr(t, "buffer")]
        if device.bvh.instances is not None:
            textures.append(device.bvh.instances)
        return {"buffers": [t.buffer.read() for t in textures],
                "quads": repr(p.quads), "spheres": repr(p.spheres), "bounds": repr(p.bounds),
                "lights": p.lights.tobytes(), "source": codegen.generate(p, has_bvh=p.has_bvh),
                "hit": p.cached_mesh is not None}
    finally:
        device.release()


def test01_a_hit_uploads_what_packing_gives(cache, gl_ctx, monkeypatch):
    """Cache off, on and empty, on again: the same buffers, compiled primitives, bounds and
    kernel geometry, bit for bit; the hit from the one device-mesh entry."""
    monkeypatch.setenv("GLRENDER_CACHE", "off")
    off = device_data(gl_ctx, mesh_scene())
    monkeypatch.setenv("GLRENDER_CACHE", "on")
    miss = device_data(gl_ctx, mesh_scene())
    assert sorted(p.name.rsplit("-", 1)[0] for p in entries(cache)) == ["bvh", "device-mesh"]
    hit = device_data(gl_ctx, mesh_scene())
    assert (off["hit"], miss["hit"], hit["hit"]) == (False, False, True)
    assert len(off["buffers"]) == 6
    for other in (miss, hit):
        assert {k: v for k, v in other.items() if k != "hit"} == \
            {k: v for k, v in off.items() if k != "hit"}


def test02_renders_and_fingerprints_agree(cache, monkeypatch):
    """A render from the cached arrays is the render of the packed ones, and so is the
    fingerprint a checkpoint records."""
    import glrender

    def run():
        r = glrender.Renderer(mesh_scene(), spp=4, seed=3)
        try:
            r.step(4)
            return r.film().mean.copy(), r.fingerprint(), r.packed.cached_mesh is not None
        finally:
            r.release()

    monkeypatch.setenv("GLRENDER_CACHE", "off")
    off = run()
    monkeypatch.setenv("GLRENDER_CACHE", "on")
    run()
    hit = run()
    assert hit[2] and not off[2]
    np.testing.assert_array_equal(hit[0], off[0])
    assert hit[1] == off[1]


@pytest.mark.parametrize("how", ["truncated", "empty", "magic", "crc", "header", "payload", "last"])
def test03_a_damaged_entry_is_packed_again_and_replaced(cache, gl_ctx, how):
    good = device_data(gl_ctx, mesh_scene())
    [path] = [p for p in entries(cache) if p.name.startswith("device-mesh-")]
    damage(path, how)
    rebuilt = device_data(gl_ctx, mesh_scene())
    assert not rebuilt["hit"] and rebuilt == good
    again = device_data(gl_ctx, mesh_scene())
    assert again["hit"] and {k: v for k, v in again.items() if k != "hit"} == \
        {k: v for k, v in good.items() if k != "hit"}


def test04_an_entry_that_does_not_read_is_packed_again(cache, gl_ctx, monkeypatch):
    """Whole and of the right key, but not what store() writes (texel arrays of another
    length than its triangle count): a miss."""
    real = disk_cache.store

    def short(kind, key, version, arrays, meta):
        real(kind, key, version, {**arrays, "uvs": arrays["uvs"][:-1]} if kind == mesh_cache.KIND
             else arrays, meta)
    monkeypatch.setattr(disk_cache, "store", short)
    good = device_data(gl_ctx, mesh_scene())
    monkeypatch.setattr(disk_cache, "store", real)
    again = device_data(gl_ctx, mesh_scene())
    assert not again["hit"] and again == good
    assert device_data(gl_ctx, mesh_scene())["hit"]


def changed(what):
    scene = mesh_scene()
    shapes = scene.shapes
    if what == "vertex":
        v = shapes[1].vertices.copy()
        v[5, 1] = np.nextafter(v[5, 1], np.inf)          # one vertex, one ulp
        shapes[1] = dataclasses.replace(shapes[1], vertices=v)
    elif what == "transform":
        M = shapes[3].world_from_object.copy()
        M[1, 3] += 1e-12
        shapes[3] = dataclasses.replace(shapes[3], world_from_object=M)
    elif what == "material":
        shapes[3] = dataclasses.replace(shapes[3], material=1)
    elif what in ("flip_normals", "face_normals"):
        shapes[1] = dataclasses.replace(shapes[1], **{what: True})
    elif what == "no uvs":
        shapes[1] = dataclasses.replace(shapes[1], uvs=None)
    elif what == "index dtype":
        shapes[1] = dataclasses.replace(shapes[1], triangles=shapes[1].triangles.astype(np.int32))
    elif what == "cutout":
        scene.materials[1] = dataclasses.replace(scene.materials[1], opacity=m.Texture("checkerboard"))
    elif what == "budget":     # the small mesh is compiled, or not, by the primitives before it
        shapes.insert(0, m.Shape("cube", material=0))
    return scene


@pytest.mark.parametrize("what", ["vertex", "transform", "material", "flip_normals", "face_normals",
                                  "no uvs", "index dtype", "cutout", "budget", "version"])
def test05_any_input_of_the_arrays_changes_the_key(cache, monkeypatch, what):
    first = pack.pack_scene(mesh_scene()).mesh_slot
    assert first is not None
    assert pack.pack_scene(mesh_scene()).mesh_slot.key == first.key
    if what == "version":
        monkeypatch.setattr(pack, "PACKER_VERSION", pack.PACKER_VERSION + 1)
    assert pack.pack_scene(changed(what)).mesh_slot.key != first.key


@pytest.mark.parametrize("what", ["emitting", "moving"])
def test06_emitting_or_moving_bvh_triangles_are_not_kept(cache, gl_ctx, what):
    """Emissive BVH triangles add lights as they are packed, a moving mesh has a tree of
    its own: such scenes keep their BVH entries only."""
    scene = mesh_scene()
    if what == "emitting":
        scene.shapes[1] = dataclasses.replace(scene.shapes[1], emission=m.Emission((1.0, 1.0, 1.0)))
    else:
        shape = scene.shapes[3]
        scene.shapes[3] = dataclasses.replace(
            shape, world_from_object_close=m.translate((0.0, 0.5, 0.0)) @ shape.world_from_object)
    device_data(gl_ctx, scene)
    assert [p.name.rsplit("-", 1)[0] for p in entries(cache)] == ["bvh"]
    assert not device_data(gl_ctx, scene)["hit"]


def test07_off_or_small_reads_and_writes_nothing(cache, gl_ctx, monkeypatch):
    monkeypatch.setattr(bvh_cache, "MIN_TRIANGLES", 10 ** 6)
    assert pack.pack_scene(mesh_scene()).mesh_slot is None
    monkeypatch.setattr(bvh_cache, "MIN_TRIANGLES", 0)
    monkeypatch.setenv("GLRENDER_CACHE", "off")
    device_data(gl_ctx, mesh_scene())
    assert entries(cache) == []
