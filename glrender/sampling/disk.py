"""The unit disk by polar maps and the concentric map: numpy twin of ``shaders/sampling/disk.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import ONE_MINUS_EPSILON, as_points, clamp_unit


def sample_disk_linear_radius(u) -> np.ndarray:
    """Polar map r = u0, theta = 2 pi u1 (not uniform: density 1 / (2 pi r))."""
    u = as_points(u, 2)
    phi = 2 * np.pi * u[:, 1]
    return u[:, :1] * np.stack([np.cos(phi), np.sin(phi)], axis=1)


def disk_linear_radius_pdf(p) -> np.ndarray:
    """Density of sample_disk_linear_radius per unit area: 1 / (2 pi r) inside the disk."""
    p = as_points(p, 2)
    r = np.hypot(p[:, 0], p[:, 1])
    with np.errstate(divide="ignore"):
        return np.where(r <= 1.0, 1.0 / (2 * np.pi * r), 0.0)


def disk_angle_fraction(p) -> np.ndarray:
    """Polar angle of p as a fraction of a turn in [0, 1)."""
    p = as_points(p, 2)
    t = np.arctan2(p[:, 1], p[:, 0]) / (2 * np.pi)
    return np.where(t < 0, np.minimum(t + 1.0, ONE_MINUS_EPSILON), t)


def invert_disk_linear_radius_sample(p) -> np.ndarray:
    p = as_points(p, 2)
    return np.stack([np.hypot(p[:, 0], p[:, 1]), disk_angle_fraction(p)], axis=1)


def uniform_disk_pdf() -> float:
    """Uniform density on the unit disk per unit area: 1 / pi."""
    return 1.0 / np.pi


def sample_uniform_disk_polar(u) -> np.ndarray:
    """Equi-areal polar map r = sqrt(u0), theta = 2 pi u1."""
    u = as_points(u, 2)
    phi = 2 * np.pi * u[:, 1]
    return np.sqrt(u[:, :1]) * np.stack([np.cos(phi), np.sin(phi)], axis=1)


def invert_uniform_disk_polar_sample(p) -> np.ndarray:
    p = as_points(p, 2)
    return np.stack([np.sum(p * p, axis=1), disk_angle_fraction(p)], axis=1)


def sample_uniform_disk_concentric(u) -> np.ndarray:
    """Shirley-Chiu concentric map of [0,1)^2 onto the unit disk."""
    o = 2.0 * as_points(u, 2) - 1.0
    ox, oy = o[:, 0], o[:, 1]
    wedge_x = np.abs(ox) > np.abs(oy)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(wedge_x, ox, oy)
        theta = np.where(wedge_x, np.pi / 4 * (oy / ox), np.pi / 2 - np.pi / 4 * (ox / oy))
    p = r[:, None] * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    return np.where(((ox == 0) & (oy == 0))[:, None], 0.0, p)


def invert_uniform_disk_concentric_sample(p) -> np.ndarray:
    p = as_points(p, 2)
    x, y = p[:, 0], p[:, 1]
    r = np.hypot(x, y)
    wedge_x = np.abs(x) > np.abs(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        ox_a = np.where(x < 0, -r, r)
        oy_a = ox_a * np.arctan(y / x) / (np.pi / 4)
        oy_b = np.where(y < 0, -r, r)
        ox_b = oy_b * np.arctan(x / y) / (np.pi / 4)
    o = np.where(wedge_x[:, None], np.stack([ox_a, oy_a], 1), np.stack([ox_b, oy_b], 1))
    o = np.where((~wedge_x & (y == 0))[:, None], 0.0, o)
    return clamp_unit(0.5 * (o + 1.0))
