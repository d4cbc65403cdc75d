"""Uniform directions in a cone about +z: numpy twin of ``shaders/sampling/cone.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_points, clamp_unit
from .sphere import azimuth_fraction, sin_theta_from_one_minus_cos, spherical_direction


def uniform_cone_pdf(cos_theta_max) -> np.ndarray:
    return 1.0 / (2 * np.pi * (1.0 - np.asarray(cos_theta_max, np.float64)))


def sample_uniform_cone(u, cos_theta_max) -> np.ndarray:
    u = as_points(u, 2)
    omc = u[:, 0] * (1.0 - cos_theta_max)
    return spherical_direction(sin_theta_from_one_minus_cos(omc), 1.0 - omc, u[:, 1])


def invert_uniform_cone_sample(w, cos_theta_max) -> np.ndarray:
    w = as_points(w, 3)
    return np.stack([clamp_unit((1.0 - w[:, 2]) / (1.0 - cos_theta_max)), azimuth_fraction(w)], 1)
