"""Henyey-Greenstein and isotropic phase functions (shaders/sampling/phase.glsl) beyond the catalogue.

The catalogue (tests/sampling/test_warps.py) runs chi-square, round trip and GLSL against
numpy for g = 0.7 and g = -0.7. Here, over g from -0.99 to 0.99 and near 0: the Legendre
moments of the sampled cosines, E[P_l(cos_theta)] = g^l (l = 1: the mean cosine is g),
the normalisation of hg_phase, and float32 agreement of every routine with its twin.
"""
import numpy as np
import pytest

from glrender.sampling import phase
from glrender.testing.harness import run_glsl
from glrender.testing.stats import sidak_z

EPS32 = 2.0 ** -23
G = (-0.99, -0.7, -0.3, -1e-4, 0.0, 1e-3, 0.3, 0.7, 0.99)
SAMPLES = 1_000_000
INCLUDES = ["sampling/phase.glsl"]
# Legendre polynomials P_1..P_3; Henyey-Greenstein's expansion has coefficients g^l
LEGENDRE = (lambda c: c, lambda c: (3 * c * c - 1) / 2, lambda c: (5 * c ** 3 - 3 * c) / 2)


def _g32(g: float) -> float:
    """g as the shader's float uniform holds it."""
    return float(np.float32(g))


def _unit_vectors(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).standard_normal((n, 3))
    special = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1e-7, -1], [-1, 0, 0]], float)
    v[:len(special)] = special
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def test01_legendre_moments_of_samples_are_powers_of_g(gl_ctx):
    """E[P_l(dot(d, wi))] = g^l for l = 1, 2, 3, with wi from sample_hg_world around a
    random d per sample (every frame_from_z branch). Independent uniforms, so the standard
    error of each mean is the sample standard deviation / sqrt(N); the |difference| must be
    within a Šidák z (alpha = 0.01 over all g and l) standard errors plus float32 rounding
    of the cosines. The standard error of the mean cosine is at most sqrt(1/3) / 1000, so
    a bias of 2e-3 in the mean cosine (0.3% of g = 0.7) is seen."""
    z = sidak_z(0.01, len(G) * len(LEGENDRE))
    for k, g in enumerate(G):
        rng = np.random.default_rng(70 + k)
        u = rng.random((SAMPLES, 2), dtype=np.float32)
        d = _unit_vectors(SAMPLES, 90 + k)
        out = run_glsl("vec3 wi = sample_hg_world(u, g, d);", {"u": u, "d": d}, {"wi": "vec3"},
                       includes=INCLUDES, uniforms={"g": g})
        wi = out["wi"].astype(np.float64)
        assert np.max(np.abs(np.linalg.norm(wi, axis=1) - 1)) <= 16 * EPS32
        cos_theta = np.sum(d.astype(np.float64) * wi, axis=1)
        for order, legendre in enumerate(LEGENDRE, start=1):
            values = legendre(cos_theta)
            stderr = values.std(ddof=1) / np.sqrt(SAMPLES)
            bias = abs(values.mean() - _g32(g) ** order)
            assert bias <= z * stderr + 16 * EPS32, (g, order, values.mean(), stderr)


