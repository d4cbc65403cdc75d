"""The catalogue of continuous warps: each GLSL warp with its numpy twin, pdf, inverse and test domain.

One :class:`Warp` per sampling routine of ``shaders/sampling/`` that maps uniform
numbers to points: the test suite runs every entry through the same checks (chi-square
against its pdf, pdf integral, round trip through the inverse, GLSL against numpy),
and ``glrender sampling`` plots them and tabulates their chi-square p-values.
Fixed parameters (cone angle, lobe exponent, roughness, light geometry) are chosen to
exercise the routines away from trivial cases.

:func:`run_warp` evaluates a warp in GLSL in one harness call: the sampled points
``p``, the pdf function at them (``pdf``), the density the sampler reported through
an ``out`` argument if it has one (``sample_pdf``, else -1) and the inverse at the
sampled points (``u_back``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..testing.chi2 import LineDomain, PlanarDomain, SphericalDomain
from ..testing.harness import run_glsl
from . import (cone, disk, disk_rejection, distributions, hemisphere, microfacet, phase, phong,
               power, sphere, spherical_rectangle, spherical_triangle, triangle)
from ._array import normalize
from .sequences import hash_combine, uint_to_unit_float

ArrayFn = Callable[[np.ndarray], np.ndarray]
EPS32 = 2.0 ** -23  # float32 machine epsilon (spacing of floats in [1, 2))
# GLSL leaves the precision of atan to the implementation: llvmpipe (Mesa 22.3 and 25.0)
# measured 2.1e-5 relative and 3.5e-6 absolute error (sin, cos, exp, log, sqrt, pow: a few ulps;
# asin and acos ~4e-4 absolute, so no warp uses them). Tolerances of results that pass
# through atan are derived from these bounds, with a margin.
ATAN_REL = 2.5e-5
ATAN_ABS = 4e-6
# An azimuth fraction phi / 2 pi from atan(y, x).
AZIMUTH_TOL = ATAN_ABS / (2 * np.pi) + 16 * EPS32
# Support tests of the chi-square pdfs accept points this close outside the support:
# float32 samples on a support boundary may round to just outside it (the extra
# probability mass, ~1e-6 times the boundary length, is far below what 1e6 samples see).
SUPPORT_SLACK = 1e-6


@dataclass(frozen=True)
class Warp:
    """A warp of ``sample_dim`` uniform numbers and everything needed to test and plot it.

    ``sample_glsl``: GLSL expression of ``u`` (float, vec2 or vec4) giving the point (of
    ``point_type``); it may write ``sample_pdf`` through an ``out`` argument.
    ``pdf_glsl``: GLSL expression of the point ``p`` (in the sampler's support).
    ``invert_glsl``: GLSL expression of ``p`` giving ``u`` back, or None.
    ``sample``, ``invert``: numpy twins on the same arguments; ``pdf``: numpy density
    on the points of ``domain`` (after ``to_domain``), zero outside the support.
    ``roundtrip_tol``: bound on |invert(sample(u)) - u| for u where ``well_conditioned``
    holds, and on |GLSL inverse - numpy inverse| there; ``agree_tol``: bound on
    |GLSL - numpy| for points; ``pdf_tol``: relative bound for densities (GLSL pdf against
    numpy pdf, and against the density the sampler returned).
    """

    name: str
    title: str
    includes: tuple[str, ...]
    point_type: str
    sample_glsl: str
    pdf_glsl: str
    sample: ArrayFn
    pdf: ArrayFn
    domain: object
    invert_glsl: str | None = None
    invert: ArrayFn | None = None
    sample_dim: int = 2
    to_domain: ArrayFn = staticmethod(lambda p: p)
    uniforms: dict = field(default_factory=dict)
    buffers: dict = field(default_factory=dict)
    preamble: str = ""
    setup: str = ""
    res: int = 101
    roundtrip_tol: float = AZIMUTH_TOL
    well_conditioned: ArrayFn = staticmethod(lambda u: np.ones(len(u), bool))
    agree_tol: float = 16 * EPS32
    pdf_tol: float = 16 * EPS32
    plot: str = "planar"  # planar | sphere | none
    group: str = ""       # warps drawn together in one figure


U_TYPES = {1: "float", 2: "vec2", 4: "vec4"}


def run_warp(warp: Warp, u: np.ndarray) -> dict[str, np.ndarray]:
    """Evaluate the GLSL warp on the uniforms ``u`` (N, sample_dim) in one harness call."""
    u = np.ascontiguousarray(u, np.float32).reshape(len(u), warp.sample_dim)
    u_type = U_TYPES[warp.sample_dim]
    lines = [warp.setup, "float sample_pdf = -1.0;",
             f"{warp.point_type} p = {warp.sample_glsl};",
             f"float pdf = {warp.pdf_glsl};"]
    outputs = {"p": warp.point_type, "pdf": "float", "sample_pdf": "float"}
    if warp.invert_glsl:
        lines.append(f"{u_type} u_back = {warp.invert_glsl};")
        outputs["u_back"] = u_type
    return run_glsl("\n".join(lines), {"u": u if warp.sample_dim > 1 else u[:, 0]}, outputs,
                    includes=list(warp.includes), uniforms=warp.uniforms, buffers=warp.buffers,
                    preamble=warp.preamble, input_types={"u": u_type})


# ---- helpers for the entries --------------------------------------------------------------
def _unit(v) -> tuple[float, float, float]:
    v = np.asarray(v, np.float64)
    return tuple(float(c) for c in v / np.linalg.norm(v))


def _vec(v) -> tuple[str, tuple[float, ...]]:
    return ("vec3", tuple(float(c) for c in v))


def _disk_support(p) -> np.ndarray:
    return np.sum(np.asarray(p) ** 2, axis=1) <= 1.0 + SUPPORT_SLACK


# ---- rejection: uniforms of the trials after the first, from a hash of u -------------------
REJECTION_PREAMBLE = """
vec2 g_rejection_u;
// Trial 0 uses the warp's own u; later trials a PCG hash of u's bits (the test kernel's RNG).
vec2 disk_rejection_uniform(uint trial) {
    if (trial == 0u) return g_rejection_u;
    uint key = hash_combine(floatBitsToUint(g_rejection_u.x), floatBitsToUint(g_rejection_u.y));
    return vec2(uint_to_unit_float(hash_combine(key, 2u * trial)),
                uint_to_unit_float(hash_combine(key, 2u * trial + 1u)));
}
"""


def rejection_trial_uniforms(u: np.ndarray, trials: int) -> np.ndarray:
    """The uniforms REJECTION_PREAMBLE supplies, as an (N, trials, 2) array."""
    u = np.asarray(u, np.float32).reshape(-1, 2)
    key = hash_combine(u[:, 0].view(np.uint32), u[:, 1].view(np.uint32))
    out = np.empty((len(u), trials, 2), np.float32)
    out[:, 0] = u
    for t in range(1, trials):
        out[:, t, 0] = uint_to_unit_float(hash_combine(key, 2 * t))
        out[:, t, 1] = uint_to_unit_float(hash_combine(key, 2 * t + 1))
    return out


def _rejection_numpy(u: np.ndarray) -> np.ndarray:
    points = [disk_rejection.sample_uniform_disk_rejection(
        rejection_trial_uniforms(chunk, disk_rejection.DISK_REJECTION_MAX_TRIALS))[0]
        for chunk in np.array_split(np.asarray(u), max(1, len(u) // 20_000))]
    return np.concatenate(points)


# ---- fixed geometry of the parametrised warps ---------------------------------------------
COS_THETA_MAX = 0.8
PHONG_N = 12.0
POWER_N = 3
TRIANGLE = ((-0.3, -0.4, 1.0), (0.8, -0.2, 1.2), (0.1, 0.7, 0.9))
TRIANGLE_REF = (0.0, 0.0, 0.0)
RECTANGLE = dict(s=(-0.5, -0.4, 1.0), ex=(1.0, 0.0, 0.2), ey=(0.0, 0.8, 0.0))
RECTANGLE_REF = (0.2, -0.1, 0.0)
ALPHA = (0.3, 0.6)
# Henyey-Greenstein mean cosines: forward and backward scattering (g = 0 is the uniform
# sphere's density, already catalogued as uniform_sphere)
HG_G = (0.7, -0.7)
# Beckmann slopes come from a Newton iteration that stops when |CDF(x) - u| < 1e-6:
# GLSL (float32) and numpy (float64) may stop at slopes 1e-6 / density apart, which is
# large in the tails; the CDF-level check is in tests/sampling/test_microfacet.py.
BECKMANN_TOL = 2e-3
WO_OBLIQUE = _unit((0.5, -0.3, 0.6))
DIST_1D = np.array([0.0, 1.0, 3.0, 0.0, 2.0, 5.0, 0.5])
DIST_1D_BOUNDS = (-1.0, 2.0)
DIST_2D = np.array([[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    [9.0, 1.0, 0.5, 0.0, 0.5, 1.0, 9.0],
                    [2.0, 2.0, 2.0, 7.0, 2.0, 2.0, 2.0],
                    [0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4]])  # rows: v bins, columns: u bins
TABLE_PREAMBLE = "float distribution_fetch(uint i) { return table[i]; }"


def _table_1d() -> np.ndarray:
    return distributions.distribution_1d_table(DIST_1D, DIST_1D_BOUNDS)


def _table_2d() -> np.ndarray:
    return distributions.distribution_2d_table(DIST_2D)


def _triangle_uniforms() -> dict:
    v0, v1, v2 = TRIANGLE
    return {"v0": _vec(v0), "v1": _vec(v1), "v2": _vec(v2), "p_ref": _vec(TRIANGLE_REF)}


def _rectangle_uniforms() -> dict:
    return {"rect_s": _vec(RECTANGLE["s"]), "rect_ex": _vec(RECTANGLE["ex"]),
            "rect_ey": _vec(RECTANGLE["ey"]), "p_ref": _vec(RECTANGLE_REF)}


def _rectangle_direction(p) -> np.ndarray:
    return normalize(np.asarray(p, np.float64) - np.asarray(RECTANGLE_REF))


def _sphere_pdf(density: Callable[[np.ndarray], np.ndarray]) -> ArrayFn:
    return lambda w: density(np.asarray(w, np.float64))


def _triangle_pdf(b12: np.ndarray) -> np.ndarray:
    """Uniform density 2 on the reference triangle b1, b2 >= 0, b1 + b2 <= 1."""
    b = np.asarray(b12, np.float64)
    inside = ((b[:, 0] >= -SUPPORT_SLACK) & (b[:, 1] >= -SUPPORT_SLACK) &
              (b[:, 0] + b[:, 1] <= 1 + SUPPORT_SLACK))
    return np.where(inside, 2.0, 0.0)


def _microfacet_warp(name, title, sampler, pdf_fn, sample_fn, wo, alpha, invert=None,
                     invert_fn=None, agree_tol=256 * EPS32) -> Warp:
    return Warp(
        name=name, title=title, includes=("sampling/microfacet.glsl",), point_type="vec3",
        sample_glsl=f"{sampler}(wo, alpha, u)", pdf_glsl=f"{pdf_fn.__name__}(wo, p, alpha)",
        sample=lambda u: sample_fn(wo, alpha, u),
        pdf=lambda w: pdf_fn(wo, w, alpha),
        domain=SphericalDomain(), uniforms={"wo": _vec(wo), "alpha": ("vec2", alpha)},
        invert_glsl=invert and f"{invert}(wo, p, alpha)",
        invert=invert_fn and (lambda w: invert_fn(wo, w, alpha)),
        # the polar disk inside loses the angle near its centre (u.x -> 0); the stretch
        # and the half-disk warp scale errors by up to 1 / alpha
        roundtrip_tol=AZIMUTH_TOL / min(alpha), well_conditioned=lambda u: u[:, 0] >= 1e-3,
        # normalising the unstretched normal: errors up to ~eps / (alpha cos theta_m)
        agree_tol=agree_tol, pdf_tol=256 * EPS32, plot="sphere", group="microfacet")


def _hg_warp(g: float) -> Warp:
    """Henyey-Greenstein scattering about +z with mean cosine g."""
    g32 = float(np.float32(g))  # the numpy twin sees the uniform's float32 value
    return Warp(
        name=f"hg_{'forward' if g > 0 else 'backward'}", title=f"Henyey-Greenstein, g = {g:g}",
        includes=("sampling/phase.glsl",), point_type="vec3",
        sample_glsl="sample_hg(u, g)", pdf_glsl="hg_phase(p.z, g)",
        invert_glsl="invert_hg_sample(p, g)",
        sample=lambda u: phase.sample_hg(u, g32),
        pdf=_sphere_pdf(lambda w: phase.hg_phase(w[:, 2], g32)),
        invert=lambda w: phase.invert_hg_sample(w, g32),
        domain=SphericalDomain(), uniforms={"g": g},
        # only u.x = 0 (cos theta = -1, the pole) loses the azimuth: x and y keep their
        # relative accuracy however small sin theta is
        well_conditioned=lambda u: u[:, 0] > 0, plot="sphere", group="phase")


def _triangle_warp(suffix: str, title: str, **fields) -> Warp:
    """A uniform triangle map (barycentrics), tested on the reference triangle (b1, b2)."""
    name = f"uniform_triangle{suffix}"
    return Warp(
        name=name, title=title, includes=("sampling/triangle.glsl",), point_type="vec3",
        sample_glsl=f"sample_{name}(u)", pdf_glsl="uniform_triangle_pdf(0.5)",
        invert_glsl=f"invert_{name}_sample(p)", sample=getattr(triangle, f"sample_{name}"),
        pdf=_triangle_pdf, invert=getattr(triangle, f"invert_{name}_sample"),
        domain=PlanarDomain(((0.0, 1.0), (0.0, 1.0))), to_domain=lambda b: b[:, 1:3],
        group="triangle", **fields)


def _table_warp(dim: str, title: str, table: np.ndarray, domain, **fields) -> Warp:
    """The piecewise-constant 1D or 2D distribution of a packed table at offset 0."""
    kind = f"distribution_{dim}"
    sample, pdf = getattr(distributions, f"sample_{kind}"), getattr(distributions, f"{kind}_pdf")
    invert = getattr(distributions, f"invert_{kind}_sample")
    one = dim == "1d"
    return Warp(
        name=kind, title=title, sample_dim=1 if one else 2,
        includes=(f"sampling/distribution{dim}.glsl",), point_type="float" if one else "vec2",
        setup="uint bin;" if one else "",
        sample_glsl=f"sample_{kind}(0u, u, sample_pdf{', bin' if one else ''})",
        pdf_glsl=f"{kind}_pdf(0u, p)", invert_glsl=f"invert_{kind}_sample(0u, p)",
        sample=lambda u: sample(table, 0, u)[0], pdf=lambda x: pdf(table, 0, x),
        invert=lambda x: invert(table, 0, x), domain=domain,
        buffers={"table": table}, preamble=TABLE_PREAMBLE, roundtrip_tol=64 * EPS32, **fields)


def build_catalog() -> list[Warp]:
    """Every continuous warp, in the order of the lecture."""
    table_1d, table_2d = _table_1d(), _table_2d()
    warps = [
        # -- 1D: the power function, by inversion and by the max of n + 1 uniforms ---------
        Warp(name="power_inversion", title=f"power x^{POWER_N}: inversion", sample_dim=1,
             includes=("sampling/power.glsl",), point_type="float",
             sample_glsl=f"sample_power(u, {POWER_N}.0)", pdf_glsl=f"power_pdf(p, {POWER_N}.0)",
             invert_glsl=f"invert_power_sample(p, {POWER_N}.0)",
             sample=lambda u: power.sample_power(u, POWER_N),
             pdf=lambda x: power.power_pdf(x, POWER_N),
             invert=lambda x: power.invert_power_sample(x, POWER_N),
             domain=LineDomain((0.0, 1.0)), plot="none"),
        Warp(name="power_max", title=f"power x^{POWER_N}: max of {POWER_N + 1} uniforms",
             sample_dim=4, includes=("sampling/power.glsl",), point_type="float",
             sample_glsl=f"sample_power_max(u, {POWER_N})", pdf_glsl=f"power_pdf(p, {POWER_N}.0)",
             sample=lambda u: power.sample_power_max(u, POWER_N),
             pdf=lambda x: power.power_pdf(x, POWER_N),
             domain=LineDomain((0.0, 1.0)), plot="none"),
        # the bin's CDF step scales the float32 error of x by n * pmf <= 7 * 5 / 11.5
        _table_warp("1d", "piecewise-constant 1D", table_1d, LineDomain(DIST_1D_BOUNDS),
                    res=7 * 15, plot="none"),
        # -- the disk --------------------------------------------------------------------------
        Warp(name="disk_linear_radius", title="polar, r = u (not uniform)",
             includes=("sampling/disk.glsl",), point_type="vec2",
             sample_glsl="sample_disk_linear_radius(u)", pdf_glsl="disk_linear_radius_pdf(p)",
             invert_glsl="invert_disk_linear_radius_sample(p)",
             sample=disk.sample_disk_linear_radius, pdf=disk.disk_linear_radius_pdf,
             invert=disk.invert_disk_linear_radius_sample, domain=PlanarDomain(),
             well_conditioned=lambda u: u[:, 0] >= 1e-2, group="disk"),
        Warp(name="uniform_disk_polar", title="equi-areal polar, r = sqrt(u)",
             includes=("sampling/disk.glsl",), point_type="vec2",
             sample_glsl="sample_uniform_disk_polar(u)",
             pdf_glsl="uniform_disk_pdf()", invert_glsl="invert_uniform_disk_polar_sample(p)",
             sample=disk.sample_uniform_disk_polar,
             pdf=lambda p: np.where(_disk_support(p), disk.uniform_disk_pdf(), 0.0),
             invert=disk.invert_uniform_disk_polar_sample, domain=PlanarDomain(),
             well_conditioned=lambda u: u[:, 0] >= 1e-4, group="disk"),
        Warp(name="uniform_disk_concentric", title="concentric (Shirley-Chiu)",
             includes=("sampling/disk.glsl",), point_type="vec2",
             sample_glsl="sample_uniform_disk_concentric(u)", pdf_glsl="uniform_disk_pdf()",
             invert_glsl="invert_uniform_disk_concentric_sample(p)",
             sample=disk.sample_uniform_disk_concentric,
             pdf=lambda p: np.where(_disk_support(p), disk.uniform_disk_pdf(), 0.0),
             invert=disk.invert_uniform_disk_concentric_sample, domain=PlanarDomain(),
             # the angle inside a ring of half-width r carries float32 error ~ eps / r;
             # u = (1 + r atan(.) / (pi / 4)) / 2 takes atan's relative error times 1/2
             well_conditioned=lambda u: np.max(np.abs(2 * u - 1), axis=1) >= 1e-2,
             roundtrip_tol=ATAN_REL / 2 + 16 * EPS32, group="disk"),
        Warp(name="uniform_disk_rejection", title="rejection from the square",
             includes=("sampling/disk_rejection.glsl", "common/hash.glsl"), point_type="vec2",
             setup="g_rejection_u = u; uint trials;",
             sample_glsl="sample_uniform_disk_rejection(trials)", pdf_glsl="uniform_disk_pdf()",
             preamble=REJECTION_PREAMBLE, sample=_rejection_numpy,
             pdf=lambda p: np.where(_disk_support(p), disk.uniform_disk_pdf(), 0.0),
             domain=PlanarDomain(), group="disk"),
        # -- the triangle ------------------------------------------------------------------------
        # u.y = b1 / (1 - b0) is lost where 1 - b0 = sqrt(u.x) is small
        _triangle_warp("_sqrt", "triangle, sqrt map (lecture)",
                       well_conditioned=lambda u: u[:, 0] >= 1e-4),
        _triangle_warp("", "triangle, Heitz 2019 low-distortion map"),
        _table_warp("2d", "piecewise-constant 2D (image)", table_2d,
                    PlanarDomain(((0.0, 1.0), (0.0, 1.0))), res=105,  # a multiple of 5 and 7
                    group="distribution"),
        # -- directions --------------------------------------------------------------------------
        Warp(name="uniform_sphere", title="uniform sphere",
             includes=("sampling/sphere.glsl",), point_type="vec3",
             sample_glsl="sample_uniform_sphere(u)", pdf_glsl="uniform_sphere_pdf()",
             invert_glsl="invert_uniform_sphere_sample(p)",
             sample=sphere.sample_uniform_sphere,
             pdf=_sphere_pdf(lambda w: np.full(len(w), sphere.uniform_sphere_pdf())),
             invert=sphere.invert_uniform_sphere_sample, domain=SphericalDomain(),
             # the azimuth is lost near the poles: judged where sin theta >= ~1e-2
             well_conditioned=lambda u: (u[:, 0] >= 1e-4) & (u[:, 0] <= 1 - 1e-4),
             plot="sphere", group="directions"),
        Warp(name="uniform_hemisphere", title="uniform hemisphere",
             includes=("sampling/hemisphere.glsl",), point_type="vec3",
             sample_glsl="sample_uniform_hemisphere(u)", pdf_glsl="uniform_hemisphere_pdf()",
             invert_glsl="invert_uniform_hemisphere_sample(p)",
             sample=hemisphere.sample_uniform_hemisphere,
             pdf=_sphere_pdf(lambda w: np.where(w[:, 2] >= -SUPPORT_SLACK,
                                                hemisphere.uniform_hemisphere_pdf(), 0.0)),
             invert=hemisphere.invert_uniform_hemisphere_sample, domain=SphericalDomain(),
             well_conditioned=lambda u: u[:, 0] <= 1 - 1e-4, plot="sphere", group="directions"),
        Warp(name="cosine_hemisphere", title="cosine hemisphere (Malley, concentric)",
             includes=("sampling/hemisphere.glsl",), point_type="vec3",
             sample_glsl="sample_cosine_hemisphere(u)", pdf_glsl="cosine_hemisphere_pdf(p.z)",
             invert_glsl="invert_cosine_hemisphere_sample(p)",
             sample=hemisphere.sample_cosine_hemisphere,
             pdf=_sphere_pdf(lambda w: hemisphere.cosine_hemisphere_pdf(w[:, 2])),
             invert=hemisphere.invert_cosine_hemisphere_sample, domain=SphericalDomain(),
             # the concentric map's centre is the pole, where the angle is lost
             well_conditioned=lambda u: np.max(np.abs(2 * u - 1), axis=1) >= 1e-2,
             roundtrip_tol=ATAN_REL / 2 + 16 * EPS32,
             plot="sphere", group="directions"),
        Warp(name="uniform_cone", title=f"uniform cone, cos theta_max = {COS_THETA_MAX}",
             includes=("sampling/cone.glsl",), point_type="vec3",
             sample_glsl="sample_uniform_cone(u, cos_theta_max)",
             pdf_glsl="uniform_cone_pdf(cos_theta_max)",
             invert_glsl="invert_uniform_cone_sample(p, cos_theta_max)",
             sample=lambda u: cone.sample_uniform_cone(u, COS_THETA_MAX),
             pdf=_sphere_pdf(lambda w: np.where(w[:, 2] >= COS_THETA_MAX - SUPPORT_SLACK,
                                                cone.uniform_cone_pdf(COS_THETA_MAX), 0.0)),
             invert=lambda w: cone.invert_uniform_cone_sample(w, COS_THETA_MAX),
             domain=SphericalDomain(), uniforms={"cos_theta_max": COS_THETA_MAX},
             # cells of width 2 / 110 in cos theta put the cone's rim (0.8) on a cell edge:
             # quadrature cannot integrate a jump across a whole row of cells accurately
             res=110,
             # u.x = (1 - z) / 0.2 multiplies z's float32 error by 5
             roundtrip_tol=AZIMUTH_TOL + 64 * EPS32, well_conditioned=lambda u: u[:, 0] >= 1e-3,
             plot="sphere", group="directions"),
        Warp(name="phong_lobe", title=f"Phong lobe cos^{PHONG_N:g}",
             includes=("sampling/phong.glsl",), point_type="vec3",
             sample_glsl=f"sample_phong_lobe(u, {PHONG_N})", pdf_glsl=f"phong_lobe_pdf(p.z, {PHONG_N})",
             invert_glsl=f"invert_phong_lobe_sample(p, {PHONG_N})",
             sample=lambda u: phong.sample_phong_lobe(u, PHONG_N),
             pdf=_sphere_pdf(lambda w: phong.phong_lobe_pdf(w[:, 2], PHONG_N)),
             invert=lambda w: phong.invert_phong_lobe_sample(w, PHONG_N),
             domain=SphericalDomain(),
             # u.x = z^13 multiplies z's relative error by 13; near the axis sin theta
             # from cos theta = u.x^(1/13) has error ~ eps / sin theta
             roundtrip_tol=AZIMUTH_TOL + 64 * EPS32, well_conditioned=lambda u: u[:, 0] <= 1 - 1e-3,
             agree_tol=1e-4, pdf_tol=64 * EPS32,
             plot="sphere", group="directions"),
        Warp(name="spherical_triangle", title="spherical triangle (Arvo 1995)",
             includes=("sampling/spherical_triangle.glsl",), point_type="vec3",
             sample_glsl="sample_spherical_triangle(v0, v1, v2, p_ref, u, sample_pdf)",
             pdf_glsl="spherical_triangle_pdf(v0, v1, v2, p_ref)",
             invert_glsl="invert_spherical_triangle_sample(v0, v1, v2, p_ref, p)",
             sample=lambda u: spherical_triangle.sample_spherical_triangle(*TRIANGLE, TRIANGLE_REF, u)[0],
             pdf=_sphere_pdf(lambda w: np.where(
                 spherical_triangle.spherical_triangle_contains(*TRIANGLE, TRIANGLE_REF, w,
                                                                SUPPORT_SLACK),
                 spherical_triangle.spherical_triangle_pdf(*TRIANGLE, TRIANGLE_REF), 0.0)),
             invert=lambda w: spherical_triangle.invert_spherical_triangle_sample(
                 *TRIANGLE, TRIANGLE_REF, w),
             domain=SphericalDomain(), uniforms=_triangle_uniforms(),
             # u.y is lost near the vertex b (1 - dot(w, b) -> 0) and the arc b-c' degenerates
             # near u.x = 0; judged away from both. u.x is a ratio of two areas from atan.
             roundtrip_tol=2 * ATAN_REL + 64 * EPS32,
             well_conditioned=lambda u: (u[:, 0] >= 1e-2) & (u[:, 1] >= 1e-2),
             agree_tol=64 * EPS32, pdf_tol=2 * ATAN_REL, plot="sphere", group="area_lights"),
        Warp(name="spherical_rectangle", title="spherical rectangle (Urena et al. 2013)",
             includes=("sampling/spherical_rectangle.glsl",), point_type="vec3",
             sample_glsl="sample_spherical_rectangle(p_ref, rect_s, rect_ex, rect_ey, u, sample_pdf)",
             pdf_glsl="spherical_rectangle_pdf(p_ref, rect_s, rect_ex, rect_ey)",
             sample=lambda u: spherical_rectangle.sample_spherical_rectangle(
                 RECTANGLE_REF, RECTANGLE["s"], RECTANGLE["ex"], RECTANGLE["ey"], u)[0],
             pdf=_sphere_pdf(lambda w: np.where(
                 spherical_rectangle.spherical_rectangle_contains(
                     RECTANGLE_REF, RECTANGLE["s"], RECTANGLE["ex"], RECTANGLE["ey"], w,
                     SUPPORT_SLACK),
                 spherical_rectangle.spherical_rectangle_pdf(
                     RECTANGLE_REF, RECTANGLE["s"], RECTANGLE["ex"], RECTANGLE["ey"]), 0.0)),
             to_domain=_rectangle_direction,
             domain=SphericalDomain(), uniforms=_rectangle_uniforms(),
             # S is the sum of two solid angles from atan (relative error <= ATAN_REL); the
             # points move by about S's relative error times the rectangle's size (~1)
             agree_tol=4 * ATAN_REL, pdf_tol=2 * ATAN_REL, plot="sphere", group="area_lights"),
        _microfacet_warp("ggx_visible_normal", f"GGX visible normals, alpha = {ALPHA}",
                         "sample_ggx_visible_normal", microfacet.ggx_visible_normal_pdf,
                         microfacet.sample_ggx_visible_normal, WO_OBLIQUE, ALPHA,
                         invert="invert_ggx_visible_normal_sample",
                         invert_fn=microfacet.invert_ggx_visible_normal_sample),
        _microfacet_warp("beckmann_visible_normal", f"Beckmann visible normals, alpha = {ALPHA}",
                         "sample_beckmann_visible_normal", microfacet.beckmann_visible_normal_pdf,
                         microfacet.sample_beckmann_visible_normal, WO_OBLIQUE, ALPHA,
                         agree_tol=BECKMANN_TOL),
        _microfacet_warp("beckmann_visible_normal_grazing",
                         "Beckmann visible normals, grazing wo, alpha = (0.5, 0.5)",
                         "sample_beckmann_visible_normal", microfacet.beckmann_visible_normal_pdf,
                         microfacet.sample_beckmann_visible_normal, _unit((0.95, 0.2, 0.12)),
                         (0.5, 0.5), agree_tol=BECKMANN_TOL),
        _microfacet_warp("beckmann_visible_normal_normal_incidence",
                         "Beckmann visible normals, wo = +z, alpha = (0.4, 0.25)",
                         "sample_beckmann_visible_normal", microfacet.beckmann_visible_normal_pdf,
                         microfacet.sample_beckmann_visible_normal, (0.0, 0.0, 1.0), (0.4, 0.25),
                         agree_tol=BECKMANN_TOL),
        # -- phase functions of participating media ------------------------------------------
        *(_hg_warp(g) for g in HG_G),
    ]
    return warps


CATALOG: list[Warp] = build_catalog()
BY_NAME: dict[str, Warp] = {w.name: w for w in CATALOG}
