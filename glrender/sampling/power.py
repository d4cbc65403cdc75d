"""The power density (n + 1) x^n on [0, 1]: numpy twin of ``shaders/sampling/power.glsl``."""
from __future__ import annotations

import numpy as np

from ._array import as_values


POWER_SMALLEST_UNIFORM = 2.0 ** -25  # u = 0 is read as this: x is never 0


def sample_power(u, n) -> np.ndarray:
    """x = u^(1 / (n + 1)) (inversion of P(x) = x^(n + 1))."""
    u = np.maximum(as_values(u), POWER_SMALLEST_UNIFORM)
    return u ** (1.0 / (np.asarray(n, np.float64) + 1.0))


def power_pdf(x, n) -> np.ndarray:
    """(n + 1) x^n per unit length on [0, 1]; 0 outside."""
    x = as_values(x)
    n = np.asarray(n, np.float64)
    inside = (x >= 0) & (x <= 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_n = np.where(x > 0, np.abs(x) ** n, np.where(n == 0, 1.0, 0.0))
    return np.where(inside, (n + 1.0) * x_n, 0.0)


def invert_power_sample(x, n) -> np.ndarray:
    return as_values(x) ** (np.asarray(n, np.float64) + 1.0)


def sample_power_max(u, n: int) -> np.ndarray:
    """The largest of the first n + 1 columns of u (N, 4), n in [0, 3]."""
    u = np.asarray(u, np.float64).reshape(len(u), -1)
    return np.maximum(u[:, :n + 1].max(axis=1), POWER_SMALLEST_UNIFORM)
