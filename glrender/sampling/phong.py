"""The normalised Phong lobe cos^n: numpy twin of ``shaders/sampling/phong.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_points, as_values, clamp_unit
from .power import invert_power_sample, power_pdf, sample_power
from .sphere import azimuth_fraction, spherical_direction


def phong_lobe_pdf(cos_theta, n) -> np.ndarray:
    """(n + 1) / (2 pi) cos^n theta per unit solid angle; 0 below the horizon."""
    c = as_values(cos_theta)
    return np.where(c > 0, power_pdf(np.maximum(c, 0.0), n) / (2 * np.pi), 0.0)


def sample_phong_lobe(u, n) -> np.ndarray:
    u = as_points(u, 2)
    cos_theta = sample_power(u[:, 0], n)
    sin_theta = np.sqrt(np.maximum(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)))
    return spherical_direction(sin_theta, cos_theta, u[:, 1])


def invert_phong_lobe_sample(w, n) -> np.ndarray:
    w = as_points(w, 3)
    return np.stack([clamp_unit(invert_power_sample(np.maximum(w[:, 2], 0.0), n)),
                     azimuth_fraction(w)], axis=1)
