"""A normal map with Mitsuba's defaults (its shadowing term, Conty Estevez et al. 2019, and
its flip of invalid normals) under light tracing and BDPT against the path tracer, per
16x16 block at a Šidák-corrected alpha of 0.01 over every block, channel and integrator
of this file (sigma from four independent seeds of each).

Mitsuba applies the term to the direction a BSDF query samples or evaluates, in either
transport mode, and flips for the arriving ray: neither is the adjoint of its radiance
BSDF (its light tracer would shadow the direction toward the camera, and flip for the
light's side). glrender applies the term to the light-side direction in both modes
(bsdf/bsdf.glsl bsdf_normal_shadowing) and flips on camera paths only (bsdf/normal_map.glsl
apply_normal_map), so every integrator estimates the path tracer's image here. Measured
with Mitsuba's forms instead: light tracing +1.7% (9.7 sigma) for the term, +6.4% for
the flip.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.testing.images import compare_images

from bidir_scenes import renders

SCENE = Path(__file__).resolve().parents[1] / "parity" / "scenes" / "bsdf-normalmap-mitsuba-defaults.xml"
SEEDS_PATH, SEEDS_OTHER = (11, 12, 13, 14), (21, 22, 23, 24)
BLOCK = 16
# integrator: its spp (the path tracer takes 128)
SPP = {"lighttrace": 64, "bdpt": 32}


def panel_scene(shadowing: bool = True):
    scene = glrender.load(SCENE)
    scene.materials = [replace(mat, normal_shadowing=shadowing) if mat.normal_map is not None
                       else mat for mat in scene.materials]
    assert any(mat.normal_shadowing for mat in scene.materials) == shadowing
    assert any(mat.normal_flip for mat in scene.materials)       # Mitsuba's default
    return scene


def block_tests(scene) -> int:
    f = scene.film
    return 3 * -(-f.width // BLOCK) * -(-f.height // BLOCK) + 2


@pytest.fixture(scope="module")
def path_reference(gl_ctx):
    paths = renders(panel_scene(), "path", 128, SEEDS_PATH)
    return paths.mean(axis=0), paths.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_PATH))


@pytest.mark.slow
@pytest.mark.parametrize("integrator", list(SPP))
def test01_matches_path_with_the_term(gl_ctx, path_reference, integrator):
    scene = panel_scene()
    ref, ref_se = path_reference
    extra = block_tests(scene) * (len(SPP) - 1)
    other = renders(scene, integrator, SPP[integrator], SEEDS_OTHER)
    c = compare_images(other, ref, ref_se, block=BLOCK, extra_tests=extra)
    print(f"{integrator} vs path: {c.summary()}")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    # power: the term darkens the image by about 2% (the parity case's measure); the
    # comparison sees a bias of the mean well below that
    plain = renders(panel_scene(shadowing=False), "path", 32, SEEDS_PATH[:2]).mean(axis=0)
    effect = 1.0 - ref.mean() / plain.mean()
    assert effect > 0.01, effect
    assert c.detectable_bias < effect / 2, (c.summary(), effect)


REFS = Path(__file__).resolve().parents[1] / "parity" / "refs"
SEEDS_STRONG = tuple(range(500, 516))
SPP_STRONG = {"path": 256, "bdpt": 64}


def strong_comparison(integrator):
    ref = np.load(REFS / "bsdf-normalmap-mitsuba-defaults.npy")[..., :3]
    ref_se = np.load(REFS / "bsdf-normalmap-mitsuba-defaults-stderr.npy")[..., :3]
    scene = panel_scene()
    other = renders(scene, integrator, SPP_STRONG[integrator], SEEDS_STRONG)
    return compare_images(other, ref, ref_se, block=BLOCK, extra_tests=block_tests(scene))


@pytest.mark.slow
@pytest.mark.parametrize("integrator", [
    "path",
    pytest.param("bdpt", marks=pytest.mark.xfail(strict=True, reason=(
        "the normal-map flip: light paths keep the map's normal where a camera path would "
        "flip it (README, known limitations); with 16 seeds BDPT is +0.03% on the image "
        "and +0.5% on a block of the floor seen under the panel (z 4.5), and with the flip "
        "off it matches the path tracer (test05)"))),
])
def test02_sixteen_seeds_against_mitsuba(gl_ctx, integrator):
    """The panel with the term, 16 seeds, against Mitsuba's reference per 16x16 block (a
    test with four times the seeds of test01, so a bias of a few tenths of a percent on
    a block shows). BDPT was 0.3-0.5% dark on the floor under the panel (-7 sigma) while
    its light walk rejected sampled directions below the geometric surface (see test04)."""
    c = strong_comparison(integrator)
    print(f"{integrator} vs Mitsuba: {c.summary()}")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


@pytest.mark.slow
def test03_light_paths_do_not_arrive_through_the_panel(gl_ctx):
    """A light path that reaches the rough plastic panel from behind its geometric surface
    while in front of the mapped shading normal (from the floor behind it) must end
    there, as the path tracer ends a sampled direction like that: before, light tracing
    was +1.2% (5 sigma) on the panel's lower middle block with the term and the flip off.
    The panel's pixels only, 16 seeds."""
    scene = panel_scene(shadowing=False)
    scene.materials = [replace(mat, normal_flip=False) if mat.normal_map is not None else mat
                       for mat in scene.materials]
    paths = renders(scene, "path", 256, SEEDS_STRONG)
    other = renders(scene, "lighttrace", 256, tuple(range(600, 616)))
    mask = np.zeros(paths.shape[1:3], bool)
    mask[13:48, 14:50] = True                       # the panel, above the floor's band
    ref, ref_se = paths.mean(axis=0), paths.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_STRONG))
    c = compare_images(other, ref, ref_se, block=BLOCK, mask=mask, check_mse=False)
    print(f"lighttrace vs path on the panel: {c.summary()}")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def against_path(scene, integrator, seeds):
    """``integrator`` (BDPT at 128 spp, light tracing at 512) against the path tracer at
    512 spp per block, 16 seeds each."""
    paths = renders(scene, "path", 512, SEEDS_STRONG)
    other = renders(scene, integrator, 128 if integrator == "bdpt" else 512, seeds)
    ref, ref_se = paths.mean(axis=0), paths.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_STRONG))
    return compare_images(other, ref, ref_se, block=BLOCK, extra_tests=block_tests(scene), check_mse=False)


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["bdpt", "lighttrace"])
def test04_light_side_rule_under_a_steep_map(gl_ctx, integrator):
    """The panel's map replaced by one normal tilted 40 degrees down (term and flip off):
    the glossy reflection of the light then points behind the panel, and camera paths
    that reach the panel from behind (through the gap under it) see it lit through the
    panel, as in Mitsuba. The rule that makes every integrator agree: a direction on the
    light side of a vertex lies on the same side of the geometric and the shading
    surface, the camera side is free. With light walks that also rejected a sampled
    (camera-side) direction below the geometric surface, BDPT was 2% dark there (z -35
    against the path tracer) and light tracing 4%. Per block against the path tracer,
    16 seeds each."""
    import math

    from test_surface_detail import flat_map

    scene = panel_scene(shadowing=False)
    tilt = flat_map((0.0, -math.sin(0.7), math.cos(0.7)))
    scene.materials = [replace(mat, normal_flip=False, normal_map=tilt) if mat.normal_map is not None
                       else mat for mat in scene.materials]
    c = against_path(scene, integrator, tuple(range(700, 716)))
    print(f"{integrator} vs path under the steep map: {c.summary()}")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["bdpt", "lighttrace"])
def test05_textured_map_with_the_term_without_the_flip(gl_ctx, integrator):
    """The parity panel's textured map with Mitsuba's shadowing term and without its flip:
    BDPT and light tracing against the path tracer per block, 16 seeds each (BDPT was
    0.3-0.5% dark on the floor under the panel before the light-side rule)."""
    scene = panel_scene()
    scene.materials = [replace(mat, normal_flip=False) if mat.normal_map is not None else mat
                       for mat in scene.materials]
    c = against_path(scene, integrator, tuple(range(950, 966)))
    print(f"{integrator} vs path, term on, flip off: {c.summary()}")
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
