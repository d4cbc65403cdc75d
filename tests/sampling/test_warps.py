"""Every continuous warp of the catalogue: chi-square goodness of fit against its pdf, pdf
integral, round trip through its inverse, GLSL against its numpy twin; broken warps fail.

Each warp runs once in GLSL on 10^6 fixed-seed uniforms (a module-scoped fixture, so
pytest runs all checks of one warp before the next and memory stays small). The
chi-square tests of this module form one Šidák family at alpha = 0.01: a correct
library fails it with probability 0.01 (with fixed seeds: never flips run to run).
With 10^6 samples and 101^2 cells the test sees a density error of ~2% spread over a
tenth of the domain (the broken warps below are rejected with p < 1e-20).
Tolerances are stated per warp in glrender/sampling/catalog.py, derived from float32
and the driver's atan precision.
"""
import numpy as np
import pytest

from glrender.sampling import spherical_rectangle as sr
from glrender.sampling import spherical_triangle as st
from glrender.sampling.catalog import ATAN_REL, CATALOG, Warp, run_warp
from glrender.testing.chi2 import ChiSquareTest, SphericalDomain, pdf_integral
from glrender.testing.harness import run_glsl
from glrender.testing.stats import sidak_alpha

SAMPLES = 1_000_000
AGREE = 200_000                 # GLSL / numpy comparisons on the first samples
CHI2_FAMILY = len(CATALOG)      # the Šidák family: every correct warp of this module


class WarpRun:
    def __init__(self, warp: Warp, seed: int):
        self.warp = warp
        self.out: dict = {}
        self.u = None

        def sample(u):
            self.u = u
            self.out = run_warp(warp, u)
            return warp.to_domain(self.out["p"].astype(np.float64))

        self.test = ChiSquareTest(warp.domain, sample, warp.pdf, sample_dim=warp.sample_dim,
                                  sample_count=SAMPLES, res=warp.res, seed=seed,
                                  test_count=CHI2_FAMILY, name=warp.name)
        self.ok = self.test.run()


