"""Monte Carlo estimates of known integrals with the GLSL warps: uniform against importance
sampling, within 4 standard errors, with the variance ratio reported.

Each estimate uses 10^6 independent fixed-seed samples, so sigma is the sample standard
deviation over sqrt(N). 4 sigma is above the Šidák threshold for the ~14 comparisons of
this module (3.6 at alpha = 0.01), and every non-zero-variance estimate is checked to
have 4 sigma below 1% of its reference (2-3% for the uniform estimates of small sources,
which most directions miss): such a bias would be seen. Zero-variance estimates
(p proportional to f) are judged by |delta| <= 4 sigma + 1e-5 |ref| (float32 rounding).
"""
import math

import numpy as np
import pytest

from glrender.sampling.spherical_geometry import spherical_triangle_area
from glrender.testing.harness import run_glsl

SAMPLES = 1_000_000
Z = 4.0


def uniforms(seed, dim=2):
    return np.random.default_rng(seed).random((SAMPLES, dim), dtype=np.float32)


def check(name, values, reference, record, zero_variance=False, detect=0.01):
    values = np.asarray(values, np.float64)
    mean, var = values.mean(), values.var(ddof=1)
    sigma = math.sqrt(var / len(values))
    record(f"{name}_mean", float(mean))
    record(f"{name}_variance", float(var))
    print(f"{name}: {mean:.6f} vs {reference:.6f}, sigma {sigma:.2g}, variance {var:.3g}")
    if zero_variance:
        assert abs(mean - reference) <= Z * sigma + 1e-5 * abs(reference)
    else:
        assert Z * sigma < detect * abs(reference)  # the test can see such a bias
        assert abs(mean - reference) <= Z * sigma
    return var


def report_ratio(name, var_uniform, var_importance, record):
    """Variance of uniform sampling over importance sampling (infinite when the importance
    estimate is constant up to float32 rounding)."""
    zero = var_importance <= 1e-12 * var_uniform
    ratio = math.inf if zero else var_uniform / var_importance
    record(f"{name}_variance_ratio", float(ratio))
    print(f"{name}: variance ratio uniform / importance = "
          + ("infinite (zero variance up to rounding)" if zero else f"{ratio:.4g}"))
    return ratio


def test01_cosine_over_the_hemisphere_is_pi(gl_ctx, record_property):
    out = run_glsl("vec3 wu = sample_uniform_hemisphere(u1); float pu = uniform_hemisphere_pdf();"
                   "vec3 wc = sample_cosine_hemisphere(u2); float pc = cosine_hemisphere_pdf(wc.z);",
                   {"u1": uniforms(1), "u2": uniforms(2)},
                   {"wu": "vec3", "pu": "float", "wc": "vec3", "pc": "float"},
                   includes=["sampling/hemisphere.glsl"])
    var_u = check("cos_uniform", out["wu"][:, 2] / out["pu"], math.pi, record_property)
    var_c = check("cos_cosine", out["wc"][:, 2] / out["pc"].astype(np.float64), math.pi,
                  record_property, zero_variance=True)
    assert var_c < 1e-10  # p = cos / pi is proportional to f: zero variance up to rounding
    assert report_ratio("cos", var_u, var_c, record_property) > 1e6


P0, P1, P2 = np.array([0.1, 0.2, 0.0]), np.array([1.3, 0.4, 0.5]), np.array([0.4, 1.1, -0.2])


@pytest.mark.parametrize("sampler", ["sample_uniform_triangle", "sample_uniform_triangle_sqrt"])
def test02_area_and_centroid_of_a_triangle(gl_ctx, record_property, sampler):
    area = 0.5 * np.linalg.norm(np.cross(P1 - P0, P2 - P0))
    out = run_glsl(f"vec3 b = {sampler}(u2); vec3 p = b.x * p0 + b.y * p1 + b.z * p2;"
                   "float pdf = uniform_triangle_pdf(triangle_area(p0, p1, p2));"
                   "float inside = u1.x + u1.y <= 1.0 ? 1.0 : 0.0;",  # the parallelogram's half
                   {"u1": uniforms(3), "u2": uniforms(4)}, {"p": "vec3", "pdf": "float", "inside": "float"},
                   includes=["sampling/triangle.glsl"],
                   uniforms={k: ("vec3", tuple(v)) for k, v in (("p0", P0), ("p1", P1), ("p2", P2))})
    # uniform over the parallelogram p0 + s e1 + t e2 (area 2A): hit or miss
    var_u = check("area_uniform", 2 * area * out["inside"], area, record_property)
    var_t = check("area_triangle", 1.0 / out["pdf"].astype(np.float64), area, record_property,
                  zero_variance=True)
    report_ratio("area", var_u, var_t, record_property)
    # the samples are uniform on the triangle: their mean is the centroid (per coordinate,
    # sigma from the sample spread; 4 sigma is ~0.2% of the triangle's size)
    centroid = (P0 + P1 + P2) / 3
    p = out["p"].astype(np.float64)
    sigma = p.std(axis=0, ddof=1) / math.sqrt(SAMPLES)
    assert np.all(np.abs(p.mean(axis=0) - centroid) <= Z * sigma)


