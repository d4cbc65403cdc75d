"""GGX and Beckmann microfacet distributions: normalisation, Smith masking, the GLSL code
against its numpy twin, and the Beckmann slope sampler against its exact CDF.

Visible-normal sampling itself is chi-square tested in test_warps.py. Integrals here are
Gauss-Legendre quadratures over the sphere (glrender.testing.chi2.pdf_integral): exact to
~1e-5 for these smooth densities, so 1e-3 is a float-safe bound that still catches any
missing factor (a wrong normalisation is off by tens of percent).
"""
import math

import numpy as np
import pytest
from scipy import special

from glrender.sampling import microfacet as mf
from glrender.sampling.erf import erf_approx, erf_inv_approx
from glrender.testing.chi2 import SphericalDomain, pdf_integral
from glrender.testing.harness import run_glsl

ALPHAS = [(0.3, 0.6), (0.5, 0.2), (1.0, 1.0), (0.15, 0.15)]
MODELS = {"ggx": (mf.ggx_d, mf.ggx_g1, mf.ggx_lambda, mf.ggx_g2, mf.ggx_visible_normal_pdf),
          "beckmann": (mf.beckmann_d, mf.beckmann_g1, mf.beckmann_lambda, mf.beckmann_g2,
                       mf.beckmann_visible_normal_pdf)}
INCLUDE = ["sampling/microfacet.glsl"]


def unit(*v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def random_directions(n, seed, upper=True):
    w = np.random.default_rng(seed).standard_normal((n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    if upper:
        w[:, 2] = np.abs(w[:, 2])
    return w


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("alpha", ALPHAS)
def test01_projected_normal_distribution_integrates_to_one(model, alpha):
    d = MODELS[model][0]
    total = pdf_integral(SphericalDomain(), lambda w: d(w, alpha) * np.maximum(w[:, 2], 0.0),
                         res=61, ires=6)
    assert total == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("theta_deg", [0.0, 45.0, 80.0, 89.0])
def test02_visible_normals_integrate_to_one(model, theta_deg):
    """Smith's G1 is what makes D_wo a density: integral of G1(wo) max(0, wo.wm) D(wm)
    over wm equals cos theta_o, for every wo (Heitz 2014, eq. 18)."""
    t = math.radians(theta_deg)
    wo = unit(math.sin(t) * 0.6, math.sin(t) * 0.8, math.cos(t))
    pdf = MODELS[model][4]
    assert pdf_integral(SphericalDomain(), lambda w: pdf(wo, w, (0.3, 0.6)), res=61, ires=6) == \
        pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("model", MODELS)
def test03_known_values(gl_ctx, model):
    d, g1, lam, g2, _ = MODELS[model]
    alpha = (0.3, 0.6)
    z, grazing = np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]])
    assert d(z, alpha)[0] == pytest.approx(1 / (math.pi * 0.3 * 0.6), rel=1e-12)
    assert g1(z, alpha)[0] == 1.0 and lam(z, alpha)[0] == 0.0
    assert g1(grazing, alpha)[0] == 0.0 and d(-z, alpha)[0] == 0.0
    out = run_glsl(f"float dz = {model}_d(vec3(0, 0, 1), a); float g1z = {model}_g1(vec3(0, 0, 1), a);"
                   f"float g1x = {model}_g1(vec3(1, 0, 0), a); float lz = {model}_lambda(vec3(0, 0, 1), a);",
                   n=1, outputs={"dz": "float", "g1z": "float", "g1x": "float", "lz": "float"},
                   includes=INCLUDE, uniforms={"a": ("vec2", alpha)})
    assert out["dz"][0] == pytest.approx(1 / (math.pi * 0.18), rel=2 ** -22)
    assert out["g1z"][0] == 1.0 and out["g1x"][0] == 0.0 and out["lz"][0] == 0.0
    # height-correlated G2 lies between the uncorrelated product and the smaller G1
    wo, wi = random_directions(10_000, 1), random_directions(10_000, 2)
    lo, hi = g1(wo, alpha) * g1(wi, alpha), np.minimum(g1(wo, alpha), g1(wi, alpha))
    assert np.all((g2(wo, wi, alpha) >= lo - 1e-12) & (g2(wo, wi, alpha) <= hi + 1e-12))