@pytest.fixture(scope="module", params=CATALOG, ids=lambda w: w.name)
def warp_run(request, gl_ctx, tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GLRENDER_CHI2_DIR", str(tmp_path_factory.mktemp("chi2")))
        run = WarpRun(request.param, seed=1000 + CATALOG.index(request.param))
    yield run


def test01_chi2_goodness_of_fit(warp_run):
    assert warp_run.ok, warp_run.test.messages


def test02_pdf_integrates_to_one(warp_run):
    warp = warp_run.warp
    # Gauss-Legendre, 6 x 6 nodes per chi-square cell, 48 x 48 where the pdf jumps
    assert abs(pdf_integral(warp.domain, warp.pdf, res=warp.res, ires=6) - 1.0) <= 1e-3


def test03_invert_sample_round_trip(warp_run):
    warp, u, out = warp_run.warp, warp_run.u, warp_run.out
    if warp.invert_glsl is None:  # rejection, max of uniforms, Urena, Beckmann: no inverse
        assert warp.invert is None and "u_back" not in out
        return
    u = u.astype(np.float64)
    back = out["u_back"].astype(np.float64).reshape(u.shape)
    keep = warp.well_conditioned(u)
    assert keep.mean() > 0.97  # the excluded neighbourhoods of singular points are small
    error = np.max(np.abs(back - u).reshape(len(u), -1), axis=1)
    worst = np.argmax(np.where(keep, error, 0))
    assert error[keep].max() <= warp.roundtrip_tol, (u[worst], back[worst])


def test04_glsl_matches_numpy(warp_run):
    warp, out = warp_run.warp, warp_run.out
    u = warp_run.u[:AGREE].astype(np.float64)
    p = out["p"][:AGREE].astype(np.float64)
    p_np = np.asarray(warp.sample(u)).reshape(p.shape)
    np.testing.assert_allclose(p, p_np, rtol=0, atol=warp.agree_tol)
    # the GLSL pdf function at the GLSL points, against the numpy pdf there
    pdf_np = warp.pdf(warp.to_domain(p))
    np.testing.assert_allclose(out["pdf"][:AGREE], pdf_np, rtol=warp.pdf_tol, atol=0)
    # samplers that return their density agree with their pdf function
    returned = out["sample_pdf"] >= 0
    np.testing.assert_allclose(out["sample_pdf"][returned], out["pdf"][returned],
                               rtol=warp.pdf_tol, atol=0)
    if warp.invert is not None:
        keep = warp.well_conditioned(u)
        back = out["u_back"][:AGREE].astype(np.float64).reshape(u.shape)
        back_np = np.asarray(warp.invert(p)).reshape(u.shape)
        np.testing.assert_allclose(back[keep], back_np[keep], rtol=0, atol=warp.roundtrip_tol)


# -- broken warps (kept only here) are rejected ------------------------------------------------
BROKEN_PREAMBLE = """
// Spherical triangle with the arc b-c' sampled uniformly in angle (not in 1 - cos theta).
vec3 broken_spherical_triangle(vec3 v0, vec3 v1, vec3 v2, vec3 p, vec2 u) {
    float pdf;
    vec3 w = sample_spherical_triangle(v0, v1, v2, p, vec2(u.x, 0.0), pdf);  // = b
    vec3 c_end = sample_spherical_triangle(v0, v1, v2, p, vec2(u.x, kOneMinusEpsilon), pdf);
    float theta = u.y * acos(clamp(dot(w, c_end), -1.0, 1.0));
    return cos(theta) * w + sin(theta) * normalize(c_end - dot(c_end, w) * w);
}
// GGX visible normals without Heitz's half-disk compression: the projected-area weight
// max(0, wo.wm) is lost for oblique wo.
vec3 broken_ggx_visible_normal(vec3 wo, vec2 alpha, vec2 u) {
    vec3 wh = normalize(vec3(alpha * wo.xy, wo.z));
    vec3 t1 = normalize(vec3(-wh.y, wh.x, 0.0));
    vec3 t2 = cross(wh, t1);
    vec2 d = sample_uniform_disk_polar(u);
    vec3 nh = d.x * t1 + d.y * t2 + sqrt(max(0.0, 1.0 - dot(d, d))) * wh;
    return normalize(vec3(alpha * nh.xy, max(1e-6, nh.z)));
}
"""


def _broken(name: str, sample_glsl: str, base: str) -> Warp:
    from dataclasses import replace
    warp = next(w for w in CATALOG if w.name == base)
    return replace(warp, name=name, sample_glsl=sample_glsl, preamble=BROKEN_PREAMBLE,
                   includes=warp.includes + ("sampling/spherical_triangle.glsl",
                                             "sampling/microfacet.glsl"),
                   invert_glsl=None, invert=None)


BROKEN = [
    # the lecture's polar map r = u judged against the uniform disk density
    _broken("disk_r_equals_u_as_uniform", "sample_disk_linear_radius(u)", "uniform_disk_polar"),
    _broken("spherical_triangle_uniform_arc_angle",
            "broken_spherical_triangle(v0, v1, v2, p_ref, u)", "spherical_triangle"),
    _broken("ggx_without_visible_weight", "broken_ggx_visible_normal(wo, alpha, u)",
            "ggx_visible_normal"),
]


@pytest.mark.parametrize("warp", BROKEN, ids=lambda w: w.name)
def test05_broken_warps_are_rejected(gl_ctx, chi2_dir, warp):
    def sample(u):
        return warp.to_domain(run_warp(warp, u)["p"].astype(np.float64))
    test = ChiSquareTest(warp.domain, sample, warp.pdf, sample_dim=warp.sample_dim,
                         sample_count=SAMPLES, res=warp.res, seed=7, name=warp.name)
    assert not test.run()
    assert test.p_value < sidak_alpha(0.01, CHI2_FAMILY) * 1e-6, test.messages
    assert test.plot_path is not None and test.plot_path.exists()


def test06_catalogue_is_complete():
    """The catalogue lists every warp the brief names, with a domain of the right kind."""
    names = {w.name for w in CATALOG}
    assert {"disk_linear_radius", "uniform_disk_polar", "uniform_disk_concentric",
            "uniform_disk_rejection", "uniform_triangle_sqrt", "uniform_triangle",
            "uniform_sphere", "uniform_hemisphere", "cosine_hemisphere", "uniform_cone",
            "phong_lobe", "spherical_triangle", "spherical_rectangle", "ggx_visible_normal",
            "beckmann_visible_normal", "power_inversion", "power_max", "distribution_1d",
            "distribution_2d", "hg_forward", "hg_backward"} <= names
    for w in CATALOG:  # directions are plotted as directions
        assert isinstance(w.domain, SphericalDomain) == (w.plot == "sphere"), w.name


@pytest.mark.parametrize("warp", CATALOG, ids=lambda w: w.name)
def test07_edges_of_the_unit_square(gl_ctx, warp):
    """u on the edges of the float32 unit square (0, 2^-24, 1/2, 1 - 2^-24 per axis) gives
    finite points of positive density: an estimator never divides by a zero pdf there
    (the r = u disk's density 1 / (2 pi r) is rightly infinite at its centre)."""
    g = np.array([0.0, 2.0 ** -24, 0.5, 1.0 - 2.0 ** -24], np.float32)
    u = np.stack(np.meshgrid(*([g] * warp.sample_dim)), axis=-1).reshape(-1, warp.sample_dim)
    out = run_warp(warp, u)
    assert np.all(np.isfinite(out["p"]))
    density = warp.pdf(warp.to_domain(out["p"].astype(np.float64)))
    assert np.all(density > 0), u[~(density > 0)]
    assert np.all(out["pdf"] > 0), u[~(out["pdf"] > 0)]  # and never NaN


@pytest.mark.parametrize("size", [0.3, 0.03, 0.003, 0.0003])
def test08_small_area_lights_keep_float32_accuracy(gl_ctx, size):
    """Solid-angle sampling of triangles and rectangles seen under 0.3 to 3e-4 rad
    (solid angles 0.06 to 7e-8 sr) agrees with the float64 twin to 1e-3 of the source's
    size, and its pdf to the atan precision (the angle-sum formulas lose everything by
    7e-6 sr in float32: these use Van Oosterom's formula and chord differences)."""
    s = np.array([-0.2, 0.1, 1.0])
    ex, ey = np.array([size, 0.0, 0.2 * size]), np.array([0.0, 0.8 * size, 0.0])
    u = np.random.default_rng(60).random((20_000, 2), dtype=np.float32)
    vec = {k: ("vec3", tuple(v)) for k, v in (("s", s), ("ex", ex), ("ey", ey))}
    out = run_glsl("float pdf_r; vec3 q = sample_spherical_rectangle(vec3(0), s, ex, ey, u, pdf_r);"
                   "float pdf_t; vec3 w = sample_spherical_triangle(s, s + ex, s + ey, vec3(0), u, pdf_t);",
                   {"u": u}, {"q": "vec3", "pdf_r": "float", "w": "vec3", "pdf_t": "float"},
                   includes=["sampling/spherical_rectangle.glsl", "sampling/spherical_triangle.glsl"],
                   uniforms=vec)
    q, pdf_r = sr.sample_spherical_rectangle((0, 0, 0), s, ex, ey, u.astype(np.float64))
    w, pdf_t = st.sample_spherical_triangle(s, s + ex, s + ey, (0, 0, 0), u.astype(np.float64))
    assert np.max(np.abs(out["q"] - q)) <= 1e-3 * size
    assert np.max(np.linalg.norm(out["w"] - w, axis=1)) <= 1e-3 * size
    np.testing.assert_allclose(out["pdf_r"], pdf_r, rtol=2 * ATAN_REL)
    np.testing.assert_allclose(out["pdf_t"], pdf_t, rtol=2 * ATAN_REL)

