"""Emission sampling (lights/light.glsl: sample_light_emission, light_emission_pdf).

Every light kind: the densities returned with a sample equal light_emission_pdf there;
directions and positions pass chi-square tests against those densities (Šidák over the
six histograms); and the light path's first throughput Le |cos| / (pdf_pos pdf_dir)
averages to the light's emitted power (closed forms; zero-variance cases get a float32
tolerance of 1e-5 relative, the others a Šidák z over the configurations).
"""
import math

import numpy as np
import pytest

from glrender.testing.chi2 import ChiSquareTest, PlanarDomain, SphericalDomain
from glrender.testing.stats import sidak_z

from emission_glsl import (SPHERE, emission_pdf, parallelogram, record, sample_emission, sphere, spot,
                           triangle)

TILTED = dict(p=(0.3, -0.2, 1.0), e1=(1.0, 0.0, 0.5), e2=(0.0, 0.7, 0.0))
LIGHTS = {
    "parallelogram": parallelogram(**TILTED),
    "two-sided": parallelogram(**TILTED, two_sided=True),
    "triangle": triangle((0.0, 1.0, 0.0), (0.5, 0.2, 0.3), (-0.4, 0.6, 0.1)),
    "sphere": sphere((0.2, 0.3, -0.1), 0.4),
    "point": record("point", p=(0.1, 0.2, 0.3), radiance=(2.0, 1.0, 0.5)),
    "spot": spot((0.0, 1.0, 0.0), (0.3, -1.0, 0.2), cutoff=35.0, beam=20.0),
    "directional": record("directional", n=(0.0, -0.6, -0.8, 0.0), radiance=(1.5, 1.0, 0.5)),
    "constant": record("constant", radiance=(0.7, 0.8, 0.9)),
}
CHI2_TESTS = 6


def uniforms(n, seed):
    return np.random.default_rng(seed).random((n, 4)).astype(np.float32)


@pytest.mark.parametrize("name", list(LIGHTS))
def test01_returned_pdfs_equal_light_emission_pdf(gl_ctx, name):
    rec = LIGHTS[name]
    out = sample_emission(rec, uniforms(4096, 1))
    assert np.all(out["pdf_pos"] > 0) and np.all(out["pdf_dir"] > 0)
    np.testing.assert_allclose(out["pdf_pos_eval"], out["pdf_pos"], rtol=1e-4)
    np.testing.assert_allclose(out["pdf_dir_eval"], out["pdf_dir"], rtol=2e-4)
    np.testing.assert_allclose(np.linalg.norm(out["d"], axis=1), 1.0, atol=1e-5)
    assert np.all(out["delta_pos"] == (name in ("point", "spot")))
    assert np.all(out["delta_dir"] == (name == "directional"))
    if name in ("directional", "constant"):
        # lights at infinity start outside the bounding sphere, heading into it
        c, r = np.array(SPHERE[:3]), SPHERE[3]
        rel = out["p"] - c
        np.testing.assert_allclose(np.einsum("ij,ij->i", rel, out["d"]), -r, rtol=1e-4)
        np.testing.assert_allclose(out["pdf_pos"], 1 / (math.pi * r * r), rtol=1e-5)


@pytest.mark.parametrize("name", ["parallelogram", "two-sided", "point", "spot", "constant"])
def test02_directions_chi2(gl_ctx, chi2_dir, name):
    rec = LIGHTS[name]
    n0 = rec["n"][:3].astype(np.float64)

    def pdf(d):
        # the emitting side's normal: for a two-sided light, the side d leaves from
        n = np.where((d @ n0)[:, None] < 0, -n0, n0) if name == "two-sided" else np.tile(n0, (len(d), 1))
        return emission_pdf(rec, np.zeros_like(d), n, d)[1]

    test = ChiSquareTest(SphericalDomain(), lambda u: sample_emission(rec, u)["d"], pdf, sample_dim=4,
                         sample_count=400_000, seed=2, test_count=CHI2_TESTS, name=f"emission-{name}")
    assert test.run(), "\n".join(test.messages)


def test03_triangle_positions_chi2(gl_ctx, chi2_dir):
    """Barycentric coordinates (a, b) of triangle light points are uniform on a + b < 1."""
    rec = LIGHTS["triangle"]
    e = np.stack([rec["e1"][:3], rec["e2"][:3]], axis=1).astype(np.float64)

    def positions(u):
        rel = sample_emission(rec, u)["p"] - rec["p"][:3]
        return np.linalg.lstsq(e, rel.T, rcond=None)[0].T

    test = ChiSquareTest(PlanarDomain(((0.0, 1.0), (0.0, 1.0))), positions,
                         lambda ab: 2.0 * (ab.sum(axis=1) < 1.0), sample_dim=4, sample_count=400_000,
                         seed=3, test_count=CHI2_TESTS, name="emission-triangle-positions")
    assert test.run(), "\n".join(test.messages)


