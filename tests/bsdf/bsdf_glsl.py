"""Run the BSDFs of shaders/bsdf/ on the device for the tests: eval, pdf and sample.

A material goes through glrender.gpu.pack.pack_material, as in the renderer; its
record's fields become uniforms and its table a buffer, and the test kernel builds
the Bsdf from them and calls the dispatch of bsdf/bsdf.glsl (two-sided handling
included). Every material kind is compiled in, so one kernel serves every test.
"""
from __future__ import annotations

import numpy as np

from glrender.gpu import layout
from glrender.gpu.pack import pack_material
from glrender.render.params import shader_defines
from glrender.scene.model import Material
from glrender.testing.harness import run_glsl

DEFINES = shader_defines(material_kinds=tuple(layout.MATERIAL_KINDS))
INCLUDES = ["bsdf/bsdf.glsl"]
PREAMBLE = """
float material_table_fetch(uint material, uint i) { return table[i]; }
Bsdf test_bsdf() { return Bsdf(u_kind, u_flags, u_c0, u_c1, u_c2, u_alpha, u_eta, 0u, u_n0); }
"""


def record(mat) -> np.ndarray:
    """The packed MaterialData of a Material (or an already packed record)."""
    return pack_material(mat) if isinstance(mat, Material) else mat


def _uniforms(rec, adjoint: bool, n0=(0.0, 0.0, 1.0)) -> dict:
    return {"u_n0": ("vec3", tuple(map(float, n0))),"u_kind": ("uint", int(rec["info"][0])), "u_flags": ("uint", int(rec["info"][1])),
            "u_c0": ("vec3", tuple(map(float, rec["color0"][:3]))),
            "u_c1": ("vec3", tuple(map(float, rec["color1"][:3]))),
            "u_c2": ("vec3", tuple(map(float, rec["color2"][:3]))),
            "u_alpha": ("vec2", tuple(map(float, rec["params"][:2]))),
            "u_eta": ("float", float(rec["params"][2])), "u_adjoint": ("uint", int(adjoint))}


def _run(body, inputs, outputs, mat, adjoint, n0=(0.0, 0.0, 1.0), defines=None):
    """``n0``: Bsdf.n0, the unperturbed normal in the local frame (a normal map's
    shadowing term); ``defines`` replace DEFINES."""
    rec = record(mat)
    return run_glsl(body, inputs, outputs, includes=INCLUDES, uniforms=_uniforms(rec, adjoint, n0),
                    buffers={"table": np.asarray(rec["table"], np.float32)},
                    defines=DEFINES if defines is None else defines, preamble=PREAMBLE)


def f32(a) -> np.ndarray:
    return np.ascontiguousarray(a, np.float32)


def eval_pdf(mat, wo, wi, adjoint: bool = False, **options) -> tuple[np.ndarray, np.ndarray]:
    """bsdf_eval (f |cos theta_i|, (N, 3)) and bsdf_pdf ((N,)) at direction pairs
    (``options``: _run's n0 and defines)."""
    out = _run("Bsdf b = test_bsdf();\n"
               "vec3 f = bsdf_eval(b, wo, wi, u_adjoint != 0u);\n"
               "float pdf = bsdf_pdf(b, wo, wi);",
               {"wo": f32(wo), "wi": f32(wi)}, {"f": "vec3", "pdf": "float"}, mat, adjoint, **options)
    return out["f"].astype(np.float64), out["pdf"].astype(np.float64)


def sample(mat, wo, u_lobe, u, adjoint: bool = False, **options) -> dict[str, np.ndarray]:
    """bsdf_sample for each (wo, u_lobe, u); the BsdfSample fields as arrays."""
    wo = np.broadcast_to(f32(wo), (len(u), 3))
    out = _run("Bsdf b = test_bsdf();\n"
               "BsdfSample s = bsdf_sample(b, wo, u_lobe, u, u_adjoint != 0u);\n"
               "vec3 wi = s.wi; vec3 weight = s.weight; float pdf = s.pdf; float eta = s.eta;\n"
               "bool delta = s.delta; bool valid = s.valid;",
               {"wo": f32(wo), "u_lobe": f32(u_lobe), "u": f32(u)},
               {"wi": "vec3", "weight": "vec3", "pdf": "float", "eta": "float", "delta": "bool",
                "valid": "bool"}, mat, adjoint, **options)
    res = {k: v.astype(np.float64) for k, v in out.items() if k not in ("delta", "valid")}
    res["delta"], res["valid"] = out["delta"].astype(bool), out["valid"].astype(bool)
    return res


def direction(theta_deg: float, phi_deg: float = 0.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def uniform_sphere(n: int, rng) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def albedo_and_delta(mat) -> tuple[np.ndarray, bool]:
    """bsdf_albedo (the albedo AOV) and bsdf_is_delta of a material."""
    out = _run("Bsdf b = test_bsdf(); vec3 a = bsdf_albedo(b); bool delta = bsdf_is_delta(b);",
               {"x": np.zeros(1, np.float32)}, {"a": "vec3", "delta": "bool"}, mat, False)
    return out["a"][0].astype(np.float64), bool(out["delta"][0])
