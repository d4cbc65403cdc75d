"""Participating media in the light-path integrators: bdpt, vcm and lighttrace against the
volumetric path tracer, per block at a Šidák-corrected alpha of 0.01 over every block,
channel and scene of this file (glrender.testing.images.compare_images, sigma from the
spread of independent seeds); and one dispatch or many, bitwise. (bdpt's O(1) weights
against the weights whose densities are evaluated afresh, bitwise, on media scenes:
tests/render/test_bdpt.py test06.) (That bdpt's weights sum
to 1 over paths with medium vertices: tests/render/test_bdpt_mis.py.)

The scenes (bidir_scenes.MEDIA): a chromatic Henyey-Greenstein fog ball in the glossy
Cornell box, fog inside the caustic scene's glass sphere, a fog ball under an image
environment, a point light in haze around the camera, and a heterogeneous .vol grid.
Light tracing cannot render what the camera sees through glass: there it is compared
where the first surface hit is not specular (null boundaries pass).

vcm's merges in media (over a ball) are checked alone (its vm mode) in haze that no
boundary cuts near what the camera sees (test03): a boundary within the radius of a merge
darkens it, the bias of every density estimate, which falls with the radius."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from glrender.drivers import create_driver
from glrender.render.renderer import settings_from_scene
from glrender.testing.images import compare_images

from glrender.vcm import VcmSettings

from bidir_scenes import (camera_haze, fog_environment, fog_glossy, fog_in_glass,
                          non_specular_first_hit, open_haze, path_reference, renders, smoke_grid)

# many seeds: a light path's vertices in a medium splat to neighbouring pixels, so the image
# mean's sigma comes from the spread of the seeds' own means (correlated_pixels), at a
# Student-t threshold of k - 1 degrees of freedom; the MSE test, whose sigma assumes
# independent pixels, is left out (its ratio strayed 4.5 of those sigmas from 1 on the smoke
# grid at one seed set, and within 1 at another)
SEEDS_PATH, SEEDS_TEST = tuple(range(51, 63)), tuple(range(71, 83))
BLOCK = 8
# name: (scene, path spp, bdpt and vcm spp, lighttrace spp)
SCENES = {
    "fog-glossy": (fog_glossy, 128, 32, 128),
    "fog-in-glass": (fog_in_glass, 512, 192, 256),
    "fog-environment": (fog_environment, 64, 16, 64),
    "camera-haze": (camera_haze, 128, 64, 128),
    "smoke-grid": (smoke_grid, 128, 32, 128),
}
# bdpt on every scene; vcm (bdpt's connections and merges at surfaces: the same subpaths)
# and light tracing on three. Light tracing leaves lights at infinity seen directly black
# (the environment scene's sky), and vcm is 1% dark on the environment scene without fog as
# well (an open defect of its merges under an image environment, not of media).
CASES = [(name, "bdpt") for name in SCENES] + \
        [(name, "vcm") for name in ("fog-in-glass", "camera-haze", "smoke-grid")] + \
        [(name, "lighttrace") for name in ("fog-glossy", "fog-in-glass", "smoke-grid")]


def block_tests(scene):
    f = scene.film
    return 3 * -(-f.width // BLOCK) * -(-f.height // BLOCK) + 2


@functools.lru_cache(maxsize=None)
def reference(name):
    """The path tracer's image of scene `name` and its standard error (once per scene: the
    file's tests run in one process)."""
    make, spp_path, _, _ = SCENES[name]
    return path_reference(make(), spp_path, SEEDS_PATH)


@pytest.fixture(scope="module")
def all_tests():
    return len(CASES) * block_tests(fog_glossy())


@pytest.mark.slow
@pytest.mark.parametrize("name, integrator", CASES)
def test01_bidirectional_media_match_the_path_tracer(gl_ctx, all_tests, name, integrator):
    make, _, spp_bdpt, spp_lt = SCENES[name]
    scene = make()
    extra = all_tests - block_tests(scene)
    test = renders(scene, integrator, spp_lt if integrator == "lighttrace" else spp_bdpt, SEEDS_TEST)
    ref, ref_se = reference(name)
    mask = None
    if integrator == "lighttrace" and name == "fog-in-glass":
        mask = non_specular_first_hit(scene, kinds=("conductor", "dielectric", "thindielectric"))
    # vcm's merges over a radius of a few pixels correlate a block's pixels: its blocks are
    # 16 pixels wide, each one's sigma from the spread of the seeds' block means
    vcm = integrator == "vcm"
    c = compare_images(test, ref, ref_se, block=2 * BLOCK if vcm else BLOCK, mask=mask, extra_tests=extra,
                       correlated_pixels=True, correlated_blocks=vcm, check_mse=False)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.05, c.summary()


@pytest.mark.parametrize("integrator", ["bdpt", "vcm", "lighttrace"])
def test02_one_dispatch_or_many_bitwise(gl_ctx, integrator):
    scene = smoke_grid(16)
    images = []
    for time_target in (1e-9, 10.0):   # one tile per dispatch vs the whole image in one
        r = create_driver(scene, settings_from_scene(scene, integrator=integrator, spp=4, seed=5,
                                                     time_target=time_target), ctx=gl_ctx)
        r.step(4)
        images.append(r.film().mean)
        r.release()
    assert np.array_equal(images[0], images[1]) and images[0].sum() > 0


@pytest.mark.slow
def test03_merges_in_a_medium_match_the_path_tracer(gl_ctx):
    """vcm's merges alone (vm: the merges and the camera paths that reach a light, here
    none, as the light is a point) in open haze: every pixel's light comes from merges of
    camera and light subpaths' scattering events within a ball of radius 0.25, at 3.4 from
    the light. Per 16-pixel block (merges correlate neighbouring pixels) against the path
    tracer, at a threshold Šidák-corrected over the blocks and channels."""
    scene = open_haze()
    ref, ref_se = path_reference(scene, 256, SEEDS_PATH)
    test = renders(scene, "vcm", 256, SEEDS_TEST, integrator_options=VcmSettings(mode="vm", initial_radius=0.25))
    c = compare_images(test, ref, ref_se, block=2 * BLOCK, correlated_pixels=True, correlated_blocks=True,
                       check_mse=False)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.05, c.summary()
