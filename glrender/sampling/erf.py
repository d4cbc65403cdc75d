"""erf and erf^{-1} by the fits of ``shaders/sampling/erf.glsl`` (numpy twin)."""
from __future__ import annotations

import numpy as np

from ._array import as_values

_ERF = (0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429)
_ERF_INV_CENTRAL = (2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06,
                    0.00021858087, -0.00125372503, -0.00417768164, 0.246640727, 1.50140941)
_ERF_INV_TAIL = (-0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844,
                 0.00573950773, -0.0076224613, 0.00943887047, 1.00167406, 2.83297682)


def _horner(coefficients, w):
    p = np.zeros_like(w)
    for c in coefficients:
        p = c + p * w
    return p


def erf_approx(x) -> np.ndarray:
    """Abramowitz & Stegun 7.1.26 (absolute error <= 1.5e-7)."""
    x = as_values(x)
    ax = np.abs(x)
    t = 1.0 / (1.0 + 0.3275911 * ax)
    poly = t * _horner(_ERF[::-1], t)
    return np.copysign(1.0 - poly * np.exp(-ax * ax), x)


def erf_inv_approx(x) -> np.ndarray:
    """Giles 2011, single-precision fit."""
    x = as_values(x)
    w = -np.log(np.maximum((1.0 - x) * (1.0 + x), 5.9604645e-8))
    central = _horner(_ERF_INV_CENTRAL, w - 2.5)
    tail = _horner(_ERF_INV_TAIL, np.sqrt(w) - 3.0)
    return np.where(w < 5.0, central, tail) * x
