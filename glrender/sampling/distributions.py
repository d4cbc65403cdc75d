"""Tabulated distributions: built in numpy, packed into one float32 array, sampled in GLSL.

GLSL samplers: ``shaders/sampling/discrete_cdf.glsl``, ``alias_table.glsl``,
``distribution1d.glsl`` and ``distribution2d.glsl``, all reading the packed array
through ``float distribution_fetch(uint i)`` (``distribution_data.glsl``). The
functions below named like the GLSL ones are their numpy twins and read the same
packed array, so the packing itself is tested.

Packed format
-------------
Every table is a block of float32 elements; a caller concatenates blocks (see
:class:`DistributionPacker`) and passes a block's start ``offset`` to GLSL. Integers
(marked *uint*) are stored bit-exact: ``np.uint32`` values viewed as float32, read
back with ``floatBitsToUint``. Offsets below are relative to the block start.

=====================  =============================  ===========================================
table                  size (elements)                layout
=====================  =============================  ===========================================
discrete CDF, n        2 + 2n                         [0] n (uint); [1 .. n+1] cdf_0 .. cdf_n
outcomes                                              (cdf_0 = 0, cdf_n = 1); [n+2 .. 2n+1]
                                                      pmf_0 .. pmf_{n-1}
alias table, n         1 + 3n                         [0] n (uint); outcome i at 1 + 3i:
outcomes                                              q_i (keep threshold), alias_i (uint), pmf_i
piecewise-constant     5 + 2n                         [0] n (uint); [1] min; [2] max; [3]
1D, n bins on                                         integral of f; [4 .. 3+n] f_0 .. f_{n-1};
[min, max]                                            [4+n .. 4+2n] cdf_0 .. cdf_n
piecewise-constant     2 + (5 + 2nv) + nv (5 + 2nu)   [0] nu (uint); [1] nv (uint); [2 ..]
2D, image nv x nu                                     marginal: a 1D table over [v0, v1] whose f_j
on [u0,u1] x [v0,v1]                                  is the integral of row j over u; then row
                                                      j's conditional 1D table over [u0, u1] at
                                                      2 + (5 + 2nv) + j (5 + 2nu)
=====================  =============================  ===========================================

CDFs are computed in float64 and rounded to float32 (rounding keeps them
non-decreasing); an outcome whose probability is below float32 resolution of its
CDF value (~6e-8) may be unreachable. Negative or non-finite weights, and tables
whose weights are all zero, raise :class:`~glrender.errors.UsageError`; a 2D row of
zeros is allowed (it is never chosen).
"""
from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ._array import ONE_MINUS_EPSILON

_F32 = np.float32


def _uint(value: int) -> np.float32:
    return np.array([value], np.uint32).view(np.float32)[0]


def _read_uint(data: np.ndarray, index) -> np.ndarray:
    return np.asarray(data, np.float32)[index].view(np.uint32).astype(np.int64)


def _weights(values, name: str, allow_zero: bool = False) -> np.ndarray:
    w = np.asarray(values, np.float64)
    if w.size == 0:
        raise UsageError(f"{name}: no weights given")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise UsageError(f"{name}: weights must be finite and >= 0")
    if not allow_zero and not w.sum() > 0:
        raise UsageError(f"{name}: all weights are zero; there is nothing to sample")
    return w


def _cdf(w: np.ndarray) -> np.ndarray:
    """Normalised running sum cdf_0 = 0 .. cdf_n = 1 in float32 (uniform steps if w sums to 0)."""
    total = w.sum()
    if total > 0:
        cdf = np.concatenate([[0.0], np.cumsum(w) / total])
    else:
        cdf = np.arange(len(w) + 1) / len(w)
    cdf = np.clip(cdf, 0.0, 1.0).astype(_F32)
    cdf[-1] = 1.0
    return cdf


# ---- builders -----------------------------------------------------------------------------
def discrete_cdf_table(weights) -> np.ndarray:
    """Packed discrete CDF table of outcomes with probability proportional to ``weights``."""
    w = _weights(weights, "discrete_cdf_table").reshape(-1)
    pmf = (w / w.sum()).astype(_F32)
    return np.concatenate([[_uint(len(w))], _cdf(w), pmf]).astype(_F32)


