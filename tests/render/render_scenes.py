"""Small analytic scenes built with the scene model, for the renderer's tests."""
from __future__ import annotations

import numpy as np

from glrender.scene import model as m


def base(width=64, height=64, **integrator) -> m.Scene:
    scene = m.Scene(film=m.Film(width=width, height=height, filter="box"),
                    integrator=m.Integrator(**integrator), source="<test scene>")
    return scene


def enclosure(albedo=0.5, radiance=1.0, width=32, height=32, **integrator) -> m.Scene:
    """A closed cube whose six inward-facing walls are diffuse (albedo) and emissive
    (radiance): L = Le / (1 - albedo) everywhere inside."""
    scene = base(width, height, **integrator)
    scene.camera = m.Camera(world_from_camera=m.look_at((0.2, -0.1, 0.3), (1, 0.5, -0.7), (0, 1, 0)),
                            fov=70)
    mat = scene.add_material(m.Material("diffuse", reflectance=(albedo,) * 3))
    scene.shapes.append(m.Shape("cube", material=mat, flip_normals=True,
                                emission=m.Emission((radiance,) * 3)))
    return scene


def sphere_in_environment(albedo=0.8, kind="diffuse", width=48, height=48, **integrator) -> m.Scene:
    """A unit sphere inside a uniform environment of radiance 1."""
    scene = base(width, height, **integrator)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 4), (0, 0, 0), (0, 1, 0)), fov=40)
    mat = scene.add_material(m.Material(kind, reflectance=(albedo,) * 3))
    scene.shapes.append(m.Shape("sphere", material=mat))
    scene.lights.append(m.Light("constant", radiance=(1.0, 1.0, 1.0)))
    return scene


def plane_under_light(light: m.Light | None = None, emitter_sphere=None, albedo=0.5,
                      width=32, height=32, **integrator) -> m.Scene:
    """A diffuse 4x4 plane at z = 0 facing +z, seen from straight above by an
    orthographic-like narrow camera, lit by one light."""
    scene = base(width, height, **integrator)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 20), (0, 0, 0), (0, 1, 0)), fov=8,
                            fov_axis="x")
    mat = scene.add_material(m.Material("diffuse", reflectance=(albedo,) * 3))
    scene.shapes.append(m.Shape("rectangle", material=mat, world_from_object=m.scale(2.0)))
    if light is not None:
        scene.lights.append(light)
    if emitter_sphere is not None:
        center, radius, radiance = emitter_sphere
        black = scene.add_material(m.Material("diffuse", reflectance=(0, 0, 0)))
        scene.shapes.append(m.Shape("sphere", material=black, center=center, radius=radius,
                                    emission=m.Emission((radiance,) * 3)))
    return scene


def plane_points(scene: m.Scene, supersample: int = 8) -> np.ndarray:
    """Where each pixel's footprint meets the plane z = 0, sampled on a supersample^2
    grid per pixel: (H, W, s*s, 3). Mirrors the camera model (Mitsuba's: +x left)."""
    from glrender.render.renderer import camera_tangents

    w, h = scene.film.width, scene.film.height
    tx, ty = camera_tangents(scene.camera, w, h)
    s = supersample
    off = (np.arange(s) + 0.5) / s
    px = (np.arange(w)[:, None] + off[None, :]).reshape(-1) / w
    py = (np.arange(h)[:, None] + off[None, :]).reshape(-1) / h
    X, Y = np.meshgrid(px, py)
    d = np.stack([(1 - 2 * X) * tx, (1 - 2 * Y) * ty, np.ones_like(X)], axis=-1)
    M = scene.camera.world_from_camera
    d = d @ M[:3, :3].T
    o = M[:3, 3]
    t = -o[2] / d[..., 2]
    p = o + t[..., None] * d
    return p.reshape(h, s, w, s, 3).transpose(0, 2, 1, 3, 4).reshape(h, w, s * s, 3)


def cornell_box(width: int, height: int) -> m.Scene:
    """scenes/cornell-box at another film size."""
    from dataclasses import replace
    from pathlib import Path

    import glrender

    scene = glrender.load(Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml")
    scene.film = replace(scene.film, width=width, height=height)
    return scene
