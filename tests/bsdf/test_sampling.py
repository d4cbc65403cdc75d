"""bsdf_sample against bsdf_pdf for every non-delta model: chi-square, normalisation, weights.

For each case (model, parameters, wo) the sampled directions that are valid and not
from a Dirac lobe have the density bsdf_pdf(wo, .) per unit solid angle; the rest of
the probability is the Dirac lobes' (plastic's mirror) or lost (a microfacet
reflection that leaves below the surface). So:
- test01: chi-square of the valid non-delta directions against bsdf_pdf / its integral
  (the samples conditioned on validity; top-ups from a seeded generator), with Šidák's
  correction over the cases of this module;
- test02: the integral of bsdf_pdf over the sphere equals the fraction of valid
  non-delta samples (at most 1, exactly 1 when nothing is lost): |I - p| <= z SE(p)
  + the quadrature's own error (the change from 101 to 201 cells per axis);
- test03: every sample's weight is bsdf_eval / bsdf_pdf at its direction, its pdf is
  bsdf_pdf's, and eta is 1 for reflection and the relative IOR for refraction.
"""
import functools

import numpy as np
import pytest

from glrender.scene.model import Material
from glrender.testing.chi2 import ChiSquareTest, SphericalDomain, integrate_cells
from glrender.testing.stats import sidak_z

import bsdf_glsl as G

CASES = {
    "roughconductor-ggx-0.1-30": (Material(kind="roughconductor", distribution="ggx", alpha=(0.1, 0.1)), 30, 0),
    "roughconductor-ggx-0.3-60": (Material(kind="roughconductor", distribution="ggx", alpha=(0.3, 0.3)), 60, 10),
    "roughconductor-ggx-0.7-normal": (Material(kind="roughconductor", distribution="ggx", alpha=(0.7, 0.7)), 0, 0),
    "roughconductor-ggx-aniso-50": (Material(kind="roughconductor", distribution="ggx", alpha=(0.1, 0.4)), 50, 30),
    "roughconductor-beckmann-0.1-45": (Material(kind="roughconductor", alpha=(0.1, 0.1)), 45, 0),
    "roughconductor-beckmann-0.3-grazing": (Material(kind="roughconductor", alpha=(0.3, 0.3)), 85, 0),
    "roughconductor-beckmann-0.7-30": (Material(kind="roughconductor", alpha=(0.7, 0.7)), 30, 200),
    "roughconductor-beckmann-aniso-70": (Material(kind="roughconductor", alpha=(0.4, 0.1)), 70, 120),
    "roughconductor-twosided-below": (Material(kind="roughconductor", distribution="ggx", alpha=(0.3, 0.3),
                                               two_sided=True), 120, 40),
    "roughdielectric-ggx-0.1-30": (Material(kind="roughdielectric", distribution="ggx", alpha=(0.1, 0.1)), 30, 0),
    "roughdielectric-ggx-0.3-inside-40": (Material(kind="roughdielectric", distribution="ggx",
                                                   alpha=(0.3, 0.3)), 140, 0),
    "roughdielectric-ggx-aniso-grazing": (Material(kind="roughdielectric", distribution="ggx",
                                                   alpha=(0.1, 0.5)), 85, 60),
    "roughdielectric-beckmann-0.3-60": (Material(kind="roughdielectric", alpha=(0.3, 0.3)), 60, 0),
    "roughdielectric-beckmann-0.1-inside-tir": (Material(kind="roughdielectric", alpha=(0.1, 0.1)), 120, 0),
    "roughdielectric-beckmann-0.7-inside": (Material(kind="roughdielectric", alpha=(0.7, 0.7),
                                                     int_ior=1.333), 170, 0),
    "plastic-30": (Material(kind="plastic", reflectance=(0.2, 0.5, 0.8)), 30, 0),
    "plastic-nonlinear-80": (Material(kind="plastic", reflectance=(0.9, 0.9, 0.9), nonlinear=True), 80, 0),
    "roughplastic-ggx-0.1-30": (Material(kind="roughplastic", distribution="ggx", alpha=(0.1, 0.1)), 30, 0),
    "roughplastic-ggx-0.7-75": (Material(kind="roughplastic", distribution="ggx", alpha=(0.7, 0.7)), 75, 0),
    "roughplastic-beckmann-0.3-45": (Material(kind="roughplastic", alpha=(0.3, 0.3), nonlinear=True,
                                              reflectance=(0.1, 0.1, 0.1)), 45, 0),
    "roughplastic-beckmann-0.1-grazing": (Material(kind="roughplastic", alpha=(0.1, 0.1)), 85, 0),
    "roughplastic-twosided-below": (Material(kind="roughplastic", distribution="ggx", alpha=(0.3, 0.3),
                                             two_sided=True), 150, 0),
    "diffuse-twosided-below": (Material(kind="diffuse", two_sided=True), 100, 0),
}
SAMPLES = 1_000_000
ALPHA = 0.01
Z = sidak_z(ALPHA, len(CASES))   # two-sided normal quantile, Šidák over this module's cases


