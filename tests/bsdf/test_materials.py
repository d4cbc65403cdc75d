"""Material parameters: named IORs, the TOML loader's material fields, pack_material, and
the roughplastic coating tables against Mitsuba 3's own."""
import textwrap

import numpy as np
import pytest

from glrender.errors import SceneError
from glrender.gpu import bindings, layout
from glrender.gpu.microfacet_tables import external_transmittance, internal_reflectance
from glrender.gpu.pack import _fresnel_diffuse_reflectance, pack_material
from glrender.scene import load
from glrender.scene.materials import CONDUCTOR_IOR, DIELECTRIC_IOR, conductor_ior, dielectric_ior
from glrender.scene.model import Material

from bsdf_reference import fresnel_reference


def test01_named_iors():
    assert dielectric_ior("BK7") == 1.5046 and dielectric_ior("water") == 1.333
    assert dielectric_ior(" Air ") == 1.000277
    assert conductor_ior("au") == CONDUCTOR_IOR["Au"]
    assert conductor_ior("none") == ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    with pytest.raises(SceneError, match="unknown IOR name 'glas'"):
        dielectric_ior("glas")
    with pytest.raises(SceneError, match="unknown conductor 'Gold'"):
        conductor_ior("Gold")
    assert len(DIELECTRIC_IOR) == 23 and len(CONDUCTOR_IOR) == 72


