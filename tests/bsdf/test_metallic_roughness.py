"""The metallic-roughness rule per surface point (bsdf/metallic_roughness.glsl) and the
coating table over alpha that per-texel rough plastic reads (bsdf/roughplastic.glsl,
glrender/gpu/microfacet_tables.py): the device's rule is the host's
(glrender/scene/loaders/pbr.py), the shipped table is what the module computes, and the
lookups interpolate it as stated."""
from __future__ import annotations

import numpy as np
import pytest

from glrender.gpu import bindings, layout, microfacet_tables as mt
from glrender.render.params import shader_defines
from glrender.scene.loaders.pbr import metallic_roughness_bsdf
from glrender.testing.harness import run_glsl

DEFINES = {**shader_defines(material_kinds=tuple(layout.MATERIAL_KINDS)), "GLRENDER_METALLIC_ROUGHNESS": 1}
PREAMBLE = """
float material_table_fetch(uint material, uint i) { return 0.0; }
float alpha_table_fetch(uint i) { return alpha_table[i]; }
"""
TABLE = {"alpha_table": np.ascontiguousarray(mt.alpha_table()).reshape(-1)}


def run(body, inputs, outputs):
    return run_glsl(body, inputs, outputs, includes=["bsdf/bsdf.glsl", "bsdf/metallic_roughness.glsl"],
                    buffers=TABLE, defines=DEFINES, preamble=PREAMBLE)


def test01_the_device_rule_is_the_hosts(gl_ctx):
    """Kind and alpha over a grid that straddles both thresholds (and values outside [0, 1])."""
    metallic = np.array([-0.1, 0.0, 0.2, 0.4999, 0.5, 0.5001, 0.9, 1.0, 1.3], np.float32)
    # (0.03 itself is no float32: the two sides of the threshold are tested instead)
    roughness = np.array([-0.2, 0.0, 0.01, 0.0299, 0.0301, 0.1, 0.5, 1.0, 1.5], np.float32)
    m, r = (a.reshape(-1) for a in np.meshgrid(metallic, roughness, indexing="ij"))
    out = run("float alpha; uint kind = metallic_roughness_kind(m, r, alpha);",
              {"m": m, "r": r}, {"kind": "uint", "alpha": "float"})
    for k in range(len(m)):
        kind, alpha = metallic_roughness_bsdf(float(m[k]), float(r[k]))
        assert out["kind"][k] == layout.MATERIAL_KINDS[kind], (m[k], r[k], kind)
        assert out["alpha"][k] == pytest.approx(alpha, rel=1e-6), (m[k], r[k])


def test02_resolve_fills_the_bsdf_of_each_kind(gl_ctx):
    """Base colour, (-, roughness, metallic) and the plastic's constants become the fields
    each BSDF reads (bsdf/conductor.glsl, plastic.glsl, roughplastic.glsl)."""
    mr = np.array([[0, 0.4, 1.0], [0, 0.0, 1.0], [0, 0.6, 0.0], [0, 0.01, 0.2]], np.float32)
    out = run("Bsdf b = Bsdf(kMaterialMetallicRoughness, kMaterialFlagTwoSided | kMaterialFlagGgx,\n"
              "              vec3(0.8, 0.5, 0.3), mr, vec3(0.25, 0.6, 0.0), vec2(0.0), 1.5, 3u, vec3(0, 0, 1));\n"
              "b = metallic_roughness_resolve(b);\n"
              "uint kind = b.kind; uint flags = b.flags; vec3 c0 = b.c0; vec3 c1 = b.c1; vec3 c2 = b.c2;\n"
              "float alpha = b.alpha.x; float eta = b.eta;",
              {"mr": mr}, {"kind": "uint", "flags": "uint", "c0": "vec3", "c1": "vec3", "c2": "vec3",
                           "alpha": "float", "eta": "float"})
    base = (0.8, 0.5, 0.3)
    kinds = [layout.MATERIAL_KINDS[k] for k in ("roughconductor", "conductor", "roughplastic", "plastic")]
    np.testing.assert_array_equal(out["kind"], kinds)
    np.testing.assert_allclose(out["alpha"], [0.16, 1e-3, 0.36, 1e-3], rtol=1e-6)
    for k in (0, 1):     # conductors: eta 0, k 1 (F = 1), the base colour as the tint
        np.testing.assert_allclose(out["c0"][k], 0.0)
        np.testing.assert_allclose(out["c1"][k], base, rtol=1e-6)
        np.testing.assert_allclose(out["c2"][k], 1.0)
    for k in (2, 3):     # plastics: the base colour under a white coating of IOR 1.5
        np.testing.assert_allclose(out["c0"][k], base, rtol=1e-6)
        np.testing.assert_allclose(out["c1"][k], 1.0)
        assert out["c2"][k][0] == pytest.approx(0.25) and out["eta"][k] == pytest.approx(1.5)
    two_sided = bindings.MATERIAL_FLAG_TWO_SIDED
    assert all(f & two_sided for f in out["flags"])
    # rough plastic reads the table over alpha: its R_int at alpha 0.36, the smooth one keeps Fdr
    assert out["flags"][2] & bindings.MATERIAL_FLAG_ALPHA_TABLE
    assert not out["flags"][3] & bindings.MATERIAL_FLAG_ALPHA_TABLE
    assert out["c2"][2][1] == pytest.approx(mt.internal_reflectance(0.36, 1.5, True), abs=1e-3)
    assert out["c2"][3][1] == pytest.approx(0.6)


