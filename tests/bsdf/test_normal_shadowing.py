"""The normal map's shadowing term (Conty Estevez, Lecocq & Stein 2019, Mitsuba 3's
use_shadowing_function) on the device: the term itself against a numpy twin and the
paper's closed form, and how bsdf/bsdf.glsl applies it (to the light-side direction:
wi for radiance, wo for importance transport)."""
from __future__ import annotations

import numpy as np
import pytest

from glrender.gpu import bindings
from glrender.scene.model import Material, Texture
from glrender.testing.harness import run_glsl

from bsdf_glsl import DEFINES, direction, eval_pdf, f32, sample

SHADOWING = {**DEFINES, "GLRENDER_NORMAL_SHADOWING": 1}


def term_numpy(cos_tilt, cos_l):
    """The paper's G1: alpha^2 = min(tan^2(tilt) / 8, 1), G = 2 / (1 + sqrt(1 + alpha^2 tan^2))."""
    cos_tilt, cos_l = np.asarray(cos_tilt, np.float64), np.asarray(cos_l, np.float64)
    alpha2 = np.minimum(0.125 * (1 - cos_tilt ** 2) / cos_tilt ** 2, 1.0)
    with np.errstate(divide="ignore"):
        tan2 = (1 - cos_l ** 2) / cos_l ** 2
        g = 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * tan2))
    return np.where(alpha2 > 0, g, 1.0)


def term_glsl(cos_tilt, cos_l) -> np.ndarray:
    out = run_glsl("float g = normal_shadowing_term(cos_tilt, cos_l);",
                   {"cos_tilt": f32(cos_tilt), "cos_l": f32(cos_l)}, {"g": "float"},
                   includes=["bsdf/bsdf.glsl"], defines=DEFINES,
                   preamble="float material_table_fetch(uint material, uint i) { return 0.0; }")
    return out["g"].astype(np.float64)


def test01_term_matches_numpy_twin(gl_ctx):
    rng = np.random.default_rng(3)
    cos_tilt = rng.uniform(0.05, 1.0, 4096)
    cos_l = rng.uniform(-1.0, 1.0, 4096)
    np.testing.assert_allclose(term_glsl(cos_tilt, cos_l), term_numpy(cos_tilt, cos_l), rtol=2e-6,
                               atol=1e-6)


def test02_term_known_values(gl_ctx):
    t8 = 1.0 / 3.0                     # tan^2(tilt) = 8: alpha^2 = 1, the clamp's edge
    cases = [
        (1.0, 0.3, 1.0),               # an untilted normal: no shadowing at any light angle
        (1.0, 0.0, 1.0),
        (0.6, 1.0, 1.0),               # light along the unperturbed normal: tan = 0
        (t8, np.sqrt(0.5), 2.0 / (1.0 + np.sqrt(2.0))),          # alpha^2 = 1, tan^2 = 1
        (0.2, np.sqrt(0.5), 2.0 / (1.0 + np.sqrt(2.0))),          # clamped at alpha^2 = 1
        (np.sqrt(8.0 / 9.0), 0.5, 2.0 / (1.0 + np.sqrt(1.0 + 0.125 / 8.0 * 3.0))),  # tan^2 = 1/8, 3
        (0.5, 0.0, 0.0),               # grazing light over a tilted normal: fully shadowed
        (0.5, -0.5, term_numpy(0.5, 0.5)),   # the term sees tan^2 only: either side alike
    ]
    cos_tilt, cos_l, want = (np.array(c, np.float64) for c in zip(*cases))
    np.testing.assert_allclose(term_glsl(cos_tilt, cos_l), want, rtol=1e-6, atol=1e-7)
    # the paper's shape: 1 at normal light, falling monotonically to 0 at grazing
    c = np.linspace(1.0, 0.0, 64)
    g = term_glsl(np.full(64, 0.7), c)
    assert g[0] == pytest.approx(1.0) and g[-1] == 0.0 and np.all(np.diff(g) <= 1e-7)


NMAP = Texture("bitmap", image=np.full((1, 1, 3), 0.5, np.float32))


def material(shadowing: bool) -> Material:
    return Material("roughplastic", reflectance=(0.6, 0.4, 0.3), alpha=(0.3, 0.3), normal_map=NMAP,
                    normal_shadowing=shadowing)


def _packed(shadowing: bool):
    from glrender.gpu.pack import pack_material
    from glrender.gpu.textures import TextureTable

    return pack_material(material(shadowing), textures=TextureTable())


# the unperturbed normal in the perturbed (local) frame: a map normal tilted by 40 degrees
N0 = direction(40.0, 200.0)


def test03_flag_and_pack():
    assert _packed(True)["info"][1] & bindings.MATERIAL_FLAG_NORMAL_SHADOWING
    assert not _packed(False)["info"][1] & bindings.MATERIAL_FLAG_NORMAL_SHADOWING


@pytest.mark.parametrize("adjoint", [False, True])
def test04_eval_applies_term_to_the_light_side(gl_ctx, adjoint):
    rng = np.random.default_rng(5)
    wo = np.array([direction(t, p) for t, p in zip(rng.uniform(0, 60, 256), rng.uniform(0, 360, 256))])
    wi = np.array([direction(t, p) for t, p in zip(rng.uniform(0, 85, 256), rng.uniform(0, 360, 256))])
    base, pdf0 = eval_pdf(_packed(False), wo, wi, adjoint, n0=N0, defines=SHADOWING)
    f, pdf = eval_pdf(_packed(True), wo, wi, adjoint, n0=N0, defines=SHADOWING)
    light = wo if adjoint else wi
    cos_l = light @ N0
    want = term_numpy(N0[2], cos_l) * (cos_l * light[:, 2] > 0)
    assert np.any(want == 0) and np.any((want > 0) & (want < 0.9))    # both cases are met
    np.testing.assert_allclose(f, base * want[:, None], rtol=2e-5, atol=1e-7)
    np.testing.assert_allclose(pdf, pdf0, rtol=1e-6)                  # the pdf is the nested BSDF's
    # without the define the flag is ignored: the scenes that do not ask pay nothing
    off, _ = eval_pdf(_packed(True), wo, wi, adjoint, n0=N0)
    np.testing.assert_allclose(off, base, rtol=1e-6)


@pytest.mark.parametrize("adjoint", [False, True])
def test05_sample_weight_carries_the_term(gl_ctx, adjoint):
    rng = np.random.default_rng(7)
    wo = direction(35.0, 60.0)
    u_lobe, u = f32(rng.random(512)), f32(rng.random((512, 2)))
    base = sample(_packed(False), wo, u_lobe, u, adjoint, n0=N0, defines=SHADOWING)
    s = sample(_packed(True), wo, u_lobe, u, adjoint, n0=N0, defines=SHADOWING)
    np.testing.assert_allclose(s["wi"][s["valid"]], base["wi"][s["valid"]], atol=1e-6)
    light = np.broadcast_to(wo, base["wi"].shape) if adjoint else base["wi"]
    cos_l = light @ N0
    want = term_numpy(N0[2], cos_l) * (cos_l * light[:, 2] > 0) * base["valid"]
    assert np.any(base["valid"] & (want == 0)) if not adjoint else np.all(want[base["valid"]] > 0)
    np.testing.assert_array_equal(s["valid"], base["valid"] & (want > 0))
    ok = s["valid"]
    np.testing.assert_allclose(s["weight"][ok], base["weight"][ok] * want[ok, None], rtol=2e-5, atol=1e-7)