def spot_power(rec) -> float:
    """2 pi I ∫ falloff(theta) sin theta dtheta over the cone (Simpson); Mitsuba's falloff:
    1 inside the beam width, linear in the angle down to 0 at the cutoff."""
    cutoff, beam = math.acos(float(rec["params"][0])), math.acos(float(rec["params"][1]))
    theta = np.linspace(0.0, cutoff, 200_001)
    f = np.clip((cutoff - theta) / (cutoff - beam), 0.0, 1.0) * np.sin(theta)
    h = theta[1] - theta[0]
    integral = h / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum())
    return 2 * math.pi * float(rec["radiance"][0]) * integral


def power(name) -> float:
    rec = LIGHTS[name]
    L, area, r = float(rec["radiance"][0]), float(rec["n"][3]), SPHERE[3]
    if name == "spot":
        return spot_power(rec)
    return {"parallelogram": math.pi * area * L, "two-sided": 2 * math.pi * area * L,
            "triangle": math.pi * area * L, "sphere": math.pi * area * L, "point": 4 * math.pi * L,
            "directional": math.pi * r * r * L, "constant": 4 * math.pi * L * math.pi * r * r}[name]


def test04_throughput_averages_to_power(gl_ctx):
    """Smallest detectable bias: z σ/√N; the spot and constant light, the two with
    variance, see 0.3% and 0.1%; the rest are exact to float32."""
    n = 200_000
    z = sidak_z(0.01, len(LIGHTS))
    for name, rec in LIGHTS.items():
        out = sample_emission(rec, uniforms(n, 4))
        cos = np.abs(np.einsum("ij,ij->i", out["n"], out["d"]))
        beta = out["Le"][:, 0] * cos / (out["pdf_pos"] * out["pdf_dir"])
        expected = power(name)
        tol = z * beta.std() / math.sqrt(n) + 1e-5 * expected
        assert abs(beta.mean() - expected) <= tol, (name, beta.mean(), expected, tol)


@pytest.mark.parametrize("name", ["parallelogram", "triangle"])
def test05_planar_light_coordinates_and_uv(gl_ctx, name):
    """planar_light_coordinates inverts p + a e1 + b e2 (edges not orthogonal), and the uv a
    textured emitter reads there is uv0 + a uv_e1 + b uv_e2: at points sample_light_emission
    returns (its e.uv) and at any point of the plane (the spherical samplers' points)."""
    from emission_glsl import DEFINES, _uniforms
    from glrender.testing.harness import run_glsl

    p, e1, e2 = (0.3, -0.2, 1.0), (1.5, 0.2, 0.1), (0.4, 0.9, -0.3)
    rec = parallelogram(p, e1, e2) if name == "parallelogram" else triangle(p, e1, e2)
    uv = np.array([[0.25, 0.5], [1.0, -0.5], [0.25, 2.0]])
    rng = np.random.default_rng(5)
    u = rng.random((256, 4)).astype(np.float32)
    ab = rng.uniform(-0.5, 1.5, (256, 2)).astype(np.float32)
    uniforms = {**_uniforms(rec), **{f"l_uv{k}": ("vec2", tuple(uv[k])) for k in range(3)}}
    body = ("LightData l = LightData(l_p, l_e1, l_e2, l_n, l_radiance, l_params.xyz, l_params.w,\n"
            "                        l_info, l_uv0, l_uv1, l_uv2, 1.0, 0.0);\n"
            "vec3 q = l.p.xyz + ab.x * l.e1.xyz + ab.y * l.e2.xyz;\n"
            "vec2 ab_back = planar_light_coordinates(l, q);\n"
            "vec2 uv_q = planar_light_uv(l, ab);\n"
            "LightEmission e = sample_light_emission(l, u.xy, u.zw, u_sphere);\n"
            "vec2 uv_e = e.uv;\n"
            "vec2 uv_e_back = planar_light_uv(l, planar_light_coordinates(l, e.p));")
    out = run_glsl(body, {"ab": ab, "u": u}, {"ab_back": "vec2", "uv_q": "vec2", "uv_e": "vec2",
                                               "uv_e_back": "vec2"},
                   includes=["lights/light.glsl"], uniforms=uniforms, defines=DEFINES)
    np.testing.assert_allclose(out["ab_back"], ab, atol=2e-5)
    np.testing.assert_allclose(out["uv_q"], uv[0] + ab[:, :1] * uv[1] + ab[:, 1:] * uv[2], atol=1e-5)
    np.testing.assert_allclose(out["uv_e"], out["uv_e_back"], atol=2e-5)
    # the sampled points lie on the light: their (a, b) in the parallelogram or the triangle
    a, b = np.linalg.lstsq(uv[1:].T, (out["uv_e"] - uv[0]).T, rcond=None)[0]
    assert a.min() > -1e-5 and b.min() > -1e-5 and (a + b if name == "triangle" else np.maximum(a, b)).max() < 1 + 1e-5
