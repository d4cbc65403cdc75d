"""Instanced meshes (``Shape.instances``) through the two-level BVH render what their
flattened copies render: glossy and diffuse copies of a smooth mesh under rotations,
non-uniform scales and mirror images (normals through the inverse transpose), beside a
mesh moving over the shutter, on a floor under an area light and a sky, by the path tracer and bdpt (light subpaths hit the copies
too), per 8-pixel block at a Šidák-corrected alpha of 0.01 over every block, channel and
case of this file, sigma from the seeds. Small copies are flattened; the wavefront executor
refuses instanced meshes in one line."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import glrender
from glrender.errors import UsageError
from glrender.gpu import pack
from glrender.scene import model as m
from glrender.testing.images import compare_images

from render_scenes import base

SEEDS_FLAT, SEEDS_INSTANCED = tuple(range(11, 17)), tuple(range(21, 27))
BLOCK = 8
CASES = [("path", 32), ("bdpt", 16)]
COPIES = 5 * 5


def copies_scene(size=32) -> m.Scene:
    rng = np.random.default_rng(7)
    scene = base(size, size, max_depth=4)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, -9, 6), (0, 0, 0.3), (0, 0, 1)), fov=45)
    floor = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5)))
    glossy = scene.add_material(m.Material("roughconductor", eta=(0.2, 0.9, 1.1), k=(3.9, 2.4, 2.2),
                                           alpha=(0.25, 0.25), distribution="ggx"))
    white = scene.add_material(m.Material("diffuse", reflectance=(0.7, 0.3, 0.2)))
    scene.shapes.append(m.Shape("rectangle", material=floor, world_from_object=m.scale((8.0, 8.0, 1.0))))
    ball = trimesh.creation.icosphere(subdivisions=3)
    bump = trimesh.creation.capsule(height=1.0, radius=0.5, count=(16, 16))
    for material, mesh, offset in ((glossy, ball, 0.0), (white, bump, 0.6)):
        transforms = []
        for k in range(COPIES):
            q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
            linear = q @ np.diag(rng.uniform(0.25, 0.6, 3))
            if k % 4 == 0:
                linear = linear @ np.diag([1.0, 1.0, -1.0])        # a mirror image
            t = np.eye(4)
            t[:3, :3] = linear
            t[:3, 3] = (-5 + 2.2 * (k % 5) + offset, -4 + 2.0 * (k // 5) + offset, 0.5)
            transforms.append(t)
        scene.shapes.append(m.Shape("mesh", material=material, vertices=np.asarray(mesh.vertices),
                                    triangles=np.asarray(mesh.faces),
                                    normals=np.asarray(mesh.vertex_normals),
                                    instances=np.stack(transforms)))
    # a mesh moving over the shutter beside them: its tree and the instances' in one query
    scene.shutter = m.Shutter(open=0.0, close=1.0)
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    scene.shapes.append(m.Shape("mesh", material=white, vertices=np.asarray(box.vertices),
                                triangles=np.asarray(box.faces), face_normals=True,
                                world_from_object=m.translate((3.5, 3.0, 0.5)),
                                world_from_object_close=m.translate((4.5, 3.0, 1.0)) @ m.rotate((0, 0, 1), 40)))
    black = scene.add_material(m.Material("diffuse", reflectance=(0.0, 0.0, 0.0)))
    scene.shapes.append(m.Shape("rectangle", material=black, emission=m.Emission((12.0, 11.0, 9.0)),
                                world_from_object=m.look_at((2, -2, 5), (0, 0, 0), (0, 0, 1)) @ m.scale(0.8)))
    scene.lights.append(m.Light("constant", radiance=(0.05, 0.07, 0.1)))
    return scene


def renders(scene, integrator, spp, seeds):
    return np.stack([glrender.render(scene, spp=spp, integrator=integrator, seed=seed, progress=False,
                                     sampler="independent").mean for seed in seeds])


def block_tests(scene):
    f = scene.film
    return 3 * -(-f.width // BLOCK) * -(-f.height // BLOCK) + 2


@pytest.mark.parametrize("integrator, spp", CASES)
def test01_instanced_matches_flattened(gl_ctx, monkeypatch, integrator, spp):
    scene = copies_scene()
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 0)     # small meshes, instanced
    assert len(pack.pack_scene(scene).instanced_meshes) == 2
    instanced = renders(scene, integrator, spp, SEEDS_INSTANCED)
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 1 << 62)
    assert not pack.pack_scene(scene).instanced_meshes
    flat = renders(scene, integrator, spp, SEEDS_FLAT)
    ref, ref_se = flat.mean(axis=0), flat.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_FLAT))
    extra = (len(CASES) - 1) * block_tests(scene)
    # bdpt's light subpaths splat onto any pixel: its image mean's sigma comes from the seeds
    c = compare_images(instanced, ref, ref_se, block=BLOCK, extra_tests=extra,
                       correlated_pixels=integrator == "bdpt")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.05, c.summary()


def test02_small_copies_are_flattened_and_emitters_always(monkeypatch):
    scene = copies_scene()
    shape = scene.shapes[1]
    extra = (COPIES - 1) * len(shape.triangles)       # what the copies beyond the first add
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", extra + 1)
    assert not pack.shares_tree(shape)
    packed = pack.pack_scene(scene)
    shared = [pack.shares_tree(s) for s in scene.shapes[1:3]]
    assert len(packed.instanced_meshes) == sum(shared)
    assert len(packed.mesh[0]) == sum(COPIES * len(s.triangles)
                                      for s, k in zip(scene.shapes[1:3], shared) if not k)
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", extra)
    assert pack.shares_tree(shape)
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 0)
    scene.shapes[2].emission = m.Emission((1.0, 1.0, 1.0))
    packed = pack.pack_scene(scene)
    assert len(packed.instanced_meshes) == 1 and not pack.shares_tree(scene.shapes[2])
    # every copy's triangles are lights, besides the rectangle and the sky
    assert len(packed.lights) == COPIES * len(scene.shapes[2].triangles) + 2


def test03_the_wavefront_executor_refuses_them(gl_ctx, monkeypatch):
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 0)
    with pytest.raises(UsageError, match="instanced meshes"):
        glrender.render(copies_scene(8), spp=1, progress=False, executor="wavefront")


def test04_bad_instances_are_refused():
    scene = copies_scene(8)
    scene.shapes[1].instances = np.zeros((3, 3, 4))
    with pytest.raises(glrender.errors.SceneError, match="instances: expected K 4x4 transforms"):
        pack.pack_scene(scene)
    scene.shapes[1].instances = np.zeros((3, 4, 4))
    with pytest.raises(glrender.errors.SceneError, match="last row"):
        pack.pack_scene(scene)


def test05_moving_one_copy_changes_the_fingerprint(gl_ctx, monkeypatch):
    """A checkpoint resumes only the same scene: the copies' transforms are in the
    fingerprint (a copy moved within the scene's box leaves the triangles and texels as
    they were)."""
    from glrender.render.renderer import Renderer, settings_from_scene

    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 0)
    prints = []
    for shift in (0.0, 0.25):
        scene = copies_scene(8)
        scene.shapes[1].instances[3, 0, 3] += shift
        with Renderer(scene, settings_from_scene(scene, spp=1)) as r:
            prints.append(r.fingerprint())
    assert prints[0] != prints[1]
