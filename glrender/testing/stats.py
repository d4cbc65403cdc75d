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


def _beta_fraction(a: float, b: float, x: float) -> float:
    """Continued fraction of the regularized incomplete beta function (modified Lentz)."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (_TINY if abs(d) < _TINY else d)
    h = d
    for m in range(1, 10_000):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (_TINY if abs(d) < _TINY else d)
        c = 1.0 + aa / c
        c = _TINY if abs(c) < _TINY else c
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (_TINY if abs(d) < _TINY else d)
        c = 1.0 + aa / c
        c = _TINY if abs(c) < _TINY else c
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return h


def beta_inc(a: float, b: float, x: float) -> float:
    """Regularized incomplete beta function I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    front = math.exp(math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) +
                     a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _beta_fraction(a, b, x) / a
    return 1.0 - front * _beta_fraction(b, a, 1.0 - x) / b


def student_t_sf(t: float, dof: float) -> float:
    """P(T >= t) for Student's t with ``dof`` degrees of freedom."""
    if dof <= 0:
        raise ValueError(f"student_t_sf: dof must be positive, got {dof}")
    tail = 0.5 * beta_inc(0.5 * dof, 0.5, dof / (dof + t * t))
    return tail if t >= 0 else 1.0 - tail


def student_t_quantile(p: float, dof: float) -> float:
    """The t with P(T <= t) = p (bisection on the survival function)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"student_t_quantile: p must be in (0, 1), got {p}")
    if p < 0.5:
        return -student_t_quantile(1.0 - p, dof)
    lo, hi = 0.0, 1.0
    while student_t_sf(hi, dof) > 1.0 - p:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if student_t_sf(mid, dof) > 1.0 - p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def sidak_t(alpha: float, tests: int, dof: float) -> float:
    """Two-sided Student-t threshold for ``tests`` comparisons at family-wise ``alpha``."""
    return student_t_quantile(1.0 - sidak_alpha(alpha, tests) / 2.0, dof)


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test significance so that ``tests`` independent tests fail together w.p. ``alpha``."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(tests), 1))


def sidak_z(alpha: float, tests: int) -> float:
    """Two-sided normal threshold z for ``tests`` comparisons at family-wise ``alpha``."""
    return NormalDist().inv_cdf(1.0 - sidak_alpha(alpha, tests) / 2.0)


def normal_quantile(p: float) -> float:
    return NormalDist().inv_cdf(p)