@pytest.mark.parametrize("g", G)
def test02_glsl_matches_numpy_and_inverts(gl_ctx, g):
    """sample_hg, hg_phase and invert_hg_sample against their float64 twins, and the round
    trip, for |g| up to 0.99 and g near 0 (the inversion has no branch at g = 0)."""
    u = np.random.default_rng(80).random((200_000, 2), dtype=np.float32)
    u[:4] = [[0.0, 0.0], [2.0 ** -24, 0.5], [0.5, 0.25], [1 - 2.0 ** -24, 1 - 2.0 ** -24]]
    out = run_glsl("vec3 p = sample_hg(u, g); float pdf = hg_phase(p.z, g); "
                   "vec2 back = invert_hg_sample(p, g);",
                   {"u": u}, {"p": "vec3", "pdf": "float", "back": "vec2"},
                   includes=INCLUDES, uniforms={"g": g})
    g64, u64 = _g32(g), u.astype(np.float64)
    p = out["p"].astype(np.float64)
    # every step of the inversion is a product or quotient of sums of non-negative terms:
    # a few ulps, then cos / sin of the azimuth
    np.testing.assert_allclose(p, phase.sample_hg(u64, g64), rtol=0, atol=16 * EPS32)
    np.testing.assert_allclose(out["pdf"], phase.hg_phase(p[:, 2], g64), rtol=16 * EPS32, atol=0)
    assert np.all(np.isfinite(out["pdf"])) and np.all(out["pdf"] > 0)
    # u.x = CDF(cos_theta): the float32 rounding of p.z (half an ulp, <= 2^-25 for |z| < 1)
    # moves it by up to 2 pi max(pdf) times that; the azimuth goes through atan
    atan_az = 4e-6 / (2 * np.pi)  # llvmpipe's atan, absolute (glrender.sampling.catalog)
    peak = float(phase.hg_phase(1.0 if g >= 0 else -1.0, g64)[0])
    tol_x = 2 * np.pi * peak * 2.0 ** -24 + 16 * EPS32
    back = out["back"].astype(np.float64)
    assert np.max(np.abs(back[:, 0] - u64[:, 0])) <= tol_x
    pole = (p[:, 0] == 0) & (p[:, 1] == 0)  # u.x = 0 gives cos_theta = -1: no azimuth
    assert np.max(np.abs(back[~pole, 1] - u64[~pole, 1])) <= atan_az + 16 * EPS32
    np.testing.assert_allclose(back[:, 0], phase.invert_hg_sample(p, g64)[:, 0], rtol=0,
                               atol=16 * EPS32)


def test03_world_sampling_is_local_sampling_in_the_frame_of_d(gl_ctx):
    """sample_hg_world(u, g, d) has dot(d, wi) = sample_hg(u, g).z and matches its twin."""
    n = 50_000
    u = np.random.default_rng(81).random((n, 2), dtype=np.float32)
    d = _unit_vectors(n, 82)
    out = run_glsl("vec3 wi = sample_hg_world(u, 0.7, d); vec3 local = sample_hg(u, 0.7);",
                   {"u": u, "d": d}, {"wi": "vec3", "local": "vec3"}, includes=INCLUDES)
    wi = out["wi"].astype(np.float64)
    np.testing.assert_allclose(wi, phase.sample_hg_world(u.astype(np.float64), _g32(0.7),
                                                         d.astype(np.float64)),
                               rtol=0, atol=32 * EPS32)
    np.testing.assert_allclose(np.sum(wi * d, axis=1), out["local"][:, 2], rtol=0, atol=32 * EPS32)


def _graded_gauss_legendre(forward: bool, nodes: int = 24, panels: int = 48):
    """Nodes and weights on [-1, 1] in cos theta, on panels that halve towards +1 (or -1)
    down to 2^-48: Henyey-Greenstein's peak at cos theta = sign(g) is (1 - |g|)^2 / 2|g|
    wide, so each panel holds a smooth piece of it."""
    edges = 1.0 - np.append(2.0 * 0.5 ** np.arange(panels + 1), 0.0)  # -1, 0, 1/2, ..., 1
    x, w = np.polynomial.legendre.leggauss(nodes)
    lo, hi = edges[:-1, None], edges[1:, None]
    c = ((lo + hi) / 2 + (hi - lo) / 2 * x).ravel()
    weights = ((hi - lo) / 2 * w).ravel()
    return (c, weights) if forward else (-c, weights)


@pytest.mark.parametrize("g", G)
def test04_hg_phase_integrates_to_one(gl_ctx, g):
    """2 pi times the integral of hg_phase over cos theta in [-1, 1] is 1 (graded
    Gauss-Legendre, accurate to ~1e-12 here); the GLSL function matches the numpy one at
    the nodes, and at g = 0 it is isotropic_phase() = 1 / (4 pi)."""
    c, weights = _graded_gauss_legendre(forward=g >= 0)
    integral = 2 * np.pi * np.sum(weights * phase.hg_phase(c, _g32(g)))
    assert abs(integral - 1.0) <= 1e-9
    c32 = c.astype(np.float32)
    out = run_glsl("float pdf = hg_phase(c, g); float iso = isotropic_phase();", {"c": c32},
                   {"pdf": "float", "iso": "float"}, includes=INCLUDES, uniforms={"g": g})
    np.testing.assert_allclose(out["pdf"], phase.hg_phase(c32, _g32(g)), rtol=16 * EPS32, atol=0)
    assert np.all(out["iso"] == np.float32(1 / (4 * np.pi)))
    if g == 0.0:
        assert np.all(out["pdf"] == out["iso"])
