"""Mitsuba 3's scalar_rgb BSDFs for parity tests: the same Material, evaluated by Mitsuba.

Naming: Mitsuba's si.wi is glrender's wo (toward the viewer / previous vertex) and
its wo is glrender's wi. BSDF values are RGB triples; Importance transport is
glrender's adjoint = True.
"""
from __future__ import annotations

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")


def _rgb(value):
    v = np.broadcast_to(np.asarray(value, np.float64), (3,))
    return {"type": "rgb", "value": [float(x) for x in v]}


def mitsuba_dict(mat) -> dict:
    """The Mitsuba scene dictionary of a glrender Material (constant colours only)."""
    d = {"type": mat.kind}
    if mat.kind in ("conductor", "roughconductor"):
        d.update(eta=_rgb(mat.eta), k=_rgb(mat.k), specular_reflectance=_rgb(mat.specular_reflectance))
    if mat.kind in ("dielectric", "roughdielectric", "thindielectric", "plastic", "roughplastic"):
        d.update(int_ior=float(mat.int_ior), ext_ior=float(mat.ext_ior),
                 specular_reflectance=_rgb(mat.specular_reflectance))
    if mat.kind in ("dielectric", "roughdielectric", "thindielectric"):
        d["specular_transmittance"] = _rgb(mat.specular_transmittance)
    if mat.kind in ("plastic", "roughplastic"):
        d.update(diffuse_reflectance=_rgb(mat.reflectance), nonlinear=bool(mat.nonlinear))
    if mat.kind == "diffuse":
        d["reflectance"] = _rgb(mat.reflectance)
    if mat.kind.startswith("rough"):
        a = np.broadcast_to(np.asarray(mat.alpha, np.float64), (2,))
        d["distribution"] = mat.distribution
        if a[0] == a[1]:
            d["alpha"] = float(a[0])
        else:
            d["alpha_u"], d["alpha_v"] = float(a[0]), float(a[1])
    if mat.two_sided:
        d = {"type": "twosided", "bsdf": d}
    return d


def load(mat):
    return mi.load_dict(mitsuba_dict(mat))


def _ctx(adjoint: bool):
    return mi.BSDFContext(mi.TransportMode.Importance if adjoint else mi.TransportMode.Radiance)


def _si(wo):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*map(float, wo))
    return si


def eval_pdf(bsdf, wo, wi, adjoint: bool = False):
    """Mitsuba's eval (N, 3) and pdf (N,) at glrender's (wo, wi) pairs."""
    ctx = _ctx(adjoint)
    f = np.zeros((len(wo), 3))
    pdf = np.zeros(len(wo))
    for n, (a, b) in enumerate(zip(wo, wi)):
        si, w = _si(a), mi.Vector3f(*map(float, b))
        f[n] = bsdf.eval(ctx, si, w)
        pdf[n] = bsdf.pdf(ctx, si, w)
    return f, pdf


def sample(bsdf, wo, u_lobe, u, adjoint: bool = False):
    """Mitsuba's sample: wi (N, 3), weight (N, 3), pdf, eta (N,)."""
    ctx = _ctx(adjoint)
    out = {"wi": np.zeros((len(u), 3)), "weight": np.zeros((len(u), 3)),
           "pdf": np.zeros(len(u)), "eta": np.zeros(len(u))}
    for n in range(len(u)):
        bs, w = bsdf.sample(ctx, _si(wo[n]), float(u_lobe[n]), mi.Point2f(*map(float, u[n])))
        out["wi"][n], out["weight"][n], out["pdf"][n], out["eta"][n] = bs.wo, w, bs.pdf, bs.eta
    return out
