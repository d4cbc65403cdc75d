"""The chi-square module passes correct samplers and rejects subtly wrong ones.

Every test uses a fixed seed; each rejected sampler is rejected with p far below
the Šidák threshold (the margin is asserted), so these tests do not flip by chance.
"""
import math

import numpy as np
import pytest

from glrender.testing.chi2 import (ChiSquareTest, LineDomain, PlanarDomain, SphericalDomain,
                                   pdf_integral, roundtrip_error)
from glrender.testing.harness import run_glsl
from glrender.testing.stats import chi2_sf, sidak_alpha, sidak_z

scipy_stats = pytest.importorskip("scipy.stats")


# -- reference samplers in numpy -----------------------------------------------------------
def disk_polar(u, exponent=0.5):
    r, phi = u[:, 0].astype(np.float64) ** exponent, 2 * np.pi * u[:, 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)


def disk_pdf(p):
    return (np.sum(p * p, axis=1) <= 1.0) / np.pi


def cosine_hemisphere(u):
    d = disk_polar(u)
    z = np.sqrt(np.maximum(0.0, 1.0 - np.sum(d * d, axis=1)))
    return np.column_stack([d, z])


def cosine_hemisphere_pdf(w):
    return np.maximum(w[:, 2], 0.0) / np.pi


TABLE = np.array([[1, 2, 3, 4], [8, 1, 1, 1], [2, 2, 9, 2], [1, 1, 1, 12]], np.float64)


def table_pdf(p):
    """Piecewise-constant density on [0,1]^2 from TABLE[row = y cell, column = x cell]."""
    n = TABLE.shape[0]
    ix = np.clip((p[:, 0] * n).astype(int), 0, n - 1)
    iy = np.clip((p[:, 1] * n).astype(int), 0, n - 1)
    return TABLE[iy, ix] / TABLE.mean()


def table_sampler(table):
    """Sample a row of ``table`` by its marginal, a column by its conditional, then a
    uniform point in the cell (inverse CDF; u has 4 dimensions)."""
    n = table.shape[0]
    marginal = np.cumsum(table.sum(axis=1)) / table.sum()
    conditional = np.cumsum(table, axis=1) / table.sum(axis=1, keepdims=True)

    def sample(u):
        row = np.minimum(np.searchsorted(marginal, u[:, 1], side="right"), n - 1)
        col = np.minimum((conditional[row] <= u[:, [0]]).sum(axis=1), n - 1)
        return np.column_stack([(col + u[:, 2]) / n, (row + u[:, 3]) / n])
    return sample


# -- the statistics under the test ---------------------------------------------------------
@pytest.mark.parametrize("stat, dof", [(0.5, 1), (30.0, 10), (10100.0, 10000), (9000.0, 10000),
                                       (100.0, 3), (1e-3, 2), (250.0, 200)])
def test01_chi2_sf_matches_scipy(stat, dof):
    assert chi2_sf(stat, dof) == pytest.approx(scipy_stats.chi2.sf(stat, dof), rel=1e-9, abs=1e-300)


def test02_sidak():
    assert sidak_alpha(0.01, 1) == pytest.approx(0.01)
    assert sidak_alpha(0.01, 100) == pytest.approx(1 - 0.99 ** 0.01)
    # thousands of comparisons at alpha 0.01 need z of about 4.6-4.9 (TESTING.md)
    assert 4.5 < sidak_z(0.01, 2000) < 4.9


# -- correct samplers pass -----------------------------------------------------------------
def test03_accepts_uniform_disk(chi2_dir):
    test = ChiSquareTest(PlanarDomain(), disk_polar, disk_pdf, seed=1)
    assert test.run(), test.messages


def test04_accepts_cosine_hemisphere(chi2_dir):
    test = ChiSquareTest(SphericalDomain(), cosine_hemisphere, cosine_hemisphere_pdf, seed=2)
    assert test.run(), test.messages


def test05_accepts_power_function_max_trick(chi2_dir):
    n = 3  # p(x) = (n+1) x^n; max of n+1 uniforms
    test = ChiSquareTest(LineDomain(), lambda u: u.max(axis=1), lambda x: (n + 1) * x ** n,
                         sample_dim=n + 1, seed=3)
    assert test.run(), test.messages


