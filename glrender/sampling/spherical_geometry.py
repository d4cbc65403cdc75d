"""The solid angle of a spherical triangle: numpy twin of ``shaders/sampling/spherical_geometry.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_points, dot


def spherical_triangle_area(a, b, c) -> np.ndarray:
    """Solid angle of the spherical triangle with unit vertices a, b, c (Van Oosterom & Strackee)."""
    a, b, c = as_points(a, 3), as_points(b, 3), as_points(c, 3)
    det = dot(a, np.cross(b - a, c - a))
    return np.abs(2.0 * np.arctan2(det, 1.0 + dot(a, b) + dot(a, c) + dot(b, c)))
