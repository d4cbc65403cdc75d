"""Ambient occlusion against its closed form: a floor beside a wall.

The AO integrator (shaders/integrators/ao.glsl) samples one cosine-weighted direction at the
first hit and counts it open unless it meets geometry within ``ao_distance`` r. Projected onto
the floor's plane, cosine-weighted directions are uniform over the unit disk (Malley), and a
direction of unit vector w meets a wall at distance d when w points toward it with
|w_x| >= d / r. So a point at distance d < r from the wall is occluded with the probability
that a uniform point of the disk lies beyond the chord at a = d / r:

    AO(d) = 1 - (acos(a) - a sqrt(1 - a^2)) / pi,      and AO = 1 for d >= r.

The wall (x = -1.45, 20 by 10, unseen by the camera) is far larger than r around every point seen, so within r it is
a half-plane. The pixels' footprints are integrated on an 8x8 grid; error bars come from four
independent seeds, each 4x4 block and the image mean tested at one Sidak-corrected threshold
(TESTING.md), on one channel: AO is grey, and its three equal channels are one sample.
"""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.scene import model as m
from glrender.testing.images import compare_images

from render_scenes import plane_points, plane_under_light

SEEDS = (21, 22, 23, 24)
WALL_X = -1.45


def floor_beside_wall(radius: float):
    scene = plane_under_light(None, albedo=0.5, kind="ao", ao_distance=radius)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5)))
    # the rectangle [-1,1]^2 facing +z, turned to face +x (toward the floor's points)
    wall = m.translate((WALL_X, 0.0, 5.0)) @ m.rotate((0, 1, 0), 90.0) @ m.scale((5.0, 10.0, 1.0))
    scene.shapes.append(m.Shape("rectangle", material=grey, world_from_object=wall))
    return scene


def expected_ao(scene, radius: float) -> np.ndarray:
    d = plane_points(scene)[..., 0] - WALL_X               # (H, W, samples): distance to the wall
    a = np.clip(d / radius, 0.0, 1.0)
    ao = 1.0 - (np.arccos(a) - a * np.sqrt(1.0 - a * a)) / np.pi
    return ao.mean(axis=-1)[..., None]


@pytest.mark.parametrize("radius", [0.75, 2.5])
def test01_floor_beside_a_wall(gl_ctx, radius):
    scene = floor_beside_wall(radius)
    # AO is grey: one channel holds the estimate (three equal ones are not three samples)
    imgs = np.stack([glrender.render(scene, spp=64, seed=s, sampler="independent",
                                     progress=False).mean[..., :1] for s in SEEDS])
    expected = expected_ao(scene, radius)
    assert expected.min() < 0.6          # the wall occludes a good part of the image
    c = compare_images(imgs, expected, block=4, extra_tests=1)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.02
    # beyond r of the wall nothing occludes: every sample is open, exactly 1
    open_pixels = expected[..., 0] == 1.0
    assert open_pixels.sum() > 100
    if open_pixels.any():
        np.testing.assert_array_equal(imgs[:, open_pixels], 1.0)


def test02_the_wall_out_of_reach_occludes_nothing(gl_ctx):
    scene = floor_beside_wall(0.04)         # nearer to no seen point than 0.05
    film = glrender.render(scene, spp=8, seed=5, sampler="independent", progress=False)
    np.testing.assert_array_equal(film.mean, 1.0)