def alias_table(weights) -> np.ndarray:
    """Packed alias table (Vose 1991) of outcomes with probability proportional to ``weights``."""
    w = _weights(weights, "alias_table").reshape(-1)
    n = len(w)
    pmf = w / w.sum()
    scaled = pmf * n
    q = np.ones(n)
    alias = np.arange(n)
    small = [i for i in range(n) if scaled[i] < 1.0]
    large = [i for i in range(n) if scaled[i] >= 1.0]
    while small and large:
        s, l = small.pop(), large.pop()
        q[s], alias[s] = scaled[s], l
        scaled[l] -= 1.0 - scaled[s]
        (small if scaled[l] < 1.0 else large).append(l)
    # Leftovers hold (up to rounding) exactly one bin's worth: they keep themselves.
    records = np.empty((n, 3), _F32)
    records[:, 0] = q
    records[:, 1] = np.asarray(alias, np.uint32).view(_F32)
    records[:, 2] = pmf
    return np.concatenate([[_uint(n)], records.reshape(-1)]).astype(_F32)


def light_power_table(powers) -> np.ndarray:
    """Alias table choosing light i with probability Phi_i / sum_j Phi_j (lecture 13)."""
    return alias_table(powers)


def distribution_1d_table(func, bounds=(0.0, 1.0), _allow_zero: bool = False) -> np.ndarray:
    """Packed piecewise-constant 1D table: density proportional to ``func`` on ``bounds``."""
    f = _weights(func, "distribution_1d_table", _allow_zero).reshape(-1)
    lo, hi = float(bounds[0]), float(bounds[1])
    if not hi > lo:
        raise UsageError(f"distribution_1d_table: empty interval [{lo}, {hi}]")
    integral = f.sum() * (hi - lo) / len(f)
    header = [_uint(len(f)), lo, hi, integral]
    return np.concatenate([np.array(header, _F32), f.astype(_F32), _cdf(f)]).astype(_F32)


def distribution_2d_table(image, bounds=((0.0, 1.0), (0.0, 1.0))) -> np.ndarray:
    """Packed piecewise-constant 2D table over ``bounds`` = ((u0, u1), (v0, v1)) with density
    proportional to ``image`` (shape (nv, nu): row j is the v bin, column i the u bin)."""
    f = np.asarray(image, np.float64)
    if f.ndim != 2:
        raise UsageError(f"distribution_2d_table: expected a 2D image, got shape {f.shape}")
    _weights(f, "distribution_2d_table")
    (u0, u1), (v0, v1) = bounds
    nv, nu = f.shape
    rows = [distribution_1d_table(row, (u0, u1), _allow_zero=True) for row in f]
    # The marginal's f_j must equal row j's stored integral exactly (pdf = product).
    row_integrals = np.array([r[3] for r in rows], np.float64)
    marginal = distribution_1d_table(row_integrals, (v0, v1))
    return np.concatenate([np.array([_uint(nu), _uint(nv)], _F32), marginal, *rows]).astype(_F32)


class DistributionPacker:
    """Concatenates packed tables into the one float32 array the shaders read.

    ``offset = packer.add(table)`` (or the ``add_*`` shortcuts) returns where the
    table starts; ``packer.array()`` gives the packed array for ``distribution_fetch``.
    """

    def __init__(self) -> None:
        self._blocks: list[np.ndarray] = []
        self.size = 0

    def add(self, table: np.ndarray) -> int:
        offset = self.size
        self._blocks.append(np.asarray(table, _F32))
        self.size += len(table)
        if self.size >= 2 ** 31:
            raise UsageError("DistributionPacker: tables exceed 2^31 elements")
        return offset

    def add_discrete_cdf(self, weights) -> int:
        return self.add(discrete_cdf_table(weights))

    def add_alias_table(self, weights) -> int:
        return self.add(alias_table(weights))

    def add_distribution_1d(self, func, bounds=(0.0, 1.0)) -> int:
        return self.add(distribution_1d_table(func, bounds))

    def add_distribution_2d(self, image, bounds=((0.0, 1.0), (0.0, 1.0))) -> int:
        return self.add(distribution_2d_table(image, bounds))

    def array(self) -> np.ndarray:
        return np.concatenate(self._blocks).astype(_F32) if self._blocks else np.zeros(1, _F32)