def load_materials(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(textwrap.dedent(text) + '\n[[shapes]]\ntype = "sphere"\nmaterial = "a"\n')
    return load(path).materials


def test02_toml_named_materials(tmp_path):
    mats = load_materials(tmp_path, """
        [materials.a]
        type = "roughconductor"
        material = "Cu"
        alpha = [0.1, 0.3]
        distribution = "ggx"
        [materials.glass]
        type = "dielectric"
        int_ior = "water"
        ext_ior = "air"
        [materials.coat]
        type = "roughplastic"
        [materials.coat2]
        type = "plastic"
        int_ior = 1.6
        """)
    cu, glass, coat, coat2 = mats
    assert (cu.eta, cu.k) == conductor_ior("Cu") and cu.alpha == (0.1, 0.3)
    assert glass.int_ior == 1.333 and glass.ext_ior == 1.000277
    assert coat.int_ior == 1.49          # Mitsuba's default for plastics: polypropylene
    assert coat2.int_ior == 1.6


@pytest.mark.parametrize("fields, message", [
    ('type = "dielectric"\nmaterial = "Au"', r"materials\.a\.material: named materials are for conductor"),
    ('type = "conductor"\nmaterial = "Au"\neta = 0.2', r"materials\.a\.material: give either eta and k"),
    ('type = "conductor"\nmaterial = "Gold"', r"materials\.a\.material: unknown conductor 'Gold'"),
    ('type = "dielectric"\nint_ior = "glas"', r"materials\.a\.int_ior: unknown IOR name 'glas'"),
    ('type = "dielectric"\nint_ior = -1.0', r"materials\.a\.int_ior: expected a number in"),
])
def test03_toml_material_errors(tmp_path, fields, message):
    with pytest.raises(SceneError, match=message):
        load_materials(tmp_path, "[materials.a]\n" + fields)


def test04_pack_material_records():
    rec = pack_material(Material(kind="roughconductor", alpha=(1e-6, 0.2), two_sided=True,
                                 distribution="ggx", eta=(0.1, 0.2, 0.3), k=(3, 2, 1)))
    assert rec["params"][0] == np.float32(1e-4)          # Mitsuba clamps alpha to 1e-4
    assert rec["info"][1] == bindings.MATERIAL_FLAG_TWO_SIDED | bindings.MATERIAL_FLAG_GGX
    np.testing.assert_array_equal(rec["color2"][:3], np.float32([3, 2, 1]))
    # dielectrics answer on both sides by themselves: two_sided is dropped
    assert pack_material(Material(kind="dielectric", two_sided=True))["info"][1] == 0
    plastic = pack_material(Material(kind="plastic", reflectance=(0.2, 0.4, 0.6),
                                     specular_reflectance=(0.5, 0.5, 0.5), int_ior=1.5,
                                     ext_ior=1.0))
    assert plastic["color2"][0] == np.float32(0.5 / (0.4 + 0.5))
    assert plastic["color2"][1] == np.float32(_fresnel_diffuse_reflectance(1 / 1.5))
    rough = pack_material(Material(kind="roughplastic", alpha=(0.3, 0.3), int_ior=1.5, ext_ior=1.0))
    np.testing.assert_array_equal(rough["table"], external_transmittance(0.3, 1.5, False))
    assert rough["color2"][1] == np.float32(internal_reflectance(0.3, 1.5, False))


@pytest.mark.parametrize("mat, message", [
    (Material(kind="roughplastic", alpha=(0.1, 0.2)), "roughplastic is isotropic"),
    (Material(kind="roughplastic", int_ior=1.0, ext_ior=1.0), "must differ for roughplastic"),
    (Material(kind="roughdielectric", int_ior=1.2, ext_ior=1.2), "must differ for a rough dielectric"),
    (Material(kind="roughconductor", alpha=(0.0, 0.1)), "expected positive roughness"),
])
def test05_pack_material_errors(mat, message):
    with pytest.raises(SceneError, match=message):
        pack_material(mat)


@pytest.mark.parametrize("eta", [1.05, 1.2, 1.5, 2.0, 3.0, 1 / 1.05, 1 / 1.2, 1 / 1.5, 1 / 2.0])
def test06_fresnel_diffuse_reflectance_fit(eta):
    """Fdr = 2 int_0^1 F(mu) mu dmu (Gauss-Legendre; F = 1 below the critical cosine);
    the fits are good to 0.6% on these IOR ranges."""
    x, w = np.polynomial.legendre.leggauss(200)
    lo = np.sqrt(1 - eta * eta) if eta < 1 else 0.0
    mu, ww = lo + (1 - lo) * 0.5 * (x + 1), (1 - lo) * 0.5 * w
    exact = lo * lo + 2 * np.sum(ww * fresnel_reference(mu, eta) * mu)
    assert abs(_fresnel_diffuse_reflectance(eta) / exact - 1) < 0.006


def mitsuba_coating_tables(mi, distribution, alpha, eta):
    """T at the 64 table cosines and R_int, read back from Mitsuba's roughplastic: its
    diffuse lobe alone is rho / (1 - rho R_int) T_o T_i cos / (pi eta^2) (nonlinear)."""
    bsdfs = {rho: mi.load_dict({"type": "roughplastic", "distribution": distribution, "alpha": alpha,
                                "int_ior": eta, "ext_ior": 1.0, "diffuse_reflectance": rho,
                                "nonlinear": True}) for rho in (0.25, 0.5)}

    def value(rho, cos_o):
        bsdf = bsdfs[rho]
        ctx = mi.BSDFContext()
        ctx.component = 1
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(float(np.sqrt(1 - cos_o * cos_o)), 0.0, float(cos_o))
        return float(bsdf.eval(ctx, si, mi.Vector3f(0.0, 0.0, 1.0))[0])
    r = value(0.5, 1.0) / value(0.25, 1.0)                   # = 2 (1 - R/4) / (1 - R/2)
    r_int = (2 - r) / (0.5 - 0.5 * r)
    t1 = np.sqrt(value(0.5, 1.0) * (1 - 0.5 * r_int) / 0.5 * np.pi * eta * eta)
    cosines = np.maximum(np.linspace(0, 1, 64, dtype=np.float32), 1e-6)
    t = [value(0.5, c) * (1 - 0.5 * r_int) / 0.5 * np.pi * eta * eta / t1 for c in cosines]
    return np.array(t), r_int


@pytest.mark.parametrize("distribution, alpha, eta", [
    ("ggx", 0.1, 1.49), ("ggx", 0.3, 1.49), ("ggx", 0.7, 1.6), ("beckmann", 0.1, 1.49),
    ("beckmann", 0.3, 1.33), ("beckmann", 0.5, 2.0)])
def test07_coating_tables_match_mitsuba(distribution, alpha, eta):
    """The host tables reproduce Mitsuba's to 4e-6 relative (the R of the parity tests)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    ref_t, ref_r = mitsuba_coating_tables(mi, distribution, alpha, eta)
    eta32 = float(np.float32(eta))
    t = external_transmittance(alpha, eta32, distribution == "ggx").astype(np.float64)
    np.testing.assert_allclose(t, ref_t, rtol=4e-6)
    assert abs(internal_reflectance(alpha, eta32, distribution == "ggx") / ref_r - 1) < 4e-6


def test08_albedo_aov_and_delta_flags(gl_ctx):
    """bsdf_albedo: the diffuse reflectance of diffuse and plastic kinds, the
    normal-incidence reflectance (+ transmittance for dielectrics) of the others;
    bsdf_is_delta for exactly the kinds whose lobes are all Dirac deltas."""
    import bsdf_glsl as G

    au = conductor_ior("Au")
    f_au = fresnel_reference(1.0, np.array(au[0]) + 1j * np.array(au[1]))
    f_glass = fresnel_reference(1.0, 1.5)
    r_thin = 2 * f_glass / (1 + f_glass)
    tint, trans = np.array([0.9, 0.6, 0.3]), np.array([0.2, 0.5, 0.8])
    cases = [
        (Material(kind="diffuse", reflectance=(0.1, 0.2, 0.3)), [0.1, 0.2, 0.3], False),
        (Material(kind="plastic", reflectance=(0.1, 0.2, 0.3)), [0.1, 0.2, 0.3], False),
        (Material(kind="roughplastic", reflectance=(0.1, 0.2, 0.3)), [0.1, 0.2, 0.3], False),
        (Material(kind="conductor", eta=au[0], k=au[1], specular_reflectance=tint), tint * f_au, True),
        (Material(kind="roughconductor", eta=au[0], k=au[1]), f_au, False),
        (Material(kind="dielectric", int_ior=1.5, ext_ior=1.0, specular_reflectance=tint,
                  specular_transmittance=trans), f_glass * tint + (1 - f_glass) * trans, True),
        (Material(kind="roughdielectric", int_ior=1.5, ext_ior=1.0), [1.0] * 3, False),
        (Material(kind="thindielectric", int_ior=1.5, ext_ior=1.0, specular_reflectance=tint,
                  specular_transmittance=trans), r_thin * tint + (1 - r_thin) * trans, True),
        (Material(kind="null"), [0.0] * 3, True),
    ]
    for mat, expected, delta in cases:
        albedo, is_delta = G.albedo_and_delta(mat)
        np.testing.assert_allclose(albedo, expected, rtol=1e-5, atol=1e-6, err_msg=mat.kind)
        assert is_delta == delta, mat.kind