def test03_irradiance_from_a_spherical_source(gl_ctx, record_property):
    """A sphere of radiance L and radius R at distance d, its centre at angle theta_c from
    the normal (entirely above the horizon): E = pi L sin^2(theta_max) cos(theta_c) with
    sin theta_max = R / d. Uniform and cosine hemisphere sampling against sampling the
    cone of the sphere's directions (through a Frame about its axis)."""
    L, R, d = 2.0, 1.0, 3.0
    axis = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    cos_max = math.sqrt(1 - (R / d) ** 2)
    reference = math.pi * L * (R / d) ** 2 * axis[2]
    out = run_glsl(
        "vec3 wu = sample_uniform_hemisphere(u1); vec3 wc = sample_cosine_hemisphere(u2);"
        "vec3 wk = frame_from_local(frame_from_z(a), sample_uniform_cone(u3, cos_max));"
        "float yu = (dot(wu, a) >= cos_max ? L * wu.z : 0.0) / uniform_hemisphere_pdf();"
        "float yc = (dot(wc, a) >= cos_max ? L * wc.z : 0.0) / cosine_hemisphere_pdf(wc.z);"
        "float yk = L * max(wk.z, 0.0) / uniform_cone_pdf(cos_max);",
        {"u1": uniforms(5), "u2": uniforms(6), "u3": uniforms(7)},
        {"yu": "float", "yc": "float", "yk": "float"},
        includes=["sampling/hemisphere.glsl", "sampling/cone.glsl", "common/frame.glsl"],
        uniforms={"a": ("vec3", tuple(axis)), "cos_max": cos_max, "L": L})
    var_u = check("irradiance_uniform", out["yu"], reference, record_property, detect=0.02)
    var_c = check("irradiance_cosine", out["yc"], reference, record_property, detect=0.02)
    var_k = check("irradiance_cone", out["yk"], reference, record_property)
    assert report_ratio("irradiance_cone", var_u, var_k, record_property) > 100
    assert report_ratio("irradiance_cosine", var_u, var_c, record_property) > 1


def test04_solid_angle_of_a_triangle_and_a_rectangle(gl_ctx, record_property):
    """Solid angles by uniform sphere sampling (does the ray hit?) against solid-angle
    sampling of the shape, whose estimate 1 / pdf has zero variance."""
    v0, v1, v2 = np.array([-0.3, -0.4, 1.0]), np.array([0.8, -0.2, 1.2]), np.array([0.1, 0.7, 0.9])
    s, ex, ey = np.array([-0.5, -0.4, 1.0]), np.array([1.0, 0.0, 0.2]), np.array([0.0, 0.8, 0.0])
    unit = [x / np.linalg.norm(x) for x in (v0, v1, v2)]
    omega_tri = spherical_triangle_area(*[x[None] for x in unit])[0]
    corners = [x / np.linalg.norm(x) for x in (s, s + ex, s + ex + ey, s + ey)]
    omega_rect = (spherical_triangle_area(*[c[None] for c in corners[:3]])[0] +
                  spherical_triangle_area(*[c[None] for c in (corners[0], corners[2], corners[3])])[0])
    origin = ("vec3", (0.0, 0.0, 0.0))
    vec = {k: ("vec3", tuple(v)) for k, v in (("v0", v0), ("v1", v1), ("v2", v2), ("rs", s),
                                              ("rex", ex), ("rey", ey))}
    out = run_glsl(
        "vec3 w = sample_uniform_sphere(u1); float pdf_t; float pdf_r;"
        "vec3 wt = sample_spherical_triangle(v0, v1, v2, o, u2, pdf_t);"
        "vec3 pr = sample_spherical_rectangle(o, rs, rex, rey, u3, pdf_r);",
        {"u1": uniforms(8), "u2": uniforms(9), "u3": uniforms(10)},
        {"w": "vec3", "pdf_t": "float", "pdf_r": "float"},
        includes=["sampling/sphere.glsl", "sampling/spherical_triangle.glsl",
                  "sampling/spherical_rectangle.glsl"], uniforms={"o": origin, **vec})
    w = out["w"].astype(np.float64)
    # hits, in float64: inside all three edge planes of the triangle (seen from the origin)
    hit_t = np.ones(len(w), bool)
    for a, b in ((v0, v1), (v1, v2), (v2, v0)):
        hit_t &= w @ np.cross(a, b) >= 0
    n = np.cross(ex, ey)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (s @ n) / (w @ n)
        q = t[:, None] * w - s
        a_, b_ = q @ ex / (ex @ ex), q @ ey / (ey @ ey)
    hit_r = (t > 0) & (a_ >= 0) & (a_ <= 1) & (b_ >= 0) & (b_ <= 1)
    for name, hit, pdf, omega in (("triangle", hit_t, out["pdf_t"], omega_tri),
                                  ("rectangle", hit_r, out["pdf_r"], omega_rect)):
        var_u = check(f"solid_angle_{name}_uniform", 4 * math.pi * hit, omega, record_property,
                      detect=0.03)
        # the pdf comes from atan (llvmpipe: 2.1e-5 relative): judged at 4e-5 relative
        inv = 1.0 / pdf.astype(np.float64)
        assert abs(inv.mean() - omega) <= 4e-5 * omega
        report_ratio(f"solid_angle_{name}", var_u, inv.var(), record_property)
