"""The power density (n + 1) x^n: inversion and the max of n + 1 uniforms give one law.

Both GLSL routines run on independent fixed-seed uniforms; a two-sample chi-square test
over 50 equal-probability bins compares them directly, without using the pdf (Šidák
over the four n). With 10^6 samples each, a difference of 2% relative in one bin's
probability is seen at ~4.5 sigma. Against the pdf, both are in tests/sampling/test_warps.py.
"""
import numpy as np
import pytest

from glrender.sampling import power
from glrender.testing.harness import run_glsl
from glrender.testing.stats import chi2_sf, sidak_alpha

SAMPLES = 1_000_000
BINS = 50
ORDERS = (0, 1, 2, 3)


@pytest.mark.parametrize("n", ORDERS)
def test01_inversion_and_max_trick_agree(gl_ctx, n):
    rng = np.random.default_rng(20 + n)
    u1 = rng.random(SAMPLES, dtype=np.float32)
    u4 = rng.random((SAMPLES, 4), dtype=np.float32)
    out = run_glsl(f"float a = sample_power(u1, {n}.0); float b = sample_power_max(u4, {n});",
                   {"u1": u1, "u4": u4}, {"a": "float", "b": "float"},
                   includes=["sampling/power.glsl"])
    # bins of equal probability under the common law P(x) = x^(n + 1)
    edges = (np.arange(BINS + 1) / BINS) ** (1.0 / (n + 1))
    a = np.histogram(out["a"], edges)[0].astype(float)
    b = np.histogram(out["b"], edges)[0].astype(float)
    assert a.sum() == b.sum() == SAMPLES
    stat = float(np.sum((a - b) ** 2 / (a + b)))  # two-sample, equal sizes
    assert chi2_sf(stat, BINS - 1) >= sidak_alpha(0.01, len(ORDERS))


def test02_max_trick_is_not_inversion_of_a_different_order(gl_ctx):
    """The same two-sample test tells n = 2 from n = 3: it has the power to fail."""
    rng = np.random.default_rng(30)
    u1 = rng.random(SAMPLES, dtype=np.float32)
    u4 = rng.random((SAMPLES, 4), dtype=np.float32)
    out = run_glsl("float a = sample_power(u1, 2.0); float b = sample_power_max(u4, 3);",
                   {"u1": u1, "u4": u4}, {"a": "float", "b": "float"},
                   includes=["sampling/power.glsl"])
    edges = (np.arange(BINS + 1) / BINS) ** (1.0 / 4)
    a = np.histogram(out["a"], edges)[0].astype(float)
    b = np.histogram(out["b"], edges)[0].astype(float)
    assert chi2_sf(float(np.sum((a - b) ** 2 / (a + b))), BINS - 1) < 1e-20


@pytest.mark.parametrize("n", [0.0, 0.5, 7.5, 40.0])
def test03_real_exponents_round_trip_and_integrate(gl_ctx, n):
    u = np.random.default_rng(31).random(100_000, dtype=np.float32)
    out = run_glsl(f"float x = sample_power(u, {n}); float back = invert_power_sample(x, {n}); "
                   f"float pdf = power_pdf(x, {n});", {"u": u},
                   {"x": "float", "back": "float", "pdf": "float"}, includes=["sampling/power.glsl"])
    # pow's float32 error (a few ulps, relative) grows by the exponent n + 1 on the way back
    np.testing.assert_allclose(out["back"], u, rtol=4 * (n + 2) * 2 ** -23, atol=2 ** -25)
    np.testing.assert_allclose(out["x"], power.sample_power(u, n), rtol=8 * 2 ** -23)
    np.testing.assert_allclose(out["pdf"], power.power_pdf(out["x"], n), rtol=8 * (n + 1) * 2 ** -23)
    x = (np.arange(200_000) + 0.5) / 200_000  # midpoint rule on [0, 1]
    assert power.power_pdf(x, n).mean() == pytest.approx(1.0, abs=1e-3)
