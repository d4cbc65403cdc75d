"""Array helpers shared by the numpy twins of the GLSL sampling routines."""
from __future__ import annotations

import numpy as np

# The largest float32 below 1 (kOneMinusEpsilon in shaders/common/constants.glsl).
ONE_MINUS_EPSILON = float(np.nextafter(np.float32(1), np.float32(0)))


def as_points(x, dim: int) -> np.ndarray:
    """``x`` as a float64 array of shape (N, dim) (a single point becomes N = 1)."""
    a = np.asarray(x, np.float64)
    return a.reshape(-1, dim)


def as_values(x) -> np.ndarray:
    """``x`` as a 1D float64 array."""
    return np.asarray(x, np.float64).reshape(-1)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of two (N, k) arrays (or an (N, k) array and a (k,) vector)."""
    return np.sum(a * b, axis=-1)


def normalize(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def clamp_unit(u: np.ndarray) -> np.ndarray:
    """Clamp to [0, 1) as the GLSL inverses do (kOneMinusEpsilon)."""
    return np.clip(u, 0.0, ONE_MINUS_EPSILON)
