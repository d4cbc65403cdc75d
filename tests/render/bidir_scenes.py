"""Scenes and helpers for comparing the light-path integrators (lighttrace, bdpt) with
the path tracer: independent renders per seed, the path tracer's mean as the reference
and its standard error from the spread of its seeds."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import glrender
from glrender.scene import model as m

from render_scenes import enclosure, plane_under_light

ROOT = Path(__file__).resolve().parents[2]


def cornell(size=64) -> m.Scene:
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film = replace(scene.film, width=size, height=size)
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


def caustic(size=32) -> m.Scene:
    scene = glrender.load(ROOT / "scenes" / "caustic" / "scene.toml")
    scene.film = replace(scene.film, width=size, height=size)
    return scene


def non_specular_first_hit(scene: m.Scene) -> np.ndarray:
    """(H, W) bool: pixels whose camera ray first meets a non-delta surface (or nothing).
    A pixel is specular where removing the delta-BSDF shapes changes the first hit's depth."""
    delta = {i for i, mat in enumerate(scene.materials)
             if mat.kind in ("conductor", "dielectric", "thindielectric", "null")}
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
