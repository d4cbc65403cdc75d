"""GGX and Beckmann microfacet distributions: numpy twin of ``shaders/sampling/microfacet.glsl``.

Directions are rows of (N, 3) arrays in the local frame (+z = normal); ``alpha`` is
(alpha_x, alpha_y); ``wo`` may be one direction or one per row.
"""
from __future__ import annotations

import numpy as np

from ._array import as_points, dot, normalize
from .disk import invert_uniform_disk_polar_sample, sample_uniform_disk_polar
from .erf import erf_approx, erf_inv_approx


def _alpha(alpha) -> np.ndarray:
    return np.asarray(alpha, np.float64).reshape(2)


def microfacet_alpha2_tan2(w, alpha) -> np.ndarray:
    w = as_points(w, 3)
    a = _alpha(alpha) * w[:, :2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sum(a * a, axis=1) / (w[:, 2] ** 2)


# ---- GGX ----------------------------------------------------------------------------------
def ggx_d(wm, alpha) -> np.ndarray:
    wm, alpha = as_points(wm, 3), _alpha(alpha)
    s = wm[:, :2] / alpha
    e = np.sum(s * s, axis=1) + wm[:, 2] ** 2
    return np.where(wm[:, 2] > 0, 1.0 / (np.pi * alpha[0] * alpha[1] * e * e), 0.0)


def ggx_lambda(w, alpha) -> np.ndarray:
    a2t2 = microfacet_alpha2_tan2(w, alpha)
    with np.errstate(invalid="ignore"):
        return np.where(as_points(w, 3)[:, 2] == 0, np.inf, 0.5 * a2t2 / (1.0 + np.sqrt(1.0 + a2t2)))


def ggx_g1(w, alpha) -> np.ndarray:
    a2t2 = microfacet_alpha2_tan2(w, alpha)
    return np.where(as_points(w, 3)[:, 2] == 0, 0.0, 2.0 / (1.0 + np.sqrt(1.0 + a2t2)))


def ggx_g2(wo, wi, alpha) -> np.ndarray:
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))