def case(name):
    mat, theta, phi = CASES[name]
    return G.record(mat), np.float32(G.direction(theta, phi))


def draw(rec, wo, u3):
    """Directions and their validity (valid and not from a Dirac lobe) for uniforms (N, 3)."""
    s = G.sample(rec, wo, u3[:, 0], u3[:, 1:])
    return s["wi"], s["valid"] & ~s["delta"]


def pdf_func(rec, wo):
    def pdf(wi):
        return G.eval_pdf(rec, np.broadcast_to(wo, wi.shape), wi)[1]
    return pdf


@functools.lru_cache(maxsize=None)
def pdf_integrals(name):
    rec, wo = case(name)
    return tuple(float(integrate_cells(SphericalDomain(), pdf_func(rec, wo), res, 6).sum())
                 for res in (101, 201))


# Beckmann's visible normals need Newton steps and its G1 an erf: those chi-square and
# normalisation tests take 5-7 s each
SLOW_CASES = [pytest.param(name, marks=pytest.mark.slow) if "beckmann" in name else name
              for name in CASES]


@pytest.mark.parametrize("name", SLOW_CASES)
def test01_chi2(gl_ctx, chi2_dir, name):
    rec, wo = case(name)
    seed = sorted(CASES).index(name)
    integral = pdf_integrals(name)[1]
    pdf = pdf_func(rec, wo)

    def conditioned(u):
        wi, ok = draw(rec, wo, u)
        out = [wi[ok]]
        rng = np.random.default_rng(1000 + seed)
        count = ok.sum()
        while count < len(u):
            wi, ok = draw(rec, wo, rng.random((len(u), 3), dtype=np.float32))
            out.append(wi[ok])
            count += ok.sum()
        return np.concatenate(out)[:len(u)]

    test = ChiSquareTest(SphericalDomain(), conditioned, lambda w: pdf(w) / integral, sample_dim=3,
                         sample_count=SAMPLES, seed=seed, alpha=ALPHA, test_count=len(CASES), name=name)
    assert test.run(), "\n".join(test.messages)


@pytest.mark.parametrize("name", SLOW_CASES)
def test02_pdf_integrates_to_the_valid_fraction(gl_ctx, name):
    rec, wo = case(name)
    coarse, fine = pdf_integrals(name)
    u = np.random.default_rng(5000 + sorted(CASES).index(name)).random((SAMPLES, 3), dtype=np.float32)
    p = draw(rec, wo, u)[1].mean()
    se = np.sqrt(max(p * (1 - p), 1.0 / SAMPLES) / SAMPLES)
    # the quadrature's error, plus that of the float32 pdf values it sums (the Beckmann
    # G1 also carries the erf fit's 1.5e-7): 1e-6 of the integral
    quadrature = abs(fine - coarse) + 1e-6
    assert fine <= 1 + quadrature
    assert abs(fine - p) <= Z * se + quadrature, (fine, p, se, quadrature)


@pytest.mark.parametrize("adjoint", [False, True], ids=["radiance", "importance"])
@pytest.mark.parametrize("name", list(CASES))
def test03_weight_is_eval_over_pdf(gl_ctx, name, adjoint):
    rec, wo = case(name)
    u = np.random.default_rng(9).random((20000, 3), dtype=np.float32)
    s = G.sample(rec, wo, u[:, 0], u[:, 1:], adjoint)
    ok = s["valid"] & ~s["delta"]
    assert ok.sum() > 1000
    f, pdf = G.eval_pdf(rec, np.broadcast_to(wo, (ok.sum(), 3)), s["wi"][ok], adjoint)
    assert np.all(pdf > 0)
    np.testing.assert_allclose(s["pdf"][ok], pdf, rtol=1e-5)
    np.testing.assert_allclose(s["weight"][ok], f / pdf[:, None], rtol=1e-5, atol=1e-7)
    through = wo[2] * s["wi"][ok, 2] < 0
    eta = float(rec["params"][2])
    np.testing.assert_allclose(s["eta"][ok], np.where(through, eta if wo[2] > 0 else 1 / eta, 1.0),
                               rtol=1e-6)
    assert np.all(~s["valid"] | np.isfinite(s["weight"]).all(axis=1))
