"""Parity with Mitsuba 3's scalar_rgb BSDFs: eval and pdf of every model, delta samples.

Each Material is packed as the renderer packs it and evaluated by shaders/bsdf/bsdf.glsl;
Mitsuba evaluates the same parameters (bsdf_mitsuba.py). Both sides compute in float32,
so the tolerance is float32's, per pair:
    |ours - mitsuba| <= 4 S + |mitsuba| (128 eps (1 + A) + R) + 1e-12 max|mitsuba|
- S: how far Mitsuba's own value moves when the float32 inputs move by 2 ulps (four
  random perturbations): the conditioning of the pair (near the critical angle, or the
  peak of a narrow lobe, one ulp of input moves the value by many ulps);
- 128 eps: the rounding of some hundred float operations (eps = 2^-24);
- A: the growth of that rounding in factors 1 - F(cos) that cancel (F -> 1 at grazing
  angles and near total internal reflection): (1 + 1 / cos_t) / (1 - F), for plastic's
  coating at wo and wi and roughdielectric's refraction at the half vector;
- R: roughplastic's tables, computed on the host in float64 and by Mitsuba in float32,
  agree to 4e-6 (test_materials.py); R carries that through T_o T_i and the lobe choice;
- the last term only absorbs Mitsuba's 1e-20 cut-off of D and float32 underflow.
A wrong constant, convention or formula moves values by far more (e.g. the 1 / eta^2
of radiance vs importance, a missing Fresnel factor, separable vs height-correlated G:
percent-level changes), as test05 demonstrates.

Beckmann pdfs: ours is the exact density of visible-normal sampling, with the exact
Smith G1 of wo; Mitsuba's pdf uses its rational fit of G1 there (sampling/microfacet
docs in bsdf/microfacet_distribution.glsl). The test converts Mitsuba's pdf with the
ratio G1_exact(wo) / G1_rational(wo) (computed in float64) before comparing.
"""
import numpy as np
import pytest

from glrender.gpu.pack import pack_material
from glrender.sampling import microfacet as nmf
from glrender.scene.model import Material

import bsdf_glsl as G
import bsdf_mitsuba as M
from bsdf_reference import EPS, fresnel_conditioning, fresnel_reference

AU = dict(eta=(0.14303598, 0.37530708, 1.4420453), k=(3.982997, 2.3855565, 1.6033592))
CU = dict(eta=(0.20100547, 0.9237495, 1.1022154), k=(3.913262, 2.453045, 2.142090))
TINT = (0.9, 0.6, 0.3)