def test06_accepts_a_glsl_sampler(gl_ctx, chi2_dir):
    def sample(u):
        body = "float r = sqrt(u.x); float phi = kTwoPi * u.y; vec2 p = r * vec2(cos(phi), sin(phi));"
        return run_glsl(body, {"u": u}, {"p": "vec2"}, includes=["common/constants.glsl"])["p"]
    test = ChiSquareTest(PlanarDomain(), sample, disk_pdf, seed=4)
    assert test.run(), test.messages


def test07_accepts_table_sampler(chi2_dir):
    test = ChiSquareTest(PlanarDomain(((0, 1), (0, 1))), table_sampler(TABLE), table_pdf, res=16,
                         sample_dim=4, seed=5)
    assert test.run(), test.messages


# -- subtly wrong samplers are rejected ----------------------------------------------------
def rejected(test):
    threshold = sidak_alpha(test.alpha, test.test_count)
    ok = test.run()
    return (not ok) and test.p_value < threshold * 1e-6


def test08_rejects_disk_with_r_equal_u(chi2_dir):
    test = ChiSquareTest(PlanarDomain(), lambda u: disk_polar(u, 1.0), disk_pdf, seed=6,
                         name="disk-r-equals-u")
    assert rejected(test), test.messages
    assert test.plot_path is not None and test.plot_path.exists()
    assert str(test.plot_path) in test.messages[-1]


def test09_rejects_slightly_wrong_radius_exponent(chi2_dir):
    test = ChiSquareTest(PlanarDomain(), lambda u: disk_polar(u, 0.47), disk_pdf, seed=7)
    assert rejected(test), test.messages


def test10_rejects_cosine_pdf_without_one_over_pi(chi2_dir):
    test = ChiSquareTest(SphericalDomain(), cosine_hemisphere, lambda w: np.maximum(w[:, 2], 0),
                         seed=8)
    assert rejected(test), test.messages


def test11_rejects_swapped_marginal(chi2_dir):
    test = ChiSquareTest(PlanarDomain(((0, 1), (0, 1))), table_sampler(TABLE.T), table_pdf,
                         res=16, sample_dim=4, seed=9)
    assert rejected(test), test.messages


def test12_samples_where_pdf_is_zero_fail_at_once(chi2_dir):
    def leaky(u):
        w = cosine_hemisphere(u)
        w[::1000, 2] *= -1  # one direction in a thousand below the horizon
        return w
    test = ChiSquareTest(SphericalDomain(), leaky, cosine_hemisphere_pdf, seed=10)
    assert not test.run()
    assert "where the pdf is zero" in test.messages[-1]


def test13_non_directions_and_nans_fail(chi2_dir):
    test = ChiSquareTest(SphericalDomain(), lambda u: 2 * cosine_hemisphere(u),
                         cosine_hemisphere_pdf, sample_count=1000)
    assert not test.run() and "not in the spherical domain" in test.messages[-1]
    test = ChiSquareTest(LineDomain(), lambda u: np.full(len(u), np.nan), lambda x: 1 + 0 * x,
                         sample_count=1000, sample_dim=1)
    assert not test.run() and "not finite" in test.messages[-1]


# -- integrals and round trips -------------------------------------------------------------
def test14_pdf_integrals():
    assert pdf_integral(SphericalDomain(), cosine_hemisphere_pdf) == pytest.approx(1, abs=1e-3)
    assert pdf_integral(PlanarDomain(), disk_pdf) == pytest.approx(1, abs=1e-3)
    assert pdf_integral(SphericalDomain(), lambda w: np.maximum(w[:, 2], 0)) == \
        pytest.approx(math.pi, abs=1e-2)


def test15_roundtrip():
    u = np.random.default_rng(11).random((1000, 2))
    def invert(p):
        r = np.hypot(p[:, 0], p[:, 1])
        return np.column_stack([r * r, np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * np.pi) / (2 * np.pi)])
    assert roundtrip_error(disk_polar, invert, u) < 1e-9
    assert roundtrip_error(lambda v: disk_polar(v, 1.0), invert, u) > 0.1
