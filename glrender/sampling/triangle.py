"""Uniform triangle points as barycentrics: numpy twin of ``shaders/sampling/triangle.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_points


def uniform_triangle_pdf(area) -> np.ndarray:
    area = np.asarray(area, np.float64)
    with np.errstate(divide="ignore"):
        return np.where(area > 0, 1.0 / area, 0.0)


def triangle_area(p0, p1, p2) -> np.ndarray:
    p0, p1, p2 = (as_points(p, 3) for p in (p0, p1, p2))
    return 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)


def sample_uniform_triangle_sqrt(u) -> np.ndarray:
    """Lecture 13's map: b0 = 1 - sqrt(u0), b1 = sqrt(u0) u1."""
    u = as_points(u, 2)
    su = np.sqrt(u[:, 0])
    b0, b1 = 1.0 - su, su * u[:, 1]
    return np.stack([b0, b1, 1.0 - b0 - b1], axis=1)


def invert_uniform_triangle_sqrt_sample(b) -> np.ndarray:
    b = as_points(b, 3)
    su = 1.0 - b[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack([su * su, np.where(su > 0, b[:, 1] / su, 0.0)], axis=1)


def sample_uniform_triangle(u) -> np.ndarray:
    """Heitz 2019 low-distortion map."""
    u = as_points(u, 2)
    first = u[:, 0] < u[:, 1]
    b0 = np.where(first, 0.5 * u[:, 0], u[:, 0] - 0.5 * u[:, 1])
    b1 = np.where(first, u[:, 1] - 0.5 * u[:, 0], 0.5 * u[:, 1])
    return np.stack([b0, b1, 1.0 - b0 - b1], axis=1)


def invert_uniform_triangle_sample(b) -> np.ndarray:
    b = as_points(b, 3)
    upper = b[:, 0] > b[:, 1]
    return np.where(upper[:, None], np.stack([b[:, 0] + b[:, 1], 2 * b[:, 1]], 1),
                    np.stack([2 * b[:, 0], b[:, 1] + b[:, 0]], 1))