MATERIALS = {
    "roughconductor-ggx-0.1": Material(kind="roughconductor", distribution="ggx", alpha=(0.1, 0.1), **AU),
    "roughconductor-ggx-0.3-tint": Material(kind="roughconductor", distribution="ggx", alpha=(0.3, 0.3),
                                            specular_reflectance=TINT, **CU),
    "roughconductor-ggx-0.7": Material(kind="roughconductor", distribution="ggx", alpha=(0.7, 0.7), **AU),
    "roughconductor-ggx-aniso": Material(kind="roughconductor", distribution="ggx", alpha=(0.05, 0.4), **CU),
    "roughconductor-beckmann-0.1": Material(kind="roughconductor", alpha=(0.1, 0.1), **AU),
    "roughconductor-beckmann-0.3": Material(kind="roughconductor", alpha=(0.3, 0.3), **CU),
    "roughconductor-beckmann-aniso": Material(kind="roughconductor", alpha=(0.4, 0.1), **AU),
    "roughconductor-ggx-twosided": Material(kind="roughconductor", distribution="ggx", alpha=(0.3, 0.3),
                                            two_sided=True, **AU),
    "roughdielectric-ggx-0.1": Material(kind="roughdielectric", distribution="ggx", alpha=(0.1, 0.1)),
    "roughdielectric-ggx-0.3-tint": Material(kind="roughdielectric", distribution="ggx", alpha=(0.3, 0.3),
                                             specular_reflectance=TINT, specular_transmittance=(0.2, 0.5, 0.8)),
    "roughdielectric-ggx-0.7-diamond": Material(kind="roughdielectric", distribution="ggx", alpha=(0.7, 0.7),
                                                int_ior=2.419),
    "roughdielectric-ggx-aniso": Material(kind="roughdielectric", distribution="ggx", alpha=(0.1, 0.5)),
    "roughdielectric-beckmann-0.3-water": Material(kind="roughdielectric", alpha=(0.3, 0.3), int_ior=1.333),
    "roughdielectric-beckmann-aniso-inverted": Material(kind="roughdielectric", alpha=(0.5, 0.2),
                                                        int_ior=1.0, ext_ior=1.5046),
    "plastic": Material(kind="plastic", reflectance=(0.2, 0.5, 0.8), int_ior=1.49),
    "plastic-nonlinear-tint": Material(kind="plastic", reflectance=(0.2, 0.5, 0.8), nonlinear=True,
                                       specular_reflectance=TINT, int_ior=1.9),
    "plastic-twosided": Material(kind="plastic", reflectance=(0.7, 0.1, 0.1), two_sided=True, int_ior=1.49),
    "roughplastic-ggx-0.1": Material(kind="roughplastic", distribution="ggx", alpha=(0.1, 0.1),
                                     reflectance=(0.2, 0.5, 0.8), int_ior=1.49),
    "roughplastic-ggx-0.3-nonlinear": Material(kind="roughplastic", distribution="ggx", alpha=(0.3, 0.3),
                                               reflectance=(0.2, 0.5, 0.8), nonlinear=True, int_ior=1.49),
    "roughplastic-ggx-0.7-tint": Material(kind="roughplastic", distribution="ggx", alpha=(0.7, 0.7),
                                          reflectance=(0.9, 0.9, 0.2), specular_reflectance=TINT, int_ior=1.6),
    "roughplastic-beckmann-0.1": Material(kind="roughplastic", alpha=(0.1, 0.1), reflectance=(0.2, 0.5, 0.8),
                                          int_ior=1.49),
    "roughplastic-beckmann-0.3-twosided": Material(kind="roughplastic", alpha=(0.3, 0.3), two_sided=True,
                                                   reflectance=(0.5, 0.5, 0.5), int_ior=1.33),
    "diffuse-twosided": Material(kind="diffuse", reflectance=(0.2, 0.5, 0.8), two_sided=True),
}


def direction_pairs(seed, n=3000):
    """Pairs over the whole sphere: half uniform, half near the mirror or refracted
    direction (where the lobes are), rounded to float32."""
    rng = np.random.default_rng(seed)
    wo = G.uniform_sphere(n, rng)
    wi = G.uniform_sphere(n, rng)
    k = n // 3
    wi[:k] = wo[:k] * [-1, -1, 1] + 0.15 * rng.standard_normal((k, 3))   # near the mirror
    wi[k:2 * k] = -wo[k:2 * k] + 0.3 * rng.standard_normal((k, 3))       # near transmission
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    return wo.astype(np.float32).astype(np.float64), wi.astype(np.float32).astype(np.float64)


def perturbation_spread(bsdf, wo, wi, adjoint, rng, count=4):
    f0, p0 = M.eval_pdf(bsdf, wo, wi, adjoint)
    sf, sp = np.zeros_like(f0), np.zeros_like(p0)
    for _ in range(count):
        a = (wo * (1 + rng.choice([-2.0, 2.0], wo.shape) * 2.0 ** -23)).astype(np.float32)
        b = (wi * (1 + rng.choice([-2.0, 2.0], wi.shape) * 2.0 ** -23)).astype(np.float32)
        f, p = M.eval_pdf(bsdf, a.astype(np.float64), b.astype(np.float64), adjoint)
        sf, sp = np.maximum(sf, np.abs(f - f0)), np.maximum(sp, np.abs(p - p0))
    return f0, p0, sf, sp


TABLE_ACCURACY = 4e-6  # roughplastic tables vs Mitsuba's own (test_materials.py)


