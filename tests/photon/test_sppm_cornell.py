"""SPPM on the Cornell box against the Mitsuba 3 reference (tests/data/refs, 49k spp).

SPPM is consistent, not unbiased: it is judged by convergence (TESTING.md). After n
iterations the radius obeys r^2 ~ n^-(1 - alpha) (Hachisuka & Jensen's rule once N is
large), so the bias (proportional to r^2) falls like n^-(1 - alpha) and the photon
variance like n^-alpha (Knaus & Zwicker 2011); the camera pass's own noise (direct light
by NEE, one sample per iteration) like n^-1. The RMSE's log-log slope therefore lies in
[-1/2, -min(alpha, 2 (1 - alpha)) / 2] ([-0.5, -0.3] for alpha = 0.7); the test allows
a margin of 0.1 for the fit over a finite range of iterations and 4 seeds. Pixels that
see the light are left out: their edge pixels' camera noise (a 17x contrast inside
a pixel) would hide the photon terms. The final image mean is within 1% of the
reference's.
"""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.photon import SppmRenderer, SppmSettings

ROOT = Path(__file__).resolve().parents[2]
REFS = Path(__file__).resolve().parents[1] / "data" / "refs"
SIZE, PHOTONS, ITERATIONS, SEEDS, RADIUS = 32, 8192, 128, 4, 0.05


def cornell():
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film = replace(scene.film, width=SIZE, height=SIZE)
    return scene


def reference():
    ref = np.load(REFS / "cornell-box-ref.npy").astype(np.float64)
    f = ref.shape[0] // SIZE
    # a box-filtered pixel of the small image is the mean of the f x f pixels it covers
    return ref.reshape(SIZE, f, SIZE, f, 3).mean(axis=(1, 3))


@pytest.mark.slow
@pytest.mark.parametrize("alpha", [0.7])
def test01_cornell_converges_at_the_rate_for_alpha(gl_ctx, alpha):
    scene, ref = cornell(), reference()
    lit = ref.max(axis=-1) > 1.0           # pixels that see the light, and their neighbours
    lit = lit | np.roll(lit, 1, 0) | np.roll(lit, -1, 0) | np.roll(lit, 1, 1) | np.roll(lit, -1, 1)
    keep = ~lit
    mse = np.zeros(ITERATIONS)
    radius2 = np.zeros(ITERATIONS)
    means = []
    for seed in range(SEEDS):
        r = SppmRenderer(scene, sppm=SppmSettings(photons_per_iteration=PHOTONS, alpha=alpha, initial_radius=RADIUS), ctx=gl_ctx,
                         seed=seed + 1, max_depth=8)
        try:
            for n in range(ITERATIONS):
                r.step(1)
                L = r.radiance()
                mse[n] += ((L - ref)[keep] ** 2).mean() / SEEDS
                radius2[n] += (r.radius ** 2).mean() / SEEDS
            means.append(L.mean())
        finally:
            r.release()
    n = np.arange(1, ITERATIONS + 1)
    fit = n >= 8
    slope = 0.5 * np.polyfit(np.log(n[fit]), np.log(mse[fit]), 1)[0]
    radius_slope = np.polyfit(np.log(n[fit]), np.log(radius2[fit]), 1)[0]
    print(f"alpha {alpha}: RMSE slope {slope:.3f}, r^2 slope {radius_slope:.3f}, "
          f"RMSE {math.sqrt(mse[7]):.4f} -> {math.sqrt(mse[-1]):.4f}, mean {np.mean(means) / ref.mean() - 1:+.4f}")
    assert abs(radius_slope + (1 - alpha)) < 0.05, radius_slope
    low, high = -0.5, -min(alpha, 2 * (1 - alpha)) / 2
    assert low - 0.1 <= slope <= high + 0.1, (slope, low, high)
    assert abs(np.mean(means) / ref.mean() - 1) < 0.01
