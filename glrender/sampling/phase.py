"""Isotropic and Henyey-Greenstein phase functions: numpy twin of ``shaders/sampling/phase.glsl``.

Local frame: +z is the direction d of travel before scattering; cos_theta = dot(d, wi).
"""
from __future__ import annotations

import numpy as np

from ._array import as_points, as_values, clamp_unit
from .frame import frame_from_local, frame_from_z
from .sphere import azimuth_fraction, spherical_direction, uniform_sphere_pdf


def isotropic_phase() -> float:
    """1 / (4 pi) per unit solid angle."""
    return uniform_sphere_pdf()


def hg_distance_squared(cos_theta, g) -> np.ndarray:
    """1 + g^2 - 2 g cos_theta as a sum of non-negative terms."""
    c = np.clip(as_values(cos_theta), -1.0, 1.0)
    if g >= 0:
        return (1.0 - g) ** 2 + 2.0 * g * (1.0 - c)
    return (1.0 + g) ** 2 - 2.0 * g * (1.0 + c)


def hg_phase(cos_theta, g) -> np.ndarray:
    """(1 - g^2) / (4 pi (1 + g^2 - 2 g cos_theta)^(3/2)) per unit solid angle, |g| < 1."""
    q2 = hg_distance_squared(cos_theta, g)
    return (1.0 - g) * (1.0 + g) / (4 * np.pi * q2 * np.sqrt(q2))


def sample_hg(u, g) -> np.ndarray:
    u = as_points(u, 2)
    x = u[:, 0]
    t = (1.0 - g) + 2.0 * g * x if g >= 0 else (1.0 + g) - 2.0 * g * (1.0 - x)
    q = (1.0 - g) * (1.0 + g) / t
    one_minus_cos = (1.0 - g) * (1.0 - x) * (q + 1.0 - g) / t
    one_plus_cos = (1.0 + g) * x * (q + 1.0 + g) / t
    cos_theta = np.where(one_minus_cos < 1.0, 1.0 - one_minus_cos, one_plus_cos - 1.0)
    sin_theta = np.sqrt(np.maximum(0.0, one_minus_cos * one_plus_cos))
    return spherical_direction(sin_theta, cos_theta, u[:, 1])


def invert_hg_sample(w, g) -> np.ndarray:
    w = as_points(w, 3)
    q = np.sqrt(hg_distance_squared(w[:, 2], g))
    cdf = (1.0 - g) * (1.0 + np.clip(w[:, 2], -1.0, 1.0)) / (q * (1.0 + g + q))
    return np.stack([clamp_unit(cdf), azimuth_fraction(w)], axis=1)


def sample_hg_world(u, g, d) -> np.ndarray:
    """sample_hg carried out of the frame frame_from_z(d); d: one unit vector or one per row."""
    wi = sample_hg(u, g)
    d = np.broadcast_to(as_points(d, 3), wi.shape)
    return frame_from_local(frame_from_z(d), wi)