def rounding_amplification(mat, wo, wi):
    """(A, R) per pair: A multiplies the float32 rounding term of the tolerance where a
    1 - F factor cancels; R is the relative error the roughplastic tables carry (host
    float64 quadrature vs Mitsuba's float32 one), through T_o T_i and the lobe choice."""
    eta = mat.int_ior / mat.ext_ior
    zero = np.zeros(len(wo))
    if mat.kind == "plastic":
        return fresnel_conditioning(wo[:, 2], eta) + fresnel_conditioning(wi[:, 2], eta), zero
    if mat.kind == "roughdielectric":
        n = np.where(wo[:, 2] > 0, eta, 1 / eta)
        m = wo + wi * n[:, None]
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        cos_m = np.abs(np.sum(wo * m, axis=1))
        through = wo[:, 2] * wi[:, 2] < 0
        return np.where(through, fresnel_conditioning(cos_m, n), 0.0), zero
    if mat.kind == "roughplastic":
        t = pack_material(mat)["table"].astype(np.float64)
        t_o = np.interp(np.abs(wo[:, 2]), np.linspace(0, 1, 64), t)
        with np.errstate(divide="ignore"):
            return zero, TABLE_ACCURACY * (2 + 1 / np.maximum(1 - t_o, 1e-6) + 1 / np.maximum(t_o, 1e-6))
    return zero, zero


def tolerance(ref, spread, amp, rel):
    """test01's bound; ref, spread (N,) or (N, 3); amp, rel (N,)."""
    if ref.ndim == 2:
        amp, rel = amp[:, None], rel[:, None]
    return 4 * spread + np.abs(ref) * (128 * EPS * (1 + amp) + rel) + 1e-12 * np.abs(ref).max()


def beckmann_g1_rational(v, alpha):
    a = 1.0 / np.sqrt(nmf.microfacet_alpha2_tan2(v, alpha))
    g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))
    return np.where(np.isinf(a), 1.0, g)


def mitsuba_pdf_with_exact_g1(mat, wo, wi, pdf_mi):
    """Mitsuba's pdf with its rational Beckmann G1(wo) replaced by the exact G1."""
    if mat.distribution != "beckmann" or not mat.kind.startswith("rough"):
        return pdf_mi
    below = (wo[:, 2] < 0)[:, None]
    if mat.kind == "roughdielectric":      # seen from inside: the whole frame flips
        wo_up, wi_up = np.where(below, -wo, wo), np.where(below, -wi, wi)
    elif mat.two_sided:                    # twosided mirrors z only
        wo_up, wi_up = np.where(below, wo * [1, 1, -1], wo), np.where(below, wi * [1, 1, -1], wi)
    else:
        wo_up, wi_up = wo, wi
    alpha = np.broadcast_to(np.asarray(mat.alpha, np.float64), (2,))
    with np.errstate(all="ignore"):
        ratio = nmf.beckmann_g1(wo_up, alpha) / beckmann_g1_rational(wo_up, alpha)
        if mat.kind != "roughplastic":
            return np.where(pdf_mi > 0, pdf_mi * ratio, pdf_mi)
        # roughplastic: only the glossy part of the mixture carries G1(wo)
        rec = pack_material(mat)
        t_o = np.interp(wo_up[:, 2], np.linspace(0, 1, 64), rec["table"].astype(np.float64))
        w = float(rec["color2"][0])
        p_s = (1 - t_o) * w / ((1 - t_o) * w + t_o * (1 - w))
        m = wo_up + wi_up
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        glossy = nmf.beckmann_d(m, alpha) * beckmann_g1_rational(wo_up, alpha) / (4 * wo_up[:, 2])
        return np.where(pdf_mi > 0, pdf_mi + p_s * glossy * (ratio - 1.0), pdf_mi)


EVAL_CASES = [(name, False) for name in MATERIALS] + \
    [(name, True) for name, mat in MATERIALS.items() if mat.kind == "roughdielectric"]


@pytest.mark.parametrize("name, adjoint", EVAL_CASES,
                         ids=[f"{n}-{'importance' if a else 'radiance'}" for n, a in EVAL_CASES])