def _visible_normal_pdf(g1, d, wo, wm) -> np.ndarray:
    wo, wm = as_points(wo, 3), as_points(wm, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf = g1 * np.maximum(0.0, dot(wo, wm)) * d / wo[:, 2]
    return np.where(wo[:, 2] > 0, pdf, 0.0)


def ggx_visible_normal_pdf(wo, wm, alpha) -> np.ndarray:
    return _visible_normal_pdf(ggx_g1(wo, alpha), ggx_d(wm, alpha), wo, wm)


def _ggx_view_frame(wo, alpha):
    wo, alpha = as_points(wo, 3), _alpha(alpha)
    wh = normalize(np.column_stack([alpha * wo[:, :2], wo[:, 2]]))
    len2 = np.sum(wh[:, :2] ** 2, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.column_stack([-wh[:, 1], wh[:, 0], np.zeros(len(wh))]) / np.sqrt(len2)[:, None]
    t1 = np.where((len2 > 0)[:, None], t1, np.array([1.0, 0.0, 0.0]))
    return wh, t1, np.cross(wh, t1)


def sample_ggx_visible_normal(wo, alpha, u) -> np.ndarray:
    """Heitz 2018."""
    u = as_points(u, 2)
    wh, t1, t2 = _ggx_view_frame(wo, alpha)
    p = sample_uniform_disk_polar(u)
    h = np.sqrt(np.maximum(0.0, 1.0 - p[:, 0] ** 2))
    s = 0.5 * (1.0 + wh[:, 2])
    py = (1.0 - s) * h + s * p[:, 1]
    pz = np.sqrt(np.maximum(0.0, 1.0 - p[:, 0] ** 2 - py ** 2))
    nh = p[:, :1] * t1 + py[:, None] * t2 + pz[:, None] * wh
    return normalize(np.column_stack([_alpha(alpha) * nh[:, :2], np.maximum(1e-6, nh[:, 2])]))


def invert_ggx_visible_normal_sample(wo, wm, alpha) -> np.ndarray:
    wm, alpha = as_points(wm, 3), _alpha(alpha)
    wh, t1, t2 = _ggx_view_frame(wo, alpha)
    nh = normalize(np.column_stack([wm[:, :2] / alpha, wm[:, 2]]))
    px, py = dot(nh, t1), dot(nh, t2)
    h = np.sqrt(np.maximum(0.0, 1.0 - px * px))
    s = 0.5 * (1.0 + wh[:, 2])
    return invert_uniform_disk_polar_sample(np.column_stack([px, (py - (1.0 - s) * h) / s]))


# ---- Beckmann -----------------------------------------------------------------------------
def beckmann_d(wm, alpha) -> np.ndarray:
    wm, alpha = as_points(wm, 3), _alpha(alpha)
    s = wm[:, :2] / alpha
    z2 = wm[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = np.exp(-np.sum(s * s, axis=1) / z2) / (np.pi * alpha[0] * alpha[1] * z2 * z2)
    return np.where(wm[:, 2] > 0, d, 0.0)


def beckmann_lambda(w, alpha) -> np.ndarray:
    a2t2 = microfacet_alpha2_tan2(w, alpha)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a = 1.0 / np.sqrt(a2t2)
        lam = 0.5 * (erf_approx(a) - 1.0) + np.exp(-a * a) / (2.0 * a * np.sqrt(np.pi))
    lam = np.where(a2t2 == 0, 0.0, lam)
    return np.where(as_points(w, 3)[:, 2] == 0, np.inf, lam)


def beckmann_g1(w, alpha) -> np.ndarray:
    return 1.0 / (1.0 + beckmann_lambda(w, alpha))


def beckmann_g2(wo, wi, alpha) -> np.ndarray:
    return 1.0 / (1.0 + beckmann_lambda(wo, alpha) + beckmann_lambda(wi, alpha))


def beckmann_visible_normal_pdf(wo, wm, alpha) -> np.ndarray:
    return _visible_normal_pdf(beckmann_g1(wo, alpha), beckmann_d(wm, alpha), wo, wm)


def beckmann_sample_slopes_11(cos_theta, u) -> np.ndarray:
    """Visible slopes of the alpha = 1 Beckmann surface seen from theta, azimuth 0."""
    u = as_points(u, 2)
    cos_theta = np.broadcast_to(np.asarray(cos_theta, np.float64), (len(u),))
    normal = cos_theta > 0.9999
    r = np.sqrt(-np.log(1.0 - u[:, 0]))
    phi = 2 * np.pi * u[:, 1]
    sin_theta = np.sqrt(np.maximum(0.0, 1.0 - cos_theta ** 2))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tan_theta = sin_theta / cos_theta
        cot_theta = 1.0 / tan_theta
        lo = np.full(len(u), -1.0)
        hi = erf_approx(cot_theta)
        ux = np.maximum(u[:, 0], 1e-6)
        theta = np.arccos(cos_theta)
        fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta))
        b = hi - (1.0 + hi) * (1.0 - ux) ** fit
        norm = 1.0 / (1.0 + hi + tan_theta * np.exp(-cot_theta ** 2) / np.sqrt(np.pi))
        active = ~normal
        for _ in range(10):
            b = np.where(active & ~((b >= lo) & (b <= hi)), 0.5 * (lo + hi), b)
            x = erf_inv_approx(b)
            value = norm * (1.0 + b + tan_theta * np.exp(-x * x) / np.sqrt(np.pi)) - ux
            derivative = norm * (1.0 - x * tan_theta)
            active = active & ~(np.abs(value) < 1e-6)
            hi = np.where(active & (value > 0), b, hi)
            lo = np.where(active & ~(value > 0), b, lo)
            b = np.where(active, b - value / derivative, b)
    slopes = np.column_stack([erf_inv_approx(b), erf_inv_approx(2.0 * np.maximum(u[:, 1], 1e-6) - 1.0)])
    return np.where(normal[:, None], r[:, None] * np.column_stack([np.cos(phi), np.sin(phi)]), slopes)


def sample_beckmann_visible_normal(wo, alpha, u) -> np.ndarray:
    """Heitz & d'Eon 2014: stretch, sample alpha = 1 slopes, rotate, unstretch."""
    u, alpha = as_points(u, 2), _alpha(alpha)
    wo = np.broadcast_to(as_points(wo, 3), (len(u), 3))
    ws = normalize(np.column_stack([alpha * wo[:, :2], wo[:, 2]]))
    slope = beckmann_sample_slopes_11(ws[:, 2], u)
    length = np.hypot(ws[:, 0], ws[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        cs = np.where((length > 0)[:, None], ws[:, :2] / length[:, None], np.array([1.0, 0.0]))
    sx = cs[:, 0] * slope[:, 0] - cs[:, 1] * slope[:, 1]
    sy = cs[:, 1] * slope[:, 0] + cs[:, 0] * slope[:, 1]
    return normalize(np.column_stack([-alpha[0] * sx, -alpha[1] * sy, np.ones(len(u))]))
