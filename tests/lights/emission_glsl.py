"""Run lights/light.glsl's emission sampling on the device for the tests.

A light is given as a packed LightData record (glrender.gpu.layout.LIGHT) whose fields
become uniforms; every light kind is compiled in.
"""
from __future__ import annotations

import math

import numpy as np

from glrender.gpu import bindings, layout
from glrender.render.params import shader_defines
from glrender.testing.harness import run_glsl

DEFINES = shader_defines(light_kinds=tuple(layout.LIGHT_KINDS))
SPHERE = (0.5, -0.25, 1.0, 3.0)   # the scene's bounding sphere for lights at infinity
LIGHT = ("LightData l = LightData(l_p, l_e1, l_e2, l_n, l_radiance, l_params.xyz, l_params.w, "
         "l_info, vec2(0.0), vec2(0.0), vec2(0.0), 0.0, 0.0);\n")


def record(kind: str, *, p=(0, 0, 0), e1=(0, 0, 0, 0), e2=(0, 0, 0), n=(0, 0, 1, 0),
           radiance=(1, 1, 1), params=(0, 0, 0, 0), flags=0) -> np.ndarray:
    rec = np.zeros(1, layout.LIGHT)[0]
    rec["p"][:3], rec["e1"][:len(e1)], rec["e2"][:3] = p, e1, e2
    rec["n"][:len(n)], rec["radiance"][:3] = n, radiance
    rec["params"], rec["selection_pmf"] = params[:3], params[3]
    rec["info"][:3] = (layout.LIGHT_KINDS[kind], flags, 0xFFFFFFFF)
    return rec


def parallelogram(p, e1, e2, radiance=(1, 2, 3), two_sided=False) -> np.ndarray:
    c = np.cross(e1, e2)
    area = float(np.linalg.norm(c))
    return record("parallelogram", p=p, e1=e1, e2=e2, n=(*(c / area), area), radiance=radiance,
                  flags=bindings.LIGHT_FLAG_TWO_SIDED if two_sided else 0)


def triangle(p, e1, e2, radiance=(1, 2, 3)) -> np.ndarray:
    c = np.cross(e1, e2)
    norm = float(np.linalg.norm(c))
    return record("triangle", p=p, e1=e1, e2=e2, n=(*(c / norm), 0.5 * norm), radiance=radiance)


def sphere(center, radius, radiance=(1, 2, 3)) -> np.ndarray:
    return record("sphere", p=center, e1=(0, 0, 0, radius), n=(0, 0, 1, 4 * math.pi * radius ** 2),
                  radiance=radiance)


def spot(position, axis, intensity=(1, 2, 3), cutoff=30.0, beam=20.0) -> np.ndarray:
    a = np.asarray(axis, np.float64)
    return record("spot", p=position, n=(*(a / np.linalg.norm(a)), 0), radiance=intensity,
                  params=(math.cos(math.radians(cutoff)), math.cos(math.radians(beam)), 0, 0))


def _uniforms(rec) -> dict:
    f = {name: ("vec4", tuple(map(float, rec[name]))) for name in ("p", "e1", "e2", "n", "radiance")}
    f["params"] = ("vec4", (*map(float, rec["params"]), float(rec["selection_pmf"])))
    uniforms = {f"l_{k}": v for k, v in f.items()}
    uniforms["l_info"] = ("uvec4", tuple(int(x) for x in rec["info"]))
    uniforms["u_sphere"] = ("vec4", SPHERE)
    return uniforms


def sample_emission(rec, u: np.ndarray) -> dict[str, np.ndarray]:
    """sample_light_emission for u (N, 4) = (u_pos, u_dir), with light_emission_pdf at the
    returned point and direction (pdf_pos_eval, pdf_dir_eval)."""
    body = LIGHT + (
        "LightEmission e = sample_light_emission(l, u.xy, u.zw, u_sphere);\n"
        "float pdf_pos_eval, pdf_dir_eval;\n"
        "light_emission_pdf(l, e.p, e.n, e.d, u_sphere, pdf_pos_eval, pdf_dir_eval);\n"
        "vec4 p_pdf = vec4(e.p, e.pdf_pos); vec4 d_pdf = vec4(e.d, e.pdf_dir);\n"
        "vec4 n_eval = vec4(e.n, pdf_pos_eval); vec4 Le_eval = vec4(e.Le, pdf_dir_eval);\n"
        "uint flags = (e.delta_pos ? 1u : 0u) | (e.delta_dir ? 2u : 0u);")
    o = run_glsl(body, {"u": np.ascontiguousarray(u, np.float32)},
                 {"p_pdf": "vec4", "d_pdf": "vec4", "n_eval": "vec4", "Le_eval": "vec4", "flags": "uint"},
                 includes=["lights/light.glsl"], uniforms=_uniforms(rec), defines=DEFINES)
    f64 = lambda a: a.astype(np.float64)  # noqa: E731
    out = {"p": f64(o["p_pdf"][:, :3]), "pdf_pos": f64(o["p_pdf"][:, 3]),
           "d": f64(o["d_pdf"][:, :3]), "pdf_dir": f64(o["d_pdf"][:, 3]),
           "n": f64(o["n_eval"][:, :3]), "pdf_pos_eval": f64(o["n_eval"][:, 3]),
           "Le": f64(o["Le_eval"][:, :3]), "pdf_dir_eval": f64(o["Le_eval"][:, 3]),
           "delta_pos": (o["flags"] & 1) != 0, "delta_dir": (o["flags"] & 2) != 0}
    return out


def emission_pdf(rec, p, n, d) -> tuple[np.ndarray, np.ndarray]:
    """light_emission_pdf at points p with normals n and directions d, each (N, 3)."""
    body = LIGHT + ("float pdf_pos, pdf_dir;\n"
                    "light_emission_pdf(l, p, n, d, u_sphere, pdf_pos, pdf_dir);")
    f = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
    out = run_glsl(body, {"p": f(p), "n": f(n), "d": f(d)}, {"pdf_pos": "float", "pdf_dir": "float"},
                   includes=["lights/light.glsl"], uniforms=_uniforms(rec), defines=DEFINES)
    return out["pdf_pos"].astype(np.float64), out["pdf_dir"].astype(np.float64)
