"""Solid-angle sampling of rectangles (Urena et al. 2013): numpy twin of ``shaders/sampling/spherical_rectangle.glsl``.

The rectangle (corner s, orthogonal edges ex, ey) and the reference point p are fixed
3-vectors; u is an array of rows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._array import ONE_MINUS_EPSILON, as_points, normalize


@dataclass
class SphericalRectangle:
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    x0: float
    y0: float
    z0: float
    x1: float
    y1: float
    b0: float
    b1: float
    cos_k: float
    sin_k: float
    solid_angle: float


def _triangle_solid_angle(r1, r2, r3, det: float) -> float:
    l1, l2, l3 = (float(np.linalg.norm(r)) for r in (r1, r2, r3))
    denominator = l1 * l2 * l3 + (r1 @ r2) * l3 + (r1 @ r3) * l2 + (r2 @ r3) * l1
    return 2.0 * float(np.arctan2(det, denominator))


def spherical_rectangle_setup(p, s, ex, ey) -> SphericalRectangle:
    p, s, ex, ey = (np.asarray(v, np.float64) for v in (p, s, ex, ey))
    w, h = float(np.linalg.norm(ex)), float(np.linalg.norm(ey))
    x, y = ex / w, ey / h
    z = np.cross(x, y)
    d = s - p
    x0, y0, z0 = float(d @ x), float(d @ y), float(d @ z)
    if z0 > 0:
        z, z0 = -z, -z0
    x1, y1 = x0 + w, y0 + h
    n0 = normalize(np.array([0.0, z0, -y0]))
    n1 = normalize(np.array([-z0, 0.0, x1]))
    n2 = normalize(np.array([0.0, -z0, y1]))
    n3 = normalize(np.array([z0, 0.0, -x0]))
    cos_g2, sin_g2 = -(n2 @ n3), float(np.linalg.norm(np.cross(n2, n3)))
    cos_g3, sin_g3 = -(n3 @ n0), float(np.linalg.norm(np.cross(n3, n0)))
    cos_k = cos_g2 * cos_g3 - sin_g2 * sin_g3
    sin_k = -(sin_g2 * cos_g3 + cos_g2 * sin_g3)
    v00, v01 = np.array([x0, y0, z0]), np.array([x0, y1, z0])
    v10, v11 = np.array([x1, y0, z0]), np.array([x1, y1, z0])
    det = abs(z0) * w * h
    solid_angle = _triangle_solid_angle(v00, v10, v11, det) + _triangle_solid_angle(v00, v11, v01, det)
    return SphericalRectangle(x, y, z, x0, y0, z0, x1, y1, float(n0[2]), float(n2[2]),
                              float(cos_k), float(sin_k), solid_angle)


def spherical_rectangle_pdf(p, s, ex, ey) -> float:
    """1 / (solid angle of the rectangle seen from p)."""
    solid_angle = spherical_rectangle_setup(p, s, ex, ey).solid_angle
    return 1.0 / solid_angle if solid_angle > 0 else 0.0


def sample_spherical_rectangle(p, s, ex, ey, u) -> tuple[np.ndarray, np.ndarray]:
    """Points of the rectangle whose directions from p are uniform in solid angle; their pdf."""
    u = as_points(u, 2)
    r = spherical_rectangle_setup(p, s, ex, ey)
    t = u[:, 0] * r.solid_angle
    cos_au = r.cos_k * np.cos(t) - r.sin_k * np.sin(t)
    sin_au = r.sin_k * np.cos(t) + r.cos_k * np.sin(t)
    fu = (cos_au * r.b0 - r.b1) / sin_au
    cu = np.clip(np.where(fu >= 0, 1.0, -1.0) / np.sqrt(fu * fu + r.b0 * r.b0),
                 -ONE_MINUS_EPSILON, ONE_MINUS_EPSILON)
    xu = np.clip(-(cu * r.z0) / np.sqrt(1.0 - cu * cu), r.x0, r.x1)
    dd = np.sqrt(xu * xu + r.z0 * r.z0)
    h0 = r.y0 / np.sqrt(dd * dd + r.y0 * r.y0)
    h1 = r.y1 / np.sqrt(dd * dd + r.y1 * r.y1)
    hv = h0 + u[:, 1] * (h1 - h0)
    hv2 = hv * hv
    with np.errstate(divide="ignore", invalid="ignore"):
        yv = np.clip(np.where(hv2 < 1.0 - 1e-6, hv * dd / np.sqrt(1.0 - hv2), r.y1), r.y0, r.y1)
    point = (np.asarray(p, np.float64) + xu[:, None] * r.x + yv[:, None] * r.y +
             r.z0 * r.z[None, :])
    return point, np.full(len(u), 1.0 / r.solid_angle)


def spherical_rectangle_contains(p, s, ex, ey, w, slack: float = 0.0) -> np.ndarray:
    """Whether the directions w (rows) from p pass through the rectangle, or miss it by at
    most a fraction ``slack`` of an edge (float32 samples may round to just outside it)."""
    p, s, ex, ey = (np.asarray(v, np.float64) for v in (p, s, ex, ey))
    w = as_points(w, 3)
    n = np.cross(ex, ey)
    denom = w @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((s - p) @ n) / denom
        q = p + t[:, None] * w - s
        a, b = q @ ex / (ex @ ex), q @ ey / (ey @ ey)
    return (t > 0) & (a >= -slack) & (a <= 1 + slack) & (b >= -slack) & (b <= 1 + slack)
