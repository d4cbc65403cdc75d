"""Multiple importance sampling weights: numpy twin of ``shaders/sampling/mis.glsl``."""
from __future__ import annotations

import numpy as np

MIS_MAX_TECHNIQUES = 8


def mis_weight_ratio(f, g, beta: float) -> np.ndarray:
    """1 / (1 + (g / f)^beta) with the GLSL guards (0 when f <= 0 or both infinite or NaN)."""
    f, g = np.asarray(f, np.float64), np.asarray(g, np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r = g / f
        w = 1.0 / (1.0 + (r if beta == 1 else r * r))
    bad = ~(f > 0) | (np.isinf(f) & np.isinf(g)) | np.isnan(w)
    return np.where(bad, 0.0, w)


def mis_balance(n_f, pdf_f, n_g, pdf_g) -> np.ndarray:
    """Balance heuristic n_f p_f / (n_f p_f + n_g p_g) (Veach 1997, eq. 9.13)."""
    return mis_weight_ratio(np.multiply(n_f, pdf_f), np.multiply(n_g, pdf_g), 1)


def mis_power(n_f, pdf_f, n_g, pdf_g) -> np.ndarray:
    """Power heuristic, beta = 2 (Veach 1997, eq. 9.15)."""
    return mis_weight_ratio(np.multiply(n_f, pdf_f), np.multiply(n_g, pdf_g), 2)


def mis_weight_n(n, pdf, k: int, beta: float) -> np.ndarray:
    """Weight of technique k given sample counts n and densities pdf of shape (N, count)."""
    n, pdf = np.asarray(n, np.float64), np.asarray(pdf, np.float64)
    f = n * pdf
    largest = np.max(f, axis=-1)
    infinite = np.sum(np.isinf(f), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = f / largest[..., None]
        terms = r if beta == 1 else r * r
        w = terms[..., k] / np.sum(terms, axis=-1)
    w = np.where(infinite > 0, np.where((infinite == 1) & np.isinf(f[..., k]), 1.0, 0.0), w)
    return np.where(largest > 0, w, 0.0)


def mis_balance_n(n, pdf, k: int) -> np.ndarray:
    return mis_weight_n(n, pdf, k, 1)


def mis_power_n(n, pdf, k: int) -> np.ndarray:
    return mis_weight_n(n, pdf, k, 2)