# ---- numpy twins of the GLSL samplers ------------------------------------------------------
def _remainder(u, c0, c1) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (u - c0) / (c1 - c0)
    return np.where(c1 > c0, np.minimum(r, ONE_MINUS_EPSILON), 0.0)


def _find_interval(cdf: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Largest i in [0, n - 1] with cdf[i] <= u (cdf has n + 1 float32 entries)."""
    i = np.searchsorted(cdf, np.asarray(u, _F32), side="right") - 1
    return np.clip(i, 0, len(cdf) - 2)


def choose_reflect_transmit(F, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reflect (0) with probability F, transmit (1) with 1 - F; (index, pmf, u_remapped)."""
    p_r = np.clip(np.asarray(F, np.float64), 0.0, 1.0)
    u = np.asarray(u, np.float64)
    reflect = u < p_r
    with np.errstate(divide="ignore", invalid="ignore"):
        rem = np.where(reflect, u / p_r, (u - p_r) / (1.0 - p_r))
    return (np.where(reflect, 0, 1), np.where(reflect, p_r, 1.0 - p_r),
            np.minimum(rem, ONE_MINUS_EPSILON))


def discrete_cdf_pmf(data, offset: int, index) -> np.ndarray:
    n = int(_read_uint(data, offset))
    index = np.asarray(index, np.int64)
    pmf = np.asarray(data, _F32)[offset + n + 2 + np.clip(index, 0, n - 1)].astype(np.float64)
    return np.where((index >= 0) & (index < n), pmf, 0.0)


def sample_discrete_cdf(data, offset: int, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    data = np.asarray(data, _F32)
    n = int(_read_uint(data, offset))
    cdf = data[offset + 1: offset + n + 2]
    u = np.asarray(u, _F32)
    i = _find_interval(cdf, u)
    rem = _remainder(u.astype(np.float64), cdf[i].astype(np.float64), cdf[i + 1].astype(np.float64))
    return i, discrete_cdf_pmf(data, offset, i), rem


def invert_discrete_cdf_sample(data, offset: int, index, u_remapped) -> np.ndarray:
    data = np.asarray(data, _F32)
    cdf = offset + 1 + np.asarray(index, np.int64)
    c0, c1 = data[cdf].astype(np.float64), data[cdf + 1].astype(np.float64)
    return np.minimum(c0 + (c1 - c0) * np.asarray(u_remapped, np.float64), ONE_MINUS_EPSILON)


def alias_table_pmf(data, offset: int, index) -> np.ndarray:
    n = int(_read_uint(data, offset))
    index = np.asarray(index, np.int64)
    pmf = np.asarray(data, _F32)[offset + 3 * np.clip(index, 0, n - 1) + 3].astype(np.float64)
    return np.where((index >= 0) & (index < n), pmf, 0.0)


def sample_alias_table(data, offset: int, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index, pmf, u_remapped), in float32 arithmetic as in GLSL so the indices agree."""
    data = np.asarray(data, _F32)
    n = int(_read_uint(data, offset))
    un = np.asarray(u, _F32) * _F32(n)
    bin_ = np.minimum(un.astype(np.int64), n - 1)
    up = np.minimum(un - bin_.astype(_F32), _F32(ONE_MINUS_EPSILON))
    record = offset + 1 + 3 * bin_
    q = data[record]
    keep = up < q
    index = np.where(keep, bin_, _read_uint(data, record + 1))
    q64, up64 = q.astype(np.float64), up.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        rem = np.where(keep, up64 / q64, (up64 - q64) / (1.0 - q64))
    return index, alias_table_pmf(data, offset, index), np.minimum(rem, ONE_MINUS_EPSILON)


def sample_light_by_power(data, offset: int, u):
    return sample_alias_table(data, offset, u)


def _header_1d(data, offset: int):
    n = int(_read_uint(data, offset))
    lo, hi, integral = (float(v) for v in data[offset + 1: offset + 4])
    return n, lo, hi, integral


def sample_distribution_1d(data, offset: int, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, pdf per unit length, bin)."""
    data = np.asarray(data, _F32)
    n, lo, hi, integral = _header_1d(data, offset)
    f = data[offset + 4: offset + 4 + n].astype(np.float64)
    cdf = data[offset + 4 + n: offset + 5 + 2 * n]
    u = np.asarray(u, _F32)
    i = _find_interval(cdf, u)
    du = _remainder(u.astype(np.float64), cdf[i].astype(np.float64), cdf[i + 1].astype(np.float64))
    pdf = f[i] / integral if integral > 0 else np.zeros(len(i))
    x = np.minimum(lo + (hi - lo) * (i + du) / n, hi)
    return x, pdf, i


def _bin_of(x, lo: float, hi: float, n: int) -> np.ndarray:
    return np.clip(((np.asarray(x, np.float64) - lo) / (hi - lo) * n).astype(np.int64), 0, n - 1)


def distribution_1d_pdf(data, offset: int, x) -> np.ndarray:
    data = np.asarray(data, _F32)
    n, lo, hi, integral = _header_1d(data, offset)
    x = np.asarray(x, np.float64)
    f = data[offset + 4 + _bin_of(x, lo, hi, n)].astype(np.float64)
    return np.where((x >= lo) & (x <= hi) & (integral > 0), f / integral, 0.0)


def invert_distribution_1d_sample(data, offset: int, x) -> np.ndarray:
    data = np.asarray(data, _F32)
    n, lo, hi, _ = _header_1d(data, offset)
    x = np.asarray(x, np.float64)
    c = (x - lo) / (hi - lo) * n
    i = _bin_of(x, lo, hi, n)
    cdf = offset + 4 + n + i
    c0, c1 = data[cdf].astype(np.float64), data[cdf + 1].astype(np.float64)
    u = np.minimum(c0 + (c1 - c0) * np.clip(c - i, 0.0, 1.0), ONE_MINUS_EPSILON)
    return np.where((x >= lo) & (x <= hi), u, -1.0)


def _layout_2d(data, offset: int):
    nu, nv = int(_read_uint(data, offset)), int(_read_uint(data, offset + 1))
    marginal = offset + 2
    rows = marginal + 5 + 2 * nv
    return nu, nv, marginal, rows, 5 + 2 * nu


def sample_distribution_2d(data, offset: int, u) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 2) = (u, v), pdf per unit area); u[:, 1] picks the row, u[:, 0] the column."""
    data = np.asarray(data, _F32)
    u = np.asarray(u, _F32).reshape(-1, 2)
    nu, nv, marginal, rows, stride = _layout_2d(data, offset)
    v, pdf_v, row = sample_distribution_1d(data, marginal, u[:, 1])
    x = np.empty(len(u))
    pdf_u = np.empty(len(u))
    for j in np.unique(row):
        sel = row == j
        x[sel], pdf_u[sel], _ = sample_distribution_1d(data, rows + int(j) * stride, u[sel, 0])
    return np.column_stack([x, v]), pdf_v * pdf_u


def distribution_2d_pdf(data, offset: int, p) -> np.ndarray:
    data = np.asarray(data, _F32)
    p = np.asarray(p, np.float64).reshape(-1, 2)
    nu, nv, marginal, rows, stride = _layout_2d(data, offset)
    _, v0, v1, integral = _header_1d(data, marginal)
    _, u0, u1, _ = _header_1d(data, rows)
    i, j = _bin_of(p[:, 0], u0, u1, nu), _bin_of(p[:, 1], v0, v1, nv)
    f = data[rows + j * stride + 4 + i].astype(np.float64)
    inside = (p[:, 0] >= u0) & (p[:, 0] <= u1) & (p[:, 1] >= v0) & (p[:, 1] <= v1)
    return np.where(inside & (integral > 0), f / integral, 0.0)


def invert_distribution_2d_sample(data, offset: int, p) -> np.ndarray:
    data = np.asarray(data, _F32)
    p = np.asarray(p, np.float64).reshape(-1, 2)
    nu, nv, marginal, rows, stride = _layout_2d(data, offset)
    _, v0, v1, _ = _header_1d(data, marginal)
    uv = invert_distribution_1d_sample(data, marginal, p[:, 1])
    j = _bin_of(p[:, 1], v0, v1, nv)
    uu = np.empty(len(p))
    for row in np.unique(j):
        sel = j == row
        uu[sel] = invert_distribution_1d_sample(data, rows + int(row) * stride, p[sel, 0])
    bad = (uv < 0) | (uu < 0)
    return np.where(bad[:, None], -1.0, np.column_stack([uu, uv]))