def numpy_lookup(alpha: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """T of the table over alpha, bilinear in (sqrt(alpha), cos theta), as stated."""
    table = mt.alpha_table().astype(np.float64)
    s = mt.alpha_table_roughness()
    x = np.clip((np.sqrt(alpha) - s[0]) / (1 - s[0]), 0, 1) * (len(s) - 1)
    j = np.minimum(x.astype(int), len(s) - 2)
    y = cos_theta * (mt.TABLE_SIZE - 1)
    i = np.minimum(y.astype(int), mt.TABLE_SIZE - 2)
    fx, fy = x - j, y - i
    row = lambda jj: (1 - fy) * table[jj, i] + fy * table[jj, i + 1]
    return (1 - fx) * row(j) + fx * row(j + 1)


def test03_transmittance_lookup(gl_ctx):
    """roughplastic_transmittance under kMaterialFlagAlphaTable interpolates the table over
    alpha bilinearly; between its rows it stays within 2e-3 of T computed at that alpha
    (and within 4e-3 at grazing angles): the bias of per-texel rough plastic."""
    rng = np.random.default_rng(7)
    alpha = np.concatenate([rng.uniform(1e-3, 1.0, 200), [1e-3, 1.0, 0.02, 0.5]]).astype(np.float32)
    cos_theta = np.concatenate([rng.uniform(0, 1, 200), [0.0, 1.0, 0.999, 0.3]]).astype(np.float32)
    out = run("Bsdf b = Bsdf(kMaterialRoughPlastic, kMaterialFlagAlphaTable | kMaterialFlagGgx, vec3(0.5),\n"
              "              vec3(1.0), vec3(0.5), vec2(alpha), 1.5, 0u, vec3(0, 0, 1));\n"
              "float T = roughplastic_transmittance(b, cos_theta);\n"
              "float R = alpha_table_internal_reflectance(alpha);",
              {"alpha": alpha, "cos_theta": cos_theta}, {"T": "float", "R": "float"})
    np.testing.assert_allclose(out["T"], numpy_lookup(alpha.astype(np.float64), cos_theta.astype(np.float64)),
                               atol=2e-6)
    for a in (0.002, 0.05, 0.3, 0.7):
        got = run("Bsdf b = Bsdf(kMaterialRoughPlastic, kMaterialFlagAlphaTable | kMaterialFlagGgx, vec3(0.5),\n"
                  "              vec3(1.0), vec3(0.5), vec2(alpha), 1.5, 0u, vec3(0, 0, 1));\n"
                  "float T = roughplastic_transmittance(b, cos_theta);\n"
                  "float R = alpha_table_internal_reflectance(alpha);",
                  {"alpha": np.full(64, a, np.float32),
                   "cos_theta": np.linspace(0, 1, 64, dtype=np.float32)}, {"T": "float", "R": "float"})
        exact = mt.external_transmittance(a, 1.5, True)
        assert np.abs(got["T"][8:] - exact[8:]).max() < 2e-3, a
        assert np.abs(got["T"] - exact).max() < 4e-3, a
        assert got["R"][0] == pytest.approx(mt.internal_reflectance(a, 1.5, True), abs=1e-3)


@pytest.mark.parametrize("row", [0, 9, mt.ALPHA_TABLE_ROWS - 1])
def test04_shipped_table_is_the_computed_one(row):
    """The table in the package holds what microfacet_tables computes (rows checked here;
    ``python -m glrender.gpu.microfacet_tables`` writes the whole)."""
    s = mt.alpha_table_roughness()[row]
    np.testing.assert_array_equal(mt.alpha_table()[row], mt.alpha_table_row(s))
