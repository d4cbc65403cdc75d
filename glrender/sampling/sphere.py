"""Uniform directions on the sphere: numpy twin of ``shaders/sampling/sphere.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import ONE_MINUS_EPSILON, as_points, as_values, clamp_unit


def uniform_sphere_pdf() -> float:
    return 1.0 / (4 * np.pi)


def azimuth_fraction(w) -> np.ndarray:
    """phi / 2 pi in [0, 1) of the azimuth of w around +z."""
    w = as_points(w, 3)
    t = np.arctan2(w[:, 1], w[:, 0]) / (2 * np.pi)
    return np.where(t < 0, np.minimum(t + 1.0, ONE_MINUS_EPSILON), t)


def spherical_direction(sin_theta, cos_theta, t) -> np.ndarray:
    """The unit direction with the given sin/cos of theta and azimuth 2 pi t."""
    phi = 2 * np.pi * as_values(t)
    sin_theta = as_values(sin_theta)
    return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), as_values(cos_theta)], 1)


def sin_theta_from_one_minus_cos(one_minus_cos) -> np.ndarray:
    omc = as_values(one_minus_cos)
    return np.sqrt(np.maximum(0.0, omc * (2.0 - omc)))


def sample_uniform_sphere(u) -> np.ndarray:
    u = as_points(u, 2)
    omc = 2.0 * u[:, 0]
    return spherical_direction(sin_theta_from_one_minus_cos(omc), 1.0 - omc, u[:, 1])


def invert_uniform_sphere_sample(w) -> np.ndarray:
    w = as_points(w, 3)
    return np.stack([clamp_unit(0.5 * (1.0 - w[:, 2])), azimuth_fraction(w)], axis=1)
