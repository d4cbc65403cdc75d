"""bsdf/fresnel.glsl against the Fresnel equations in complex float64 arithmetic.

References: r_s = (cos - sqrt(n^2 - sin^2)) / (cos + sqrt(n^2 - sin^2)) and
r_p = (n^2 cos - sqrt(n^2 - sin^2)) / (n^2 cos + sqrt(n^2 - sin^2)), F = (|r_s|^2 +
|r_p|^2) / 2 for a complex relative IOR n (principal square root: the refracted wave
decays into the conductor). Inputs are float32; tolerances are a few dozen float32
ulps of the result, times the conditioning of cos_t = sqrt(cos_t^2) near the critical
angle: a rounding error of a few ulps in cos_t^2 moves cos_t by ~ulps / cos_t.
"""
import numpy as np
import pytest

from glrender.scene.materials import conductor_ior
from glrender.testing.harness import run_glsl

from bsdf_reference import EPS, fresnel_reference

def run_fresnel(cos_theta, eta):
    out = run_glsl("FresnelDielectric r = fresnel_dielectric(c, eta);\n"
                   "float F = r.F; float cos_t = r.cos_theta_t; float eta_it = r.eta_it;\n"
                   "float eta_ti = r.eta_ti;\n"
                   "vec3 w = vec3(sqrt(max(0.0, 1.0 - c * c)), 0.0, c);\n"
                   "vec3 wt = refract_local(w, r.cos_theta_t, r.eta_ti);",
                   {"c": np.float32(cos_theta)}, {"F": "float", "cos_t": "float", "eta_it": "float",
                                                   "eta_ti": "float", "wt": "vec3"},
                   includes=["bsdf/fresnel.glsl"], uniforms={"eta": float(eta)})
    return out


@pytest.mark.parametrize("eta", [1.5046, 1.333, 2.419, 1 / 1.5046, 1.0])
def test01_dielectric_both_sides(gl_ctx, eta):
    eta = float(np.float32(eta))
    c = np.linspace(-1.0, 1.0, 20001, dtype=np.float32)
    out = run_fresnel(c, eta)
    c64 = c.astype(np.float64)
    n = np.where(c64 >= 0, eta, 1.0 / eta)       # IOR of the far side / the near side
    a = np.abs(c64)
    cos_t2 = 1.0 - (1.0 - a * a) / n ** 2
    ref = np.zeros_like(a) if eta == 1.0 else fresnel_reference(a, n)
    well = np.abs(cos_t2) > 1e-6
    conditioning = 1.0 + 1.0 / np.sqrt(np.abs(cos_t2[well]))
    assert np.all(np.abs(out["F"] - ref)[well] <= 32 * EPS * conditioning + 8 * EPS * ref[well])
    tir = cos_t2 < 0
    assert np.all(out["F"][tir] == 1.0)              # total internal reflection
    # the refracted direction: opposite side, unit length, Snell's law sin_t = sin_i / n
    ok = well & ~tir & (a > 0)
    assert np.all(np.sign(out["cos_t"][ok]) == -np.sign(c64[ok]))
    ct = np.sqrt(cos_t2[ok])
    assert np.all(np.abs(np.abs(out["cos_t"][ok]) - ct) <= 32 * EPS * (1.0 + 1.0 / ct))
    np.testing.assert_allclose(out["eta_it"], n, rtol=4 * EPS)
    np.testing.assert_allclose(out["eta_ti"], 1.0 / n, rtol=4 * EPS)
    wt = out["wt"][ok].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(wt, axis=1), 1.0, atol=64 * EPS)
    np.testing.assert_allclose(wt[:, 0] * n[ok], -np.sqrt(1.0 - a[ok] ** 2), atol=64 * EPS)


def test02_dielectric_special_cases(gl_ctx):
    out = run_fresnel(np.array([0.0, -0.0, 1.0, -1.0], np.float32), 1.5)
    assert out["F"][0] == 1.0 and out["F"][1] == 1.0        # grazing: everything reflects
    ref = ((1.5 - 1.0) / (1.5 + 1.0)) ** 2                  # normal incidence, both sides
    np.testing.assert_allclose(out["F"][2:], ref, rtol=8 * EPS)
    matched = run_fresnel(np.array([0.3, -0.7, 1.0], np.float32), 1.0)
    assert np.all(matched["F"] == 0.0)                      # index-matched: no interface


@pytest.mark.parametrize("name", ["Au", "Cu", "Al", "Ag", "Cr", "CsI"])
def test03_conductor(gl_ctx, name):
    eta, k = (np.array(v, np.float32) for v in conductor_ior(name))
    c = np.linspace(0.0, 1.0, 4001, dtype=np.float32)
    out = run_glsl("vec3 F = fresnel_conductor(c, u_eta, u_k);", {"c": c}, {"F": "vec3"},
                   includes=["bsdf/fresnel.glsl"],
                   uniforms={"u_eta": ("vec3", tuple(map(float, eta))),
                             "u_k": ("vec3", tuple(map(float, k)))})
    n = eta.astype(np.float64) + 1j * k.astype(np.float64)
    ref = fresnel_reference(c.astype(np.float64)[:, None], n[None, :])
    assert np.max(np.abs(out["F"] - ref)) <= 64 * EPS


def test04_conductor_none_is_a_perfect_mirror(gl_ctx):
    c = np.linspace(0.0, 1.0, 1001, dtype=np.float32)
    out = run_glsl("vec3 F = fresnel_conductor(c, vec3(0.0), vec3(1.0));", {"c": c}, {"F": "vec3"},
                   includes=["bsdf/fresnel.glsl"])
    assert np.all(out["F"] == 1.0)


def test05_reflect_and_refract_about_a_microfacet(gl_ctx):
    rng = np.random.default_rng(5)
    w = rng.standard_normal((1000, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    m = rng.standard_normal((1000, 3)) * [0.3, 0.3, 1.0]
    m[:, 2] = np.abs(m[:, 2])
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    out = run_glsl("vec3 r = reflect_about(w, m);\n"
                   "FresnelDielectric f = fresnel_dielectric(dot(w, m), 1.5);\n"
                   "vec3 t = refract_about(w, m, f.cos_theta_t, f.eta_ti); float F = f.F;",
                   {"w": np.float32(w), "m": np.float32(m)}, {"r": "vec3", "t": "vec3", "F": "float"},
                   includes=["bsdf/fresnel.glsl"])
    r, t = out["r"].astype(np.float64), out["t"].astype(np.float64)
    cw = np.sum(w * m, axis=1)
    # the mirror direction: same angle to m, in the plane of w and m, unit length
    np.testing.assert_allclose(np.sum(r * m, axis=1), cw, atol=16 * EPS)
    np.testing.assert_allclose(r + w, 2 * cw[:, None] * m, atol=16 * EPS)
    # refraction (where not totally reflected): Snell's law in the plane of w and m
    ok = out["F"] < 1.0
    n = np.where(cw >= 0, 1.5, 1 / 1.5)
    sin_i = np.linalg.norm(np.cross(w, m), axis=1)
    sin_t = np.linalg.norm(np.cross(t, m), axis=1)
    np.testing.assert_allclose((sin_t * n)[ok], sin_i[ok], atol=64 * EPS)
    assert np.all(np.sign(np.sum(t * m, axis=1))[ok] == -np.sign(cw[ok]))
    np.testing.assert_allclose(np.linalg.norm(t[ok], axis=1), 1.0, atol=64 * EPS)
