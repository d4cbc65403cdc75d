"""Tables of the rough plastic coating, computed on the host exactly as Mitsuba 3 does.

Mitsuba 3's ``roughplastic`` (``src/bsdfs/roughplastic.cpp``, ``eval_transmittance``
and ``eval_reflectance`` in ``include/mitsuba/render/microfacet.h``) precomputes:

- ``T(cos theta)``, the fraction of light arriving from outside at cos theta that the
  rough interface transmits (Fresnel and Smith shadowing included), at 64 cosines
  ``max(1e-6, i / 63)``; its shaders interpolate the table linearly;
- ``R_int``, the interface's hemispherical reflectance for diffuse light from
  inside: ``2 mean(R(mu) mu)`` over the same 64 cosines, with R computed for 1 / eta.

Each directional integral maps a Gauss-Legendre grid (32 x 32 nodes on [0, 1]^2, or
128 x 128 when the relevant relative IOR is below 1) through Mitsuba's visible-normal
sampler: ``sum_j w_j G1(w_out, m_j) F(w, m_j)``. The quadrature is coarse where the
sampler bends (T differs from a 400 x 400-node integral by up to 2e-3), so this
module reproduces Mitsuba's sampler itself, step by step (the concentric-disk GGX
variant, the Beckmann inversion with exactly three Newton steps), rather than
glrender's own warps: the BSDF then matches Mitsuba's to float32 precision.
Everything here runs in float64 numpy.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..sampling.erf import erf_approx, erf_inv_approx

TABLE_SIZE = 64


def _erf(x):
    x = np.asarray(x, np.float64)
    return erf_approx(x.ravel()).reshape(x.shape)


def _erf_inv(x):
    x = np.asarray(x, np.float64)
    return erf_inv_approx(x.ravel()).reshape(x.shape)


def _fresnel(cos_theta, eta):
    """Mitsuba's ``fresnel``: (F, cos_theta_t, eta_ti) for a dielectric interface."""
    outside = cos_theta >= 0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = 1.0 / eta_it
    cos_t2 = 1.0 - (1.0 - cos_theta ** 2) * eta_ti ** 2
    ci, ct = np.abs(cos_theta), np.sqrt(np.maximum(cos_t2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    F = 0.5 * (a_s ** 2 + a_p ** 2)
    F = np.where(eta == 1.0, 0.0, np.where(ci == 0.0, 1.0, F))
    return F, np.where(outside, -ct, ct), eta_ti


def _smith_g1(v, m, alpha, ggx):
    """Mitsuba's shading G1 (rational fit for Beckmann), isotropic alpha."""
    xy_alpha2 = alpha ** 2 * (v[..., 0] ** 2 + v[..., 1] ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        tan2 = xy_alpha2 / v[..., 2] ** 2
        if ggx:
            g = 2.0 / (1.0 + np.sqrt(1.0 + tan2))
        else:
            a = 1.0 / np.sqrt(tan2)
            g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
    g = np.where(xy_alpha2 == 0.0, 1.0, g)
    return np.where(np.sum(v * m, axis=-1) * v[..., 2] <= 0.0, 0.0, g)


def _concentric_disk(u):
    """Mitsuba's ``square_to_uniform_disk_concentric``."""
    x, y = 2.0 * u[..., 0] - 1.0, 2.0 * u[..., 1] - 1.0
    q13 = np.abs(x) < np.abs(y)
    r, rp = np.where(q13, y, x), np.where(q13, x, y)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 0.25 * np.pi * rp / r
    phi = np.where(q13, 0.5 * np.pi - phi, phi)
    phi = np.where((x == 0) & (y == 0), 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


def _visible_slopes_11(cos_theta, u, ggx):
    """Mitsuba's ``sample_visible_11``: slopes of the alpha = 1 surface seen from
    theta at azimuth 0. cos_theta has shape (N, 1), u shape (K, 2): result (N, K)."""
    if ggx:
        px, py = _concentric_disk(u)
        s = 0.5 * (1.0 + cos_theta)
        h = np.sqrt(np.maximum(1.0 - px ** 2, 0.0))
        py = h + (py - h) * s
        pz = np.sqrt(np.maximum(1.0 - px ** 2 - py ** 2, 0.0))
        sin_theta = np.sqrt(np.maximum(1.0 - cos_theta ** 2, 0.0))
        norm = 1.0 / (sin_theta * py + cos_theta * pz)
        return (cos_theta * py - sin_theta * pz) * norm, px * norm
    tan_theta = np.sqrt(np.maximum(1.0 - cos_theta ** 2, 0.0)) / cos_theta
    with np.errstate(divide="ignore"):
        cot_theta = 1.0 / tan_theta
    maxval = _erf(cot_theta)
    u = np.clip(u, 1e-6, 1.0 - 1e-6)
    ux, uy = u[..., 0], u[..., 1]
    x = maxval - (maxval + 1.0) * _erf(np.sqrt(-np.log(ux)))
    inv_sqrt_pi = 1.0 / np.sqrt(np.pi)
    with np.errstate(invalid="ignore"):
        tail = np.where(tan_theta == 0.0, 0.0, tan_theta * np.exp(-cot_theta ** 2))
    target = ux * (1.0 + maxval + inv_sqrt_pi * tail)
    for _ in range(3):  # exactly Mitsuba's three Newton steps
        slope = _erf_inv(x)
        value = 1.0 + x + inv_sqrt_pi * tan_theta * np.exp(-slope ** 2) - target
        x = x - value / (1.0 - slope * tan_theta)
    return _erf_inv(x), np.broadcast_to(_erf_inv(2.0 * uy - 1.0), x.shape)


def _sample_visible_normal(wi, alpha, u, ggx):
    """Mitsuba's visible-normal sampler for directions wi (N, 3) at nodes u (K, 2):
    microfacet normals of shape (N, K, 3)."""
    ws = wi * np.array([alpha, alpha, 1.0])
    ws = ws / np.linalg.norm(ws, axis=1, keepdims=True)
    sin2 = 1.0 - ws[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        cs = np.clip(ws[:, :2] / np.sqrt(sin2)[:, None], -1.0, 1.0)
    cs = np.where((np.abs(sin2) <= 4.0 * 2.0 ** -24)[:, None], [1.0, 0.0], cs)
    cos_phi, sin_phi = cs[:, :1], cs[:, 1:]
    sx, sy = _visible_slopes_11(ws[:, 2:], u, ggx)
    mx = (cos_phi * sx - sin_phi * sy) * alpha
    my = (sin_phi * sx + cos_phi * sy) * alpha
    m = np.stack([-mx, -my, np.ones_like(mx)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _quadrature(eta):
    res = 32 if eta > 1 else 128
    nodes, weights = np.polynomial.legendre.leggauss(res)
    ny, nx = np.meshgrid(nodes, nodes, indexing="ij")
    wy, wx = np.meshgrid(weights, weights, indexing="ij")
    u = np.stack([nx.ravel(), ny.ravel()], axis=1) * 0.5 + 0.5
    return u, (wx * wy).ravel() * 0.25


def _cosines():
    mu = np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE, dtype=np.float32).astype(np.float64))
    return np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=1)


def external_transmittance(alpha: float, eta: float, ggx: bool) -> np.ndarray:
    """T at the 64 cosines of the table (float32), Mitsuba's ``eval_transmittance``."""
    return _external_transmittance(float(alpha), float(eta), bool(ggx)).copy()


@lru_cache(maxsize=64)
def _external_transmittance(alpha: float, eta: float, ggx: bool) -> np.ndarray:
    wi = _cosines()
    u, w = _quadrature(eta)
    m = _sample_visible_normal(wi, alpha, u, ggx)
    wi_b = wi[:, None, :]
    cos_m = np.sum(wi_b * m, axis=-1)
    F, cos_t, eta_ti = _fresnel(cos_m, eta)
    wo = m * (cos_m * eta_ti + cos_t)[..., None] - wi_b * eta_ti[..., None]
    smith = _smith_g1(wo, m, alpha, ggx) * (1.0 - F)
    smith = np.where(wo[..., 2] * wi_b[..., 2] >= 0.0, 0.0, smith)
    return (smith @ w).astype(np.float32)


@lru_cache(maxsize=64)
def internal_reflectance(alpha: float, eta: float, ggx: bool) -> float:
    """R_int: 2 mean(R(mu) mu) with R Mitsuba's ``eval_reflectance`` for 1 / eta."""
    wi = _cosines()
    eta_in = 1.0 / eta
    u, w = _quadrature(eta_in)
    m = _sample_visible_normal(wi, alpha, u, ggx)
    wi_b = wi[:, None, :]
    cos_m = np.sum(wi_b * m, axis=-1)
    wo = 2.0 * cos_m[..., None] * m - wi_b
    F, _, _ = _fresnel(cos_m, eta_in)
    smith = _smith_g1(wo, m, alpha, ggx) * F
    smith = np.where((wo[..., 2] <= 0.0) | (wi_b[..., 2] <= 0.0), 0.0, smith)
    return float(2.0 * np.mean((smith @ w) * wi[:, 2]))


# ---- the coating of the metallic-roughness rule, per texel ------------------------------------
#
# A metallic-roughness material (glTF's, scene/loaders/pbr.py) chooses roughplastic per
# surface point with alpha = roughness^2 >= ALPHA_TABLE_MIN, GGX and IOR 1.5 (PBR_IOR): the
# table over alpha holds T(cos theta) and R_int for that coating at ALPHA_TABLE_ROWS values of
# sqrt(alpha) evenly spaced in [sqrt(ALPHA_TABLE_MIN), 1]; bsdf/roughplastic.glsl interpolates
# bilinearly in (sqrt(alpha), cos theta). Against the exact values between its rows the
# interpolation errs by at most 7e-4 in T for cos theta > 0.1 (3e-3 at grazing angles) and
# 8e-4 in R_int. R_int's quadrature (128 x 128 nodes, IOR below 1) takes half a second a row,
# so the table ships with the package (data/roughplastic_alpha_table.npy, written by
# ``python -m glrender.gpu.microfacet_tables``; tests/bsdf/test_metallic_roughness.py checks
# rows of it against this module).

PBR_IOR = 1.5
ALPHA_TABLE_MIN = 1e-3
ALPHA_TABLE_ROWS = 32
ALPHA_TABLE_COLUMNS = TABLE_SIZE + 1      # T at the 64 cosines, then R_int
_ALPHA_TABLE_FILE = "data/roughplastic_alpha_table.npy"


def alpha_table_roughness() -> np.ndarray:
    """sqrt(alpha) of each row of the table over alpha."""
    return np.linspace(np.sqrt(ALPHA_TABLE_MIN), 1.0, ALPHA_TABLE_ROWS)


def alpha_table_row(sqrt_alpha: float) -> np.ndarray:
    """One row of the table: T at the 64 cosines and R_int, for alpha = sqrt_alpha^2
    (GGX, IOR PBR_IOR), float32."""
    alpha = float(sqrt_alpha) ** 2
    return np.append(_external_transmittance(alpha, PBR_IOR, True),
                     np.float32(internal_reflectance(alpha, PBR_IOR, True))).astype(np.float32)


def compute_alpha_table() -> np.ndarray:
    """The whole table (ALPHA_TABLE_ROWS x ALPHA_TABLE_COLUMNS float32), from scratch."""
    return np.stack([alpha_table_row(s) for s in alpha_table_roughness()])


@lru_cache(maxsize=1)
def alpha_table() -> np.ndarray:
    """The table as shipped with the package (read-only)."""
    from importlib import resources

    with resources.files(__package__).joinpath(_ALPHA_TABLE_FILE).open("rb") as f:
        table = np.load(f, allow_pickle=False)
    if table.shape != (ALPHA_TABLE_ROWS, ALPHA_TABLE_COLUMNS) or table.dtype != np.float32:
        raise RuntimeError(f"glrender/gpu/{_ALPHA_TABLE_FILE}: a table of shape "
                           f"{(ALPHA_TABLE_ROWS, ALPHA_TABLE_COLUMNS)} float32 was expected, "
                           f"got {table.shape} {table.dtype}: write it again")
    table.setflags(write=False)
    return table


if __name__ == "__main__":
    from pathlib import Path

    out = Path(__file__).with_name("data") / "roughplastic_alpha_table.npy"
    out.parent.mkdir(exist_ok=True)
    np.save(out, compute_alpha_table())
    print(f"wrote {out}")
