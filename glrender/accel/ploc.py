"""Parallel Locally-Ordered Clustering (PLOC; Meister & Bittner 2018), vectorised in numpy.

Primitives start as clusters sorted along a Morton curve. Each iteration finds,
for every cluster, the neighbour within ``radius`` positions whose merged box has
the smallest surface area; mutual nearest neighbours merge into a new node, which
takes the left one's place. The work of an iteration is a few dozen whole-array
numpy operations per offset, so the Python loop runs once per offset per
iteration (about ``radius`` x a few dozen times), never once per primitive.

Ties (equal areas: identical or regularly tessellated geometry) are broken by a
strict total order on pairs, (area, offset, parity of the left index, left
index), so the globally smallest pair is always mutual and progress is
guaranteed; the parity term makes a row of identical clusters pair up as
(0,1), (2,3), ... and halve in one iteration instead of merging one pair per
iteration. Should an iteration still merge fewer than 1/``STALL_FRACTION`` of
the clusters, that iteration merges Morton neighbours pairwise instead, which
bounds the number of iterations by O(log n) on any input.
"""
from __future__ import annotations

import numpy as np

from .morton import morton_order
from .tree import BinaryTree, single_leaf_tree

DEFAULT_RADIUS = 8
STALL_FRACTION = 64


def _nearest_neighbours(clo: np.ndarray, chi: np.ndarray, radius: int) -> np.ndarray:
    """Signed offset from each cluster to its nearest neighbour (smallest merged area).

    ``clo``/``chi`` are (3, m) float32 structure-of-arrays bounds in Morton order.
    """
    m = clo.shape[1]
    best = np.full(m, np.inf, np.float32)
    offset = np.zeros(m, np.int64)
    odd = (np.arange(m) & 1).astype(bool)
    ext = np.empty((3, m), np.float32)
    tmp = np.empty(m, np.float32)
    area = np.empty(m, np.float32)
    fwd = np.empty(m, np.float32)
    bwd = np.empty(m, np.float32)
    for d in range(1, min(radius, m - 1) + 1):
        k = m - d
        e = ext[:, :k]
        t = tmp[:k]
        a = area[:k]
        for axis in range(3):
            np.maximum(chi[axis, :k], chi[axis, d:], out=e[axis])
            np.minimum(clo[axis, :k], clo[axis, d:], out=t)
            np.subtract(e[axis], t, out=e[axis])
        # half area = ex*ey + ez*(ex + ey)
        np.multiply(e[0], e[1], out=a)
        np.add(e[0], e[1], out=t)
        np.multiply(t, e[2], out=t)
        np.add(a, t, out=a)
        # Cluster i sees the pair (i, i+d) forward and (i-d, i) backward.
        fwd[:k] = a
        fwd[k:] = np.inf
        bwd[:d] = np.inf
        bwd[d:] = a
        # Same area: the pair whose left index is even wins; same parity (d even):
        # the smaller left index, i.e. the backward pair.
        take_bwd = (bwd < fwd) | ((bwd == fwd) & (odd | (d % 2 == 0)))
        cand = np.where(take_bwd, bwd, fwd)
        better = cand < best  # strict: a smaller offset keeps its win on ties
        best = np.where(better, cand, best)
        offset = np.where(better, np.where(take_bwd, -d, d), offset)
    return offset


def build_ploc(lo: np.ndarray, hi: np.ndarray, radius: int = DEFAULT_RADIUS) -> BinaryTree:
    """A binary BVH over boxes ``lo``/``hi`` (n, 3), one primitive per leaf."""
    lo = np.ascontiguousarray(lo, np.float32)
    hi = np.ascontiguousarray(hi, np.float32)
    n = len(lo)
    if n <= 1:
        return single_leaf_tree(lo, hi)
    total = 2 * n - 1
    node_lo = np.empty((total, 3), np.float32)
    node_hi = np.empty((total, 3), np.float32)
    node_lo[:n], node_hi[:n] = lo, hi
    left = np.full(total, -1, np.int64)
    right = np.full(total, -1, np.int64)

    order = morton_order(0.5 * (lo.astype(np.float64) + hi))
    ids = order.astype(np.int64)
    clo = np.ascontiguousarray(lo[order].T)
    chi = np.ascontiguousarray(hi[order].T)
    next_id = n
    levels = []
    while len(ids) > 1:
        m = len(ids)
        offset = _nearest_neighbours(clo, chi, radius)
        pos = np.arange(m)
        nn = pos + offset
        mutual = nn[nn] == pos
        first = np.nonzero(mutual & (offset > 0))[0]
        if len(first) * STALL_FRACTION < m:
            first = np.arange(0, m - 1, 2)  # stalled: merge Morton neighbours pairwise
            second = first + 1
        else:
            second = nn[first]
        count = len(first)
        new = np.arange(next_id, next_id + count)
        left[new], right[new] = ids[first], ids[second]
        mlo = np.minimum(clo[:, first], clo[:, second])
        mhi = np.maximum(chi[:, first], chi[:, second])
        node_lo[new], node_hi[new] = mlo.T, mhi.T
        levels.append((next_id, next_id + count))
        next_id += count
        ids[first] = new
        clo[:, first], chi[:, first] = mlo, mhi
        keep = np.ones(m, bool)
        keep[second] = False
        ids = ids[keep]
        clo = np.ascontiguousarray(clo[:, keep])
        chi = np.ascontiguousarray(chi[:, keep])
    return BinaryTree(node_lo, node_hi, left, right, levels)
