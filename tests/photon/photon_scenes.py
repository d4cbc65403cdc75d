"""Small scenes for the photon tests, built with the scene model."""
from __future__ import annotations

import math

import numpy as np

from glrender.scene import model as m


def plane_scene(light: m.Light | None = None, *, albedo=0.5, width=16, height=16, area_light=None,
                **integrator) -> m.Scene:
    """A diffuse 4x4 plane at z = 0 facing +z, seen from above through a narrow camera.
    ``area_light``: (centre, half size, radiance) of a downward-facing emitting square."""
    scene = m.Scene(film=m.Film(width=width, height=height, filter="box"),
                    integrator=m.Integrator(**integrator), source="<photon test scene>")
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 20), (0, 0, 0), (0, 1, 0)), fov=8,
                            fov_axis="x")
    mat = scene.add_material(m.Material("diffuse", reflectance=(albedo,) * 3))
    scene.shapes.append(m.Shape("rectangle", material=mat, world_from_object=m.scale(2.0)))
    if light is not None:
        scene.lights.append(light)
    if area_light is not None:
        centre, half, radiance = area_light
        black = scene.add_material(m.Material("diffuse", reflectance=(0, 0, 0)))
        # the rectangle faces +z; flipped by a half turn about x it faces down
        world = m.translate(centre) @ m.rotate((1, 0, 0), 180.0) @ m.scale(half)
        scene.shapes.append(m.Shape("rectangle", material=black, world_from_object=world,
                                    emission=m.Emission((radiance,) * 3)))
    return scene


def spot_power(intensity: float, cutoff_deg: float, beam_deg: float) -> float:
    """Power of a spot light with Mitsuba's falloff (1 inside the beam width, linear in
    the angle to 0 at the cutoff), by quadrature in float64."""
    c, b = math.radians(cutoff_deg), math.radians(min(beam_deg, cutoff_deg))
    theta = np.linspace(0.0, c, 400_001)
    falloff = np.where(theta <= b, 1.0, (c - theta) / max(c - b, 1e-12))
    return float(intensity * 2 * math.pi * np.trapezoid(falloff * np.sin(theta), theta))