@pytest.mark.parametrize("model", MODELS)
def test04_glsl_matches_numpy(gl_ctx, model):
    d, g1, lam, g2, vpdf = MODELS[model]
    wo, wi = random_directions(100_000, 3), random_directions(100_000, 4)
    wm = random_directions(100_000, 5)
    alpha = (0.3, 0.6)
    out = run_glsl(f"float d = {model}_d(wm, a); float g1 = {model}_g1(wo, a); "
                   f"float lam = {model}_lambda(wo, a); float g2 = {model}_g2(wo, wi, a); "
                   f"float vpdf = {model}_visible_normal_pdf(wo, wm, a);",
                   {"wo": wo.astype(np.float32), "wi": wi.astype(np.float32),
                    "wm": wm.astype(np.float32)},
                   {k: "float" for k in ("d", "g1", "lam", "g2", "vpdf")}, includes=INCLUDE,
                   uniforms={"a": ("vec2", alpha)})
    f32 = {k: v.astype(np.float32).astype(np.float64) for k, v in (("wo", wo), ("wi", wi), ("wm", wm))}
    # relative errors of a few ulps per operation; D's exponent (Beckmann) and the
    # 1 / cos^4 amplify them near the horizon: judged where D is not vanishingly small
    ref_d = d(f32["wm"], alpha)
    big = ref_d > 1e-6 * ref_d.max()
    np.testing.assert_allclose(out["d"][big], ref_d[big], rtol=1e-4)
    np.testing.assert_allclose(out["g1"], g1(f32["wo"], alpha), rtol=0, atol=1e-6)
    np.testing.assert_allclose(out["g2"], g2(f32["wo"], f32["wi"], alpha), rtol=0, atol=1e-6)
    finite = np.isfinite(lam(f32["wo"], alpha)) & (f32["wo"][:, 2] > 1e-3)
    np.testing.assert_allclose(out["lam"][finite], lam(f32["wo"], alpha)[finite], rtol=1e-4, atol=1e-6)
    # D_wo has the factor max(0, wo.wm), whose rounding is absolute (~eps): an absolute
    # bound of 1e-6 of the largest value covers it where wo.wm nearly vanishes
    ref_v = vpdf(f32["wo"], f32["wm"], alpha)
    np.testing.assert_allclose(out["vpdf"], ref_v, rtol=1e-4, atol=1e-6 * ref_v.max())


def test05_erf_and_its_inverse(gl_ctx):
    x = np.linspace(-5, 5, 200_001).astype(np.float32)
    y = np.linspace(-1, 1, 200_001)[1:-1].astype(np.float32)
    out = run_glsl("float e = erf_approx(x);", {"x": x}, {"e": "float"}, includes=["sampling/erf.glsl"])
    ref = special.erf(x.astype(np.float64))
    # A&S's bound 1.5e-7, plus float32 evaluation: Horner's five roundings of terms up to
    # ~1.5 in size (~1.5 * 2^-24 each), and exp's few ulps
    assert np.max(np.abs(out["e"] - ref)) <= 1.5e-7 + 8 * 1.5 * 2 ** -24
    assert np.max(np.abs(erf_approx(x) - ref)) <= 1.5e-7
    out = run_glsl("float e = erf_inv_approx(y);", {"y": y}, {"e": "float"},
                   includes=["sampling/erf.glsl"])
    ref = special.erfinv(y.astype(np.float64))
    # Giles' fit: a few float32 ulps relative; the log of (1 - y)(1 + y) adds rounding
    # near |y| = 1, where erf_inv is steep
    np.testing.assert_allclose(out["e"], ref, rtol=2e-6, atol=2e-7)
    np.testing.assert_allclose(erf_inv_approx(y), ref, rtol=2e-6, atol=2e-7)


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 60.0, 80.0, 88.0])
def test06_beckmann_slopes_invert_their_cdf(gl_ctx, theta_deg):
    """The visible-slope sampler inverts the exact (float64) slope CDF of Heitz & d'Eon:
    |CDF(x) - u.x| stays within the Newton stopping tolerance 1e-6 plus erf's error."""
    cos_theta = math.cos(math.radians(theta_deg))
    u = np.random.default_rng(6).random((200_000, 2), dtype=np.float32)
    out = run_glsl("vec2 s = beckmann_sample_slopes_11(c, u);", {"u": u}, {"s": "vec2"},
                   includes=INCLUDE, uniforms={"c": cos_theta})
    x, y = out["s"][:, 0].astype(np.float64), out["s"][:, 1].astype(np.float64)
    ux, uy = np.maximum(u[:, 0], 1e-6), np.maximum(u[:, 1], 1e-6)
    if cos_theta > 0.9999:  # normal incidence: a 2D Gaussian of variance 1/2 per axis
        r2 = x * x + y * y
        np.testing.assert_allclose(1 - np.exp(-r2), u[:, 0], rtol=0, atol=4e-6)
        return
    tan_t = math.tan(math.radians(theta_deg))
    cot_t = 1 / tan_t

    def cdf(v):
        return 1 + special.erf(v) + tan_t / math.sqrt(math.pi) * np.exp(-v * v)
    assert np.all(x <= cot_t + 1e-5)  # only slopes facing wo are visible
    np.testing.assert_allclose(cdf(x) / cdf(cot_t), ux, rtol=0, atol=4e-6)
    np.testing.assert_allclose(0.5 * (1 + special.erf(y)), uy, rtol=0, atol=1e-6)
