"""Small statistics used by glrender's tests and lab, without SciPy.

- :func:`chi2_sf`: survival function of the chi-square distribution (the p-value
  of a goodness-of-fit statistic), through the regularized incomplete gamma
  function (series below ``a + 1``, Lentz continued fraction above).
- :func:`sidak_alpha` / :func:`sidak_z`: Šidák correction for ``m`` simultaneous
  tests, so that a correct renderer fails a whole test with probability ``alpha``.
"""
from __future__ import annotations

import math
from statistics import NormalDist

_EPS = 1e-15
_TINY = 1e-300
_MAX_ITER = 1_000_000


def _gamma_p_series(a: float, x: float) -> float:
    """Regularized lower incomplete gamma P(a, x) by its power series (x < a + 1)."""
    term = total = 1.0 / a
    ap = a
    for _ in range(_MAX_ITER):
        ap += 1.0
        term *= x / ap
        total += term
        if abs(term) < abs(total) * _EPS:
            break
    return total * math.exp(-x + a * math.log(x) - math.lgamma(a))


def _gamma_q_fraction(a: float, x: float) -> float:
    """Regularized upper incomplete gamma Q(a, x) by Lentz's continued fraction."""
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, _MAX_ITER):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return math.exp(-x + a * math.log(x) - math.lgamma(a)) * h


def gamma_q(a: float, x: float) -> float:
    """Regularized upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a)."""
    if a <= 0:
        raise ValueError(f"gamma_q: a must be positive, got {a}")
    if x <= 0:
        return 1.0
    if x < a + 1.0:
        return max(0.0, 1.0 - _gamma_p_series(a, x))
    return _gamma_q_fraction(a, x)


def chi2_sf(stat: float, dof: int) -> float:
    """P(X >= stat) for X ~ chi-square with ``dof`` degrees of freedom."""
    if dof <= 0:
        raise ValueError(f"chi2_sf: dof must be positive, got {dof}")
    if not math.isfinite(stat):
        return 0.0
    return gamma_q(0.5 * dof, 0.5 * stat)


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test significance so that ``tests`` independent tests fail together w.p. ``alpha``."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(tests), 1))


def sidak_z(alpha: float, tests: int) -> float:
    """Two-sided normal threshold z for ``tests`` comparisons at family-wise ``alpha``."""
    return NormalDist().inv_cdf(1.0 - sidak_alpha(alpha, tests) / 2.0)


def normal_quantile(p: float) -> float:
    return NormalDist().inv_cdf(p)
