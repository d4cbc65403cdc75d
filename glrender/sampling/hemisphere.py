"""Uniform and cosine-weighted hemisphere directions: numpy twin of ``shaders/sampling/hemisphere.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import ONE_MINUS_EPSILON, as_points, as_values, clamp_unit
from .disk import invert_uniform_disk_concentric_sample, sample_uniform_disk_concentric
from .sphere import azimuth_fraction, spherical_direction


def uniform_hemisphere_pdf() -> float:
    return 1.0 / (2 * np.pi)


def sample_uniform_hemisphere(u) -> np.ndarray:
    u = as_points(u, 2)
    return spherical_direction(np.sqrt(np.maximum(0.0, 1.0 - u[:, 0] ** 2)), u[:, 0], u[:, 1])


def invert_uniform_hemisphere_sample(w) -> np.ndarray:
    w = as_points(w, 3)
    return np.stack([clamp_unit(w[:, 2]), azimuth_fraction(w)], axis=1)


def sample_cosine_hemisphere(u) -> np.ndarray:
    """Malley's method through the concentric disk."""
    d = sample_uniform_disk_concentric(u)
    r = np.minimum(np.max(np.abs(2.0 * as_points(u, 2) - 1.0), axis=1), ONE_MINUS_EPSILON)
    return np.column_stack([d, np.sqrt(np.maximum(0.0, (1.0 - r) * (1.0 + r)))])


def cosine_hemisphere_pdf(cos_theta) -> np.ndarray:
    return np.maximum(as_values(cos_theta), 0.0) / np.pi


def invert_cosine_hemisphere_sample(w) -> np.ndarray:
    return invert_uniform_disk_concentric_sample(as_points(w, 3)[:, :2])