def test01_eval_and_pdf(gl_ctx, name, adjoint):
    """Importance transport differs from radiance only for refraction (test02)."""
    mat = MATERIALS[name]
    seed = sorted(MATERIALS).index(name)
    wo, wi = direction_pairs(seed)
    bsdf = M.load(mat)
    f_mi, pdf_mi, s_f, s_pdf = perturbation_spread(bsdf, wo, wi, adjoint, np.random.default_rng(seed))
    f, pdf = G.eval_pdf(mat, wo, wi, adjoint)
    amp, rel = rounding_amplification(mat, wo, wi)
    assert np.count_nonzero(f_mi.max(axis=1) > 0) > len(wo) // 10   # the test sees the lobes
    bad = np.abs(f - f_mi) > tolerance(f_mi, s_f, amp, rel)
    assert not bad.any(), (f"eval differs at {np.count_nonzero(bad.any(axis=1))} pairs, e.g. wo="
                           f"{wo[bad.any(axis=1)][0]} wi={wi[bad.any(axis=1)][0]}: "
                           f"{f[bad.any(axis=1)][0]} vs {f_mi[bad.any(axis=1)][0]}")
    ref = mitsuba_pdf_with_exact_g1(mat, wo, wi, pdf_mi)
    bad = np.abs(pdf - ref) > tolerance(ref, s_pdf, amp, rel)
    assert not bad.any(), (f"pdf differs at {np.count_nonzero(bad)} pairs, e.g. wo={wo[bad][0]} "
                           f"wi={wi[bad][0]}: {pdf[bad][0]} vs {ref[bad][0]}")


@pytest.mark.parametrize("name", ["roughconductor-ggx-0.3-tint", "plastic", "roughplastic-ggx-0.1"])
def test02_reflection_models_are_the_same_for_importance(gl_ctx, name):
    mat = MATERIALS[name]
    wo, wi = direction_pairs(99, 500)
    f_r, pdf_r = G.eval_pdf(mat, wo, wi, adjoint=False)
    f_i, pdf_i = G.eval_pdf(mat, wo, wi, adjoint=True)
    assert np.array_equal(f_r, f_i) and np.array_equal(pdf_r, pdf_i)


DELTA = {
    "conductor-au": Material(kind="conductor", **AU),
    "conductor-cu-tint": Material(kind="conductor", specular_reflectance=TINT, **CU),
    "conductor-none": Material(kind="conductor"),
    "conductor-twosided": Material(kind="conductor", two_sided=True, **AU),
    "dielectric-bk7": Material(kind="dielectric"),
    "dielectric-diamond-tint": Material(kind="dielectric", int_ior=2.419, specular_reflectance=TINT,
                                        specular_transmittance=(0.2, 0.5, 0.8)),
    "dielectric-inverted": Material(kind="dielectric", int_ior=1.0, ext_ior=1.333),
    "thindielectric": Material(kind="thindielectric"),
    "thindielectric-tint": Material(kind="thindielectric", int_ior=1.7, specular_reflectance=TINT,
                                    specular_transmittance=(0.2, 0.5, 0.8)),
    "plastic-specular": Material(kind="plastic", reflectance=(0.2, 0.5, 0.8), specular_reflectance=TINT,
                                 int_ior=1.49),
}


@pytest.mark.parametrize("adjoint", [False, True], ids=["radiance", "importance"])
@pytest.mark.parametrize("name", list(DELTA))
def test03_delta_samples(gl_ctx, name, adjoint):
    """Sampled direction, weight, discrete probability and eta of the Dirac lobes, for
    random wo on both sides and u_lobe away from the lobe boundary (within 1e-4 of it
    the two float32 implementations may round F differently)."""
    mat = DELTA[name]
    rng = np.random.default_rng(sorted(DELTA).index(name))
    wo = G.uniform_sphere(4000, rng).astype(np.float32).astype(np.float64)
    u_lobe = rng.random(4000).astype(np.float32).astype(np.float64)
    u = rng.random((4000, 2)).astype(np.float32).astype(np.float64)
    ours = G.sample(mat, wo, u_lobe, u, adjoint)
    mit = M.sample(M.load(mat), wo, u_lobe, u, adjoint)
    eta = mat.int_ior / mat.ext_ior
    c = np.abs(wo[:, 2])
    if mat.kind == "dielectric":
        n = np.where(wo[:, 2] >= 0, eta, 1 / eta)
        boundary = fresnel_reference(c, n)
    elif mat.kind == "thindielectric":
        F = fresnel_reference(c, np.full_like(c, eta))
        boundary = 2 * F / (1 + F)
    elif mat.kind == "plastic":
        F = fresnel_reference(c, np.full_like(c, eta))
        w = float(pack_material(mat)["color2"][0])
        boundary = F * w / (F * w + (1 - F) * (1 - w))
    else:
        boundary = np.full_like(c, 2.0)
    keep = (np.abs(u_lobe - boundary) > 1e-4) & (np.abs(wo[:, 2]) > 1e-3)
    if mat.kind == "plastic":   # its Dirac lobe; the diffuse lobe is test01's
        keep &= u_lobe < boundary
        assert ours["delta"][keep & (wo[:, 2] > 0)].all()
    mit_ok = np.abs(mit["weight"]).max(axis=1) > 0
    ours_ok = ours["valid"] & (np.abs(ours["weight"]).max(axis=1) > 0)
    assert np.array_equal(ours_ok[keep], mit_ok[keep])   # e.g. a conductor seen from below
    k = keep & mit_ok
    assert k.sum() > 200
    np.testing.assert_allclose(ours["wi"][k], mit["wi"][k], atol=64 * EPS)
    np.testing.assert_allclose(ours["weight"][k], mit["weight"][k], rtol=256 * EPS, atol=1e-7)
    np.testing.assert_allclose(ours["pdf"][k], mit["pdf"][k], rtol=256 * EPS)
    np.testing.assert_allclose(ours["eta"][k], mit["eta"][k], rtol=4 * EPS)


