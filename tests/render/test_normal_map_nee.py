"""Next-event estimation under a normal map keeps the light-side rule every integrator
follows (integrators/shading.glsl light_side_valid): a direction toward a light must lie
on the same side of the geometric and the shading surface.

The scene: a one-sided diffuse floor (z = 0, facing +z) whose uniform normal map tilts
the shading normal 40 degrees toward +x, seen from above, lit by a panel above it and by
a panel beyond its +x edge, below its plane and facing it. Directions from the floor to
the low panel lie above the shading surface but below the geometric one. A BSDF sample
there ends the path (the path tracer's rule), so light sampling must not take them
either: before the rule, light sampling counted the low panel through the floor (the
direct integrator's light strategy against its BSDF strategy, and the path tracer
against BDPT, which already applied it).
"""
from __future__ import annotations

import numpy as np
import pytest

from glrender.scene import model as m
from glrender.testing.images import compare_images

from bidir_scenes import renders
from render_scenes import base
from test_surface_detail import flat_map

TILT = 40.0
SEEDS_A, SEEDS_B = (31, 32, 33, 34), (41, 42, 43, 44)
SIZE = 24
BLOCK = 8
# the family of block tests in this file: two comparisons (test02, test03), each of
# every block and channel and of the image mean
COMPARISONS = 2
TESTS_PER_COMPARISON = 3 * (SIZE // BLOCK) ** 2 + 2


def floor_scene(high: bool = True, low: bool = True, **integrator) -> m.Scene:
    scene = base(SIZE, SIZE, **integrator)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 20), (0, 0, 0), (0, 1, 0)), fov=8,
                            fov_axis="x")
    t = np.radians(TILT)
    floor = scene.add_material(m.Material("diffuse", reflectance=(0.6, 0.6, 0.6),
                                          normal_map=flat_map((np.sin(t), 0.0, np.cos(t)))))
    scene.shapes.append(m.Shape("rectangle", material=floor, world_from_object=m.scale(2.0)))
    black = scene.add_material(m.Material("diffuse", reflectance=(0.0, 0.0, 0.0)))
    if high:   # above the floor, facing down
        scene.shapes.append(m.Shape("rectangle", material=black, emission=m.Emission((6.0, 6.0, 6.0)),
                                    world_from_object=m.translate((-1.0, 0.0, 3.0))
                                    @ m.rotate((1, 0, 0), 180.0) @ m.scale(0.8)))
    if low:    # beyond the +x edge, below the floor's plane, facing -x
        scene.shapes.append(m.Shape("rectangle", material=black, emission=m.Emission((8.0, 8.0, 8.0)),
                                    world_from_object=m.translate((3.5, 0.0, -0.3))
                                    @ m.rotate((0, 1, 0), -90.0) @ m.scale((0.25, 2.0, 1.0))))
    return scene


@pytest.mark.parametrize("integrator, options", [
    ("path", {}), ("bdpt", {}), ("lighttrace", {}),
    ("direct", {"strategy": "light"}), ("direct", {"strategy": "bsdf"}),
    ("direct", {"strategy": "mis-power"}),
])
def test01_the_low_panel_alone_lights_nothing(gl_ctx, integrator, options):
    """Every path from the low panel to the camera meets the floor from below its
    geometric surface: the image is black, exactly."""
    scene = floor_scene(high=False, max_depth=3, **options)
    image = renders(scene, integrator, 16, (5,))[0]
    assert np.all(image == 0.0), (integrator, options, float(image.max()), float(image.mean()))


def agree(a: np.ndarray, b: np.ndarray) -> None:
    ref, ref_se = b.mean(axis=0), b.std(axis=0, ddof=1) / np.sqrt(len(b))
    c = compare_images(a, ref, ref_se, block=BLOCK, extra_tests=(COMPARISONS - 1) * TESTS_PER_COMPARISON)
    print(c.summary())
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test02_direct_light_sampling_matches_bsdf_sampling(gl_ctx):
    light = renders(floor_scene(strategy="light"), "direct", 256, SEEDS_A)
    bsdf = renders(floor_scene(strategy="bsdf"), "direct", 1024, SEEDS_B)
    assert bsdf.mean() > 0.03, bsdf.mean()       # the high panel lights the floor
    agree(light, bsdf)


@pytest.mark.slow
def test03_path_matches_bdpt(gl_ctx):
    path = renders(floor_scene(max_depth=3), "path", 64, SEEDS_A)
    bdpt = renders(floor_scene(max_depth=3), "bdpt", 32, SEEDS_B)
    agree(path, bdpt)
