"""Orthonormal frames: numpy twin of ``shaders/common/frame.glsl`` (Duff et al. 2017)."""
from __future__ import annotations

import numpy as np

from ._array import as_points, dot


def branchless_onb(n) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors b1, b2 with (b1, b2, n) a right-handed orthonormal basis, per row of n."""
    n = as_points(n, 3)
    s = np.where(n[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    b1 = np.stack([1.0 + s * n[:, 0] ** 2 * a, s * b, -s * n[:, 0]], axis=1)
    b2 = np.stack([b, s + n[:, 1] ** 2 * a, -n[:, 1]], axis=1)
    return b1, b2


def frame_from_z(n) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frame (x, y, z) whose z axis is the unit vector n (rows)."""
    n = as_points(n, 3)
    x, y = branchless_onb(n)
    return x, y, n


def frame_from_xy(x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frame with the given orthonormal x and y axes; z = x cross y."""
    x, y = as_points(x, 3), as_points(y, 3)
    return x, y, np.cross(x, y)


def frame_to_local(frame, v) -> np.ndarray:
    """Coordinates of v in the frame: local_from_world v."""
    x, y, z = frame
    v = as_points(v, 3)
    return np.stack([dot(v, x), dot(v, y), dot(v, z)], axis=1)


def frame_from_local(frame, v) -> np.ndarray:
    """The vector whose local coordinates are v: world_from_local v."""
    x, y, z = frame
    v = as_points(v, 3)
    return v[:, :1] * x + v[:, 1:2] * y + v[:, 2:3] * z
