"""Solid-angle sampling of triangles (Arvo 1995): numpy twin of ``shaders/sampling/spherical_triangle.glsl``.

The triangle (v0, v1, v2) and the reference point p are fixed 3-vectors; u and w are
arrays of rows.
"""
from __future__ import annotations

import numpy as np

from ._array import as_points, as_values, clamp_unit, dot, normalize
from .spherical_geometry import spherical_triangle_area


def _unit_vertices(v0, v1, v2, p):
    p = np.asarray(p, np.float64)
    return tuple(normalize(np.asarray(v, np.float64) - p)[None, :] for v in (v0, v1, v2))


def spherical_triangle_pdf(v0, v1, v2, p) -> float:
    """1 / (solid angle of the triangle seen from p)."""
    a, b, c = _unit_vertices(v0, v1, v2, p)
    area = float(spherical_triangle_area(a, b, c)[0])
    return 1.0 / area if area > 0 else 0.0


def spherical_triangle_contains(v0, v1, v2, p, w, slack: float = 0.0) -> np.ndarray:
    """Whether the directions w (rows) from p pass through the triangle, or miss it by at
    most ``slack`` radians (float32 samples on an edge may round to just outside it)."""
    a, b, c = _unit_vertices(v0, v1, v2, p)
    w = as_points(w, 3)
    orient = np.sign(dot(a, np.cross(b, c)))
    inside = np.ones(len(w), bool)
    for x, y in ((a, b), (b, c), (c, a)):
        inside &= dot(w, normalize(np.cross(x, y))) * orient >= -slack
    return inside


def sample_spherical_triangle(v0, v1, v2, p, u) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions from p toward the triangle, uniform in solid angle; and their pdf."""
    u = as_points(u, 2)
    a, b, c = _unit_vertices(v0, v1, v2, p)
    ab, ac = b - a, c - a
    area = spherical_triangle_area(a, b, c)[0]
    e = normalize(ac - dot(ac, a)[:, None] * a)
    half_area = 0.5 * u[:, 0] * area
    y = np.sin(half_area) * (1.0 + dot(a, b))
    x = np.abs(dot(a, np.cross(ab, e))) * np.cos(half_area) - np.sin(half_area) * dot(ab, e)
    short = y * (1.0 + dot(a, c)) < x * dot(e, ac)
    with np.errstate(divide="ignore", invalid="ignore"):
        d_sub = (2.0 * y / (x * x + y * y))[:, None] * (x[:, None] * e - y[:, None] * a) - ab
    d = np.where(short[:, None], d_sub, ac - ab)
    arc = 0.5 * dot(d, d)
    omc = u[:, 1] * arc
    sin_theta = np.sqrt(np.maximum(0.0, omc * (2.0 - omc)))
    w = (1.0 - omc)[:, None] * b + sin_theta[:, None] * normalize(d + arc[:, None] * b)
    return w, np.full(len(u), 1.0 / area)


def invert_spherical_triangle_sample(v0, v1, v2, p, w) -> np.ndarray:
    w = as_points(w, 3)
    a, b, c = _unit_vertices(v0, v1, v2, p)
    area = spherical_triangle_area(a, b, c)[0]
    c_sub = normalize(np.cross(np.cross(b, w - b), np.cross(c - a, a)))
    c_sub = np.where((dot(c_sub, a + c) < 0)[:, None], -c_sub, c_sub)
    u0 = spherical_triangle_area(np.broadcast_to(a, w.shape), np.broadcast_to(b, w.shape),
                                 c_sub) / area
    u1 = dot(w - b, w - b) / dot(c_sub - b, c_sub - b)
    return clamp_unit(np.stack([as_values(u0), as_values(u1)], axis=1))