@pytest.mark.parametrize("name", ["Au", "Cu", "Al", "Ag", "Cr", "W", "TiN", "none"])
def test04_named_conductors_are_mitsubas(gl_ctx, name):
    """material = "Au" gives Mitsuba's own RGB reduction of its spectral tables."""
    from glrender.scene.materials import conductor_ior

    eta, k = conductor_ior(name)
    bsdf = M.mi.load_dict({"type": "conductor", "material": name})
    params = M.mi.traverse(bsdf)
    if name == "none":
        assert (eta, k) == ((0.0,) * 3, (1.0,) * 3)
        return
    np.testing.assert_array_equal(np.float32(eta), np.float32(list(params["eta.value"])))
    np.testing.assert_array_equal(np.float32(k), np.float32(list(params["k.value"])))


def _replace(mat, **changes):
    return Material(**{**mat.__dict__, **changes})


def _height_correlated(mat, wo, wi):
    """roughconductor with Smith's height-correlated G2 instead of the separable G."""
    f, _ = G.eval_pdf(mat, wo, wi)
    up = (wo[:, 2] > 0) & (wi[:, 2] > 0)
    alpha = mat.alpha
    with np.errstate(all="ignore"):
        ratio = nmf.ggx_g2(wo, wi, alpha) / (nmf.ggx_g1(wo, alpha) * nmf.ggx_g1(wi, alpha))
    return f * np.where(up, ratio, 1.0)[:, None]


CHANGES = {
    "importance-transport": ("roughdielectric-ggx-0.3-tint",
                             lambda mat, wo, wi: G.eval_pdf(mat, wo, wi, adjoint=True)[0]),
    "eta+1%": ("roughdielectric-ggx-0.3-tint",
               lambda mat, wo, wi: G.eval_pdf(_replace(mat, int_ior=mat.int_ior * 1.01), wo, wi)[0]),
    "height-correlated-G": ("roughconductor-ggx-0.3-tint", _height_correlated),
    "nonlinear-off": ("plastic-nonlinear-tint",
                      lambda mat, wo, wi: G.eval_pdf(_replace(mat, nonlinear=False), wo, wi)[0]),
}


@pytest.mark.parametrize("change", list(CHANGES))
def test05_the_tolerance_sees_model_errors(gl_ctx, change):
    """Small modelling errors fail test01's tolerance at many of the pairs it tests."""
    name, modified = CHANGES[change]
    mat = MATERIALS[name]
    wo, wi = direction_pairs(7)
    f_mi, _, s_f, _ = perturbation_spread(M.load(mat), wo, wi, False, np.random.default_rng(7))
    tol = tolerance(f_mi, s_f, *rounding_amplification(mat, wo, wi))
    f_exact, _ = G.eval_pdf(mat, wo, wi)
    assert not (np.abs(f_exact - f_mi) > tol).any()
    bad = (np.abs(modified(mat, wo, wi) - f_mi) > tol).any(axis=1)
    assert np.count_nonzero(bad) > len(wo) // 20
