"""The disk by rejection from the square: trial counts, the bounded loop and its fallback.

Uniformity of the accepted points is tested with every other warp (test_warps.py). Here:
the number of trials is geometric with success probability pi / 4, so its mean is 4 / pi;
with 10^6 samples the standard error of the mean is 5.9e-4 (0.05%), and a mean off by
0.25% would be seen at 4 sigma.
"""
import math

import numpy as np

from glrender.sampling.catalog import REJECTION_PREAMBLE, rejection_trial_uniforms
from glrender.sampling.disk_rejection import DISK_REJECTION_MAX_TRIALS, sample_uniform_disk_rejection
from glrender.testing.harness import run_glsl
from glrender.testing.stats import chi2_sf, sidak_alpha

SAMPLES = 1_000_000
P_ACCEPT = math.pi / 4
INCLUDES = ["sampling/disk_rejection.glsl", "common/hash.glsl"]
BODY = ("g_rejection_u = u; uint trials; vec2 p = sample_uniform_disk_rejection(trials); "
        "uint loops = g_loop_count;")


def run_trials():
    u = np.random.default_rng(40).random((SAMPLES, 2), dtype=np.float32)
    return run_glsl(BODY, {"u": u}, {"p": "vec2", "trials": "uint", "loops": "uint"},
                    includes=INCLUDES, preamble=REJECTION_PREAMBLE,
                    defines={"GLRENDER_COUNT_LOOPS": 1})


def test01_expected_trials_is_four_over_pi(gl_ctx):
    out = run_trials()
    trials = out["trials"].astype(np.float64)
    sigma = math.sqrt((1 - P_ACCEPT) / P_ACCEPT ** 2 / SAMPLES)  # geometric variance
    print(f"mean trials {trials.mean():.5f} vs 4/pi = {4 / math.pi:.5f} (sigma {sigma:.2g})")
    assert abs(trials.mean() - 4 / math.pi) <= 4 * sigma
    # every trial is one loop iteration, and the loop stays far below llvmpipe's cap
    np.testing.assert_array_equal(out["loops"], out["trials"])
    assert out["trials"].max() <= DISK_REJECTION_MAX_TRIALS
    # accepted when x^2 + y^2 <= 1 in float32: up to two roundings above 1 in float64
    assert np.all(np.sum(out["p"].astype(np.float64) ** 2, axis=1) <= 1.0 + 2 ** -22)
    # and the count's law is geometric: P(k) = (1 - p)^(k - 1) p, k >= 7 pooled
    k = np.minimum(out["trials"], 7)
    counts = np.bincount(k, minlength=8)[1:]
    probs = np.array([(1 - P_ACCEPT) ** (j - 1) * P_ACCEPT for j in range(1, 7)])
    expected = SAMPLES * np.append(probs, 1 - probs.sum())
    stat = float(np.sum((counts - expected) ** 2 / expected))
    assert chi2_sf(stat, len(expected) - 1) >= sidak_alpha(0.01, 1)


def test02_glsl_matches_numpy_on_explicit_uniforms(gl_ctx):
    n = 20_000
    u = np.random.default_rng(41).random((n, 2), dtype=np.float32)
    trials_u = rejection_trial_uniforms(u, DISK_REJECTION_MAX_TRIALS)
    preamble = ("uint g_sample;\nvec2 disk_rejection_uniform(uint trial) {\n"
                f"    uint k = 2u * (g_sample * {DISK_REJECTION_MAX_TRIALS}u + trial);\n"
                "    return vec2(trials_u[k], trials_u[k + 1u]);\n}")
    out = run_glsl("g_sample = index; uint trials; vec2 p = sample_uniform_disk_rejection(trials);",
                   n=n, outputs={"p": "vec2", "trials": "uint"},
                   includes=["sampling/disk_rejection.glsl"], preamble=preamble,
                   buffers={"trials_u": trials_u.reshape(-1)})
    p, trials = sample_uniform_disk_rejection(trials_u)
    np.testing.assert_array_equal(out["trials"], trials)
    np.testing.assert_allclose(out["p"], p, rtol=0, atol=2 ** -23)  # 2u - 1 is exact in float32
    # the GLSL supplier of the catalogue draws the same uniforms as rejection_trial_uniforms
    out = run_glsl(BODY.replace(" uint loops = g_loop_count;", ""), {"u": u},
                   {"p": "vec2", "trials": "uint"}, includes=INCLUDES, preamble=REJECTION_PREAMBLE)
    np.testing.assert_array_equal(out["trials"], trials)


def test03_bounded_loop_falls_back_inside_the_disk(gl_ctx):
    """A supplier that never hits the disk: 64 trials, then a point of the disk."""
    corners = np.array([[0.0, 0.0], [0.999, 0.001], [0.001, 0.999], [0.999, 0.999]], np.float32)
    preamble = "vec2 g_corner;\nvec2 disk_rejection_uniform(uint trial) { return g_corner; }"
    out = run_glsl("g_corner = c; uint trials; vec2 p = sample_uniform_disk_rejection(trials); "
                   "uint loops = g_loop_count;", {"c": corners},
                   {"p": "vec2", "trials": "uint", "loops": "uint"},
                   includes=["sampling/disk_rejection.glsl"], preamble=preamble,
                   defines={"GLRENDER_COUNT_LOOPS": 1})
    assert np.all(out["trials"] == DISK_REJECTION_MAX_TRIALS)
    assert np.all(out["loops"] == DISK_REJECTION_MAX_TRIALS)
    assert np.all(np.sum(out["p"].astype(np.float64) ** 2, axis=1) <= 1.0 + 1e-6)
    p, trials = sample_uniform_disk_rejection(np.repeat(corners[:, None], 64, axis=1))
    np.testing.assert_array_equal(trials, DISK_REJECTION_MAX_TRIALS)
    np.testing.assert_allclose(out["p"], p, rtol=0, atol=4 * 2 ** -23)
