"""SPPM on the caustic scene (a glass sphere focusing a small light onto a floor),
against the Mitsuba 3 reference (73k spp) box-filtered down to 64x64
(tests/data/refs/caustic-ref-64.npy, the mean of each 4x4 block of the shared 256x256
reference: exact for the scene's box filter).

In the caustic window (rows 128-172, columns 128-200 of the full image) the error must
fall as for the Cornell box (fitted slope within 0.1 of the theory's band for alpha,
tests/photon/test_sppm_cornell.py), and the window's mean must lie within the bias
bound plus a Student-t band from independent seeds. Bias bound: the density estimate
averages the caustic over disks of radius at most r0 on the floor, which moves light
across the window's border; the bound is the largest change of the window's mean when
the reference is averaged over disks of up to r0 (in pixels at the window, with a
margin for the floor's slant).
"""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.photon import SppmRenderer, SppmSettings
from glrender.photon.sppm import DEFAULT_RADIUS_PIXELS
from glrender.testing.stats import student_t_quantile

ROOT = Path(__file__).resolve().parents[2]
REF = Path(__file__).resolve().parents[1] / "data" / "refs" / "caustic-ref-64.npy"
SIZE, PHOTONS, ITERATIONS, SEEDS, ALPHA = 64, 32768, 48, 3, 0.7
WINDOW = (slice(32, 43), slice(32, 50))


def disk_blur(image, radius):
    """The image averaged over a disk of ``radius`` pixels around each pixel (pixel
    centres within the disk; the window lies far from the image's edges)."""
    r = int(math.ceil(radius))
    offsets = [(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1) if dy * dy + dx * dx <= radius ** 2]
    return sum(np.roll(image, (dy, dx), axis=(0, 1)) for dy, dx in offsets) / len(offsets)


@pytest.mark.slow
def test01_caustic_window_converges(gl_ctx):
    scene = glrender.load(ROOT / "scenes" / "caustic" / "scene.toml")
    scene.film = replace(scene.film, width=SIZE, height=SIZE)
    ref = np.load(REF).astype(np.float64)
    mse = np.zeros(ITERATIONS)
    window_means = []
    for seed in range(SEEDS):
        r = SppmRenderer(scene, sppm=SppmSettings(photons_per_iteration=PHOTONS, alpha=ALPHA), ctx=gl_ctx,
                         seed=seed + 1, max_depth=8)
        try:
            for n in range(ITERATIONS):
                r.step(1)
                L = r.radiance()
                mse[n] += ((L - ref)[WINDOW] ** 2).mean() / SEEDS
            window_means.append(L[WINDOW].mean())
        finally:
            r.release()
    n = np.arange(1, ITERATIONS + 1)
    fit = n >= 8
    slope = 0.5 * np.polyfit(np.log(n[fit]), np.log(mse[fit]), 1)[0]
    low, high = -0.5, -min(ALPHA, 2 * (1 - ALPHA)) / 2
    # the default r0 is DEFAULT_RADIUS_PIXELS pixel footprints at the scene's centre, about
    # the window's distance; 1.5x for the floor's slant and the distance's difference
    r0_pixels = 1.5 * DEFAULT_RADIUS_PIXELS
    # every radius is at most r0: the blur of the window's mean at any radius up to it
    bias_bound = max(abs(disk_blur(ref, rad)[WINDOW].mean() - ref[WINDOW].mean())
                     for rad in np.linspace(0.5, r0_pixels, 6))
    mean = np.mean(window_means)
    se = np.std(window_means, ddof=1) / math.sqrt(SEEDS)
    t = student_t_quantile(0.995, SEEDS - 1)
    print(f"caustic window: RMSE slope {slope:.3f}, RMSE {math.sqrt(mse[7]):.4f} -> {math.sqrt(mse[-1]):.4f}, "
          f"mean {mean / ref[WINDOW].mean() - 1:+.4f} (bound {bias_bound / ref[WINDOW].mean():.4f}, "
          f"t se {t * se / ref[WINDOW].mean():.4f})")
    assert low - 0.1 <= slope <= high + 0.1, (slope, low, high)
    assert abs(mean - ref[WINDOW].mean()) <= bias_bound + t * se


@pytest.mark.slow
def test02_gathers_stay_far_below_the_loop_cap(gl_ctx):
    """The dense caustic under the sphere: the worst camera or photon invocation's loop
    iterations (BVH traversal included) stay far below llvmpipe's ~65,535 cap, and no
    gather candidate is skipped by the bound."""
    from glrender.render.renderer import settings_from_scene

    scene = glrender.load(ROOT / "scenes" / "caustic" / "scene.toml")
    scene.film = replace(scene.film, width=32, height=32)
    settings = settings_from_scene(scene, integrator="sppm", max_depth=8, count_loops=True)
    r = SppmRenderer(scene, settings, SppmSettings(photons_per_iteration=PHOTONS), ctx=gl_ctx)
    try:
        r.step(2)
        assert 0 < r.max_loop_count() < 30_000, r.max_loop_count()
        assert r.counters["skipped"] == 0 and r.counters["max_visited"] > 0
    finally:
        r.release()
