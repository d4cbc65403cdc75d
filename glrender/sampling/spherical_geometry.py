"""Angles and areas on the unit sphere: numpy twin of ``shaders/sampling/spherical_geometry.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_points, dot


def angle_between(v1, v2) -> np.ndarray:
    """Angle in [0, pi] between unit vectors (rows): 2 atan(|v1 - v2|, |v1 + v2|)."""
    v1, v2 = as_points(v1, 3), as_points(v2, 3)
    return 2.0 * np.arctan2(np.linalg.norm(v1 - v2, axis=1), np.linalg.norm(v1 + v2, axis=1))


def gram_schmidt(v, w) -> np.ndarray:
    v, w = as_points(v, 3), as_points(w, 3)
    return v - dot(v, w)[:, None] * w


def spherical_triangle_area(a, b, c) -> np.ndarray:
    """Solid angle of the spherical triangle with unit vertices a, b, c (Van Oosterom & Strackee)."""
    a, b, c = as_points(a, 3), as_points(b, 3), as_points(c, 3)
    return np.abs(2.0 * np.arctan2(dot(a, np.cross(b, c)), 1.0 + dot(a, b) + dot(a, c) + dot(b, c)))
