"""Scenes and helpers for comparing the light-path integrators (lighttrace, bdpt) with
the path tracer: independent renders per seed, the path tracer's mean as the reference
and its standard error from the spread of its seeds."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import glrender
from glrender.scene import model as m

from render_scenes import base, enclosure, plane_under_light

ROOT = Path(__file__).resolve().parents[2]


def cornell(size=64) -> m.Scene:
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film = replace(scene.film, width=size, height=size)
    return scene


def cornell_motion(size=64) -> m.Scene:
    """The Cornell box with a white ball on its small box moving toward the red wall during
    a box shutter of [0, 1] (vcm: every path of an iteration takes the iteration's time)."""
    scene = cornell(size)
    scene.shutter = m.Shutter(open=0.0, close=1.0)
    white = next(s for s in scene.shapes if s.name == "small box").material
    ball = m.Shape("sphere", material=white, center=(0.33, -0.2, 0.38), radius=0.2, name="ball")
    ball.world_from_object_close = m.translate((-0.4, 0.0, 0.0))
    scene.shapes.append(ball)
    return scene


def glossy(size=64) -> m.Scene:
    """The Cornell box with a rough conductor floor and a rough plastic large box."""
    scene = cornell(size)
    gold = scene.add_material(m.Material("roughconductor", eta=(0.143, 0.374, 1.442),
                                         k=(3.983, 2.385, 1.603), alpha=(0.15, 0.15),
                                         distribution="ggx"))
    plastic = scene.add_material(m.Material("roughplastic", reflectance=(0.3, 0.4, 0.6),
                                            alpha=(0.1, 0.1), distribution="ggx"))
    for shape in scene.shapes:
        if shape.name == "floor":
            shape.material = gold
        if shape.name == "large box":
            shape.material = plastic
    return scene


def thin_lens(size=64) -> m.Scene:
    scene = cornell(size)
    scene.camera = replace(scene.camera, aperture_radius=0.08, focus_distance=3.2)
    return scene


def point_light(size=32) -> m.Scene:
    return plane_under_light(m.Light("point", position=(0.7, -0.4, 2.5), intensity=(6.0, 4.0, 2.0)),
                             width=size, height=size, max_depth=3)


def closed_enclosure(size=32) -> m.Scene:
    return enclosure(albedo=0.5, radiance=1.0, width=size, height=size, max_depth=-1)


def slab_enclosure(size=32) -> m.Scene:
    """The closed enclosure flattened into a slab 0.1 thick, 2 from the origin: its two large
    walls face each other 0.1 apart, where a connection's shadow ray offset off its start
    alone (256 ulps of 2 along the normal) ran past the margin kept short of the far end
    (1e-4 of the distance) and met the far wall: BDPT lost every such connection."""
    scene = enclosure(albedo=0.5, radiance=1.0, width=size, height=size, max_depth=-1)
    scene.shapes[0].world_from_object = m.translate((0.0, 0.0, 2.0)) @ m.scale((1.0, 1.0, 0.05))
    scene.camera = replace(scene.camera, world_from_camera=m.look_at((-0.8, -0.1, 2.0), (1.0, 0.3, 2.02),
                                                                     (0, 0, 1)))
    return scene


def caustic(size=32) -> m.Scene:
    scene = glrender.load(ROOT / "scenes" / "caustic" / "scene.toml")
    scene.film = replace(scene.film, width=size, height=size)
    return scene


def non_specular_first_hit(scene: m.Scene, kinds=("conductor", "dielectric", "thindielectric", "null")) -> np.ndarray:
    """(H, W) bool: pixels whose camera ray first meets a non-delta surface (or nothing).
    A pixel is specular where removing the delta-BSDF shapes (of the material ``kinds``)
    changes the first hit's depth."""
    delta = {i for i, mat in enumerate(scene.materials) if mat.kind in kinds}
    bare = replace(scene, shapes=[s for s in scene.shapes if s.material not in delta])
    depth = [glrender.render(sc, spp=4, integrator="path", max_depth=1, aovs=True, seed=1,
                             progress=False, sampler="independent").aov("depth")
             for sc in (scene, bare)]
    # every sample of the pixel must agree (an edge pixel partly on glass is masked)
    return np.abs(depth[0] - depth[1]) <= 1e-4 * np.maximum(depth[1], 1.0)


def renders(scene: m.Scene, integrator: str, spp: int, seeds, **options) -> np.ndarray:
    return np.stack([glrender.render(scene, spp=spp, integrator=integrator, seed=seed,
                                     sampler="independent", progress=False, **options).mean
                     for seed in seeds])


def path_reference(scene: m.Scene, spp: int, seeds) -> tuple[np.ndarray, np.ndarray]:
    """The path tracer's image over independent ``seeds`` and its per-pixel standard error."""
    paths = renders(scene, "path", spp, seeds)
    return paths.mean(axis=0), paths.std(axis=0, ddof=1) / np.sqrt(len(seeds))


def use_generic_weights(monkeypatch) -> None:
    """Renderers made from here on compile GLRENDER_BDPT_GENERIC_WEIGHTS: every MIS density
    of bdpt's and vcm's connections evaluated afresh (the oracle of their O(1) weights)."""
    from glrender.render import renderer as renderer_module

    defines = renderer_module.shader_defines
    monkeypatch.setattr(renderer_module, "shader_defines",
                        lambda **kw: {**defines(**kw), "GLRENDER_BDPT_GENERIC_WEIGHTS": 1})


def _floor_and_spheres(scene: m.Scene) -> None:
    """A diffuse floor (z = 0, 6x6) with a diffuse sphere and a rough plastic one on it."""
    floor = scene.add_material(m.Material("diffuse", reflectance=(0.6, 0.55, 0.5)))
    white = scene.add_material(m.Material("diffuse", reflectance=(0.8, 0.8, 0.8)))
    plastic = scene.add_material(m.Material("roughplastic", reflectance=(0.2, 0.3, 0.7),
                                            alpha=(0.15, 0.15), distribution="ggx"))
    scene.shapes.append(m.Shape("rectangle", material=floor, world_from_object=m.scale(3.0)))
    scene.shapes.append(m.Shape("sphere", material=white, center=(-0.6, 0.2, 0.7), radius=0.7))
    scene.shapes.append(m.Shape("sphere", material=plastic, center=(0.8, -0.5, 0.45), radius=0.45))
    scene.camera = m.Camera(world_from_camera=m.look_at((0.5, -5.0, 3.2), (0, 0, 0.4), (0, 0, 1)), fov=45)


def environment(size=32) -> m.Scene:
    """The floor and spheres under an image environment: a sky gradient and a small bright
    patch (a sun of finite size, importance sampled)."""
    scene = base(size, size, max_depth=4)
    _floor_and_spheres(scene)
    h, w = 16, 32
    v = (np.arange(h)[:, None] + 0.5) / h
    image = np.zeros((h, w, 3), np.float32)
    image[...] = np.stack([0.3 + 0.5 * (1 - v), 0.4 + 0.5 * (1 - v), 0.9 * np.ones_like(v)], -1)[:, :1]
    image[3:5, 9:11] = (30.0, 28.0, 24.0)
    scene.lights.append(m.Light("envmap", image=image, world_from_light=m.rotate((1, 0, 0), 90)))
    return scene


def directional(size=32) -> m.Scene:
    """The floor and spheres under a sun (a directional light) and nothing else."""
    scene = base(size, size, max_depth=4)
    _floor_and_spheres(scene)
    scene.lights.append(m.Light("directional", direction=(-0.5, 0.6, -0.7), irradiance=(3.0, 2.8, 2.5)))
    return scene


# ---- participating media ------------------------------------------------------------------

def _fog_ball(scene: m.Scene, center, radius, **medium) -> int:
    """A ball of fog bounded by a null sphere; returns its medium."""
    null = scene.add_material(m.Material("null"))
    fog = scene.add_medium(m.Medium(**medium))
    scene.shapes.append(m.Shape("sphere", material=null, center=center, radius=radius, interior=fog))
    return fog


def fog_glossy(size=32) -> m.Scene:
    """glossy's Cornell box with a ball of chromatic, forward-scattering fog (Henyey-Greenstein
    g = 0.6) floating left of the boxes."""
    scene = glossy(size)
    _fog_ball(scene, (-0.4, 0.3, -0.1), 0.4, sigma_t=(1.5, 3.0, 5.0), albedo=(0.9, 0.8, 0.95),
              phase="hg", g=0.6)
    return scene


def fog_in_glass(size=32) -> m.Scene:
    """The caustic scene with its glass sphere filled with backward-scattering fog (g = -0.4):
    medium vertices behind specular ones."""
    scene = caustic(size)
    fog = scene.add_medium(m.Medium(sigma_t=(2.0, 2.0, 2.0), albedo=(0.95, 0.9, 0.8), phase="hg", g=-0.4))
    glass = next(i for i, mat in enumerate(scene.materials) if mat.kind == "dielectric")
    for shape in scene.shapes:
        if shape.material == glass:
            shape.interior = fog
    return scene


def fog_environment(size=32) -> m.Scene:
    """environment's floor and spheres with a ball of isotropic fog over the floor (light
    subpaths from the environment's disk scatter in it)."""
    scene = environment(size)
    _fog_ball(scene, (0.3, 0.6, 0.9), 0.6, sigma_t=(1.2, 1.2, 1.2), albedo=(0.8, 0.8, 0.8))
    return scene


def camera_haze(size=32) -> m.Scene:
    """The Cornell box in haze that fills the scene (a medium around the camera), lit by its
    ceiling light and a point light in the haze: the light subpaths start in it, found by
    their first segment. Paths in unbounded haze never leave it: max depth 12, so that
    Russian roulette ends most first."""
    scene = cornell(size)
    scene.integrator.max_depth = 12
    haze = scene.add_medium(m.Medium(sigma_t=(0.15, 0.2, 0.3), albedo=(0.9, 0.9, 0.9), phase="hg", g=0.3))
    scene.camera = replace(scene.camera, medium=haze)
    scene.lights.append(m.Light("point", position=(-0.5, 0.5, 0.2), intensity=(0.6, 0.5, 0.3)))
    return scene


def smoke_grid(size=32) -> m.Scene:
    """The parity suite's heterogeneous medium: a .vol grid of smoke over a floor."""
    scene = glrender.load(ROOT / "tests" / "parity" / "scenes" / "medium-grid.xml")
    scene.film = replace(scene.film, width=size, height=size)
    return scene


def open_haze(size=32) -> m.Scene:
    """Chromatic forward-scattering haze around the camera, lit by a point light out of
    view 3.4 ahead, and nothing else within reach (a black ball far behind the camera): no
    surface or medium boundary near what the camera sees. Max depth 3."""
    scene = base(size, size, max_depth=3)
    haze = scene.add_medium(m.Medium(sigma_t=(0.3, 0.5, 0.8), albedo=(0.9, 0.8, 0.7), phase="hg", g=0.4))
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 0), (0, 1, 0), (0, 0, 1)), fov=40, medium=haze)
    black = scene.add_material(m.Material("diffuse", reflectance=(0, 0, 0)))
    scene.shapes.append(m.Shape("sphere", material=black, center=(0, -60, 0), radius=1.0))
    scene.lights.append(m.Light("point", position=(0.0, 3.0, 1.6), intensity=(3.0, 3.0, 3.0)))
    return scene


MEDIA = (fog_glossy, fog_in_glass, fog_environment, camera_haze, smoke_grid)
