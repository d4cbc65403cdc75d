"""Full top-down binned SAH build (Wald 2007), vectorised over all nodes of a level.

The quality reference for the PLOC builder: every node is split at the best of
``bins - 1`` planes on each of the three axes by the surface area heuristic,
down to one primitive per leaf (leaves are chosen afterwards, by the same SAH
pass as for PLOC, so both trees are judged by the same rules). Each level is a
handful of whole-array numpy operations over all primitives still in inner
nodes (``np.minimum.at`` for the bin boxes), so the Python loop runs once per
level. Segments whose centroids cannot be separated by binning (all in one bin)
split at their middle position; past ``MEDIAN_AFTER`` levels every split is a
middle split, which bounds the depth on adversarial inputs. Primitives start in
Morton order and every partition is stable, so middle splits stay spatial.
"""
from __future__ import annotations

import numpy as np

from .morton import morton_order
from .tree import BinaryTree, half_area, single_leaf_tree

DEFAULT_BINS = 32
MEDIAN_AFTER = 64


def _segment_reduce(values: np.ndarray, starts: np.ndarray, op) -> np.ndarray:
    return op.reduceat(values, starts, axis=0)


def build_binned_sah(lo: np.ndarray, hi: np.ndarray, bins: int = DEFAULT_BINS) -> BinaryTree:
    """A binary BVH over boxes ``lo``/``hi`` (n, 3) by binned SAH, one primitive per leaf."""
    lo = np.ascontiguousarray(lo, np.float32)
    hi = np.ascontiguousarray(hi, np.float32)
    n = len(lo)
    if n <= 1:
        return single_leaf_tree(lo, hi)
    cen = 0.5 * (lo.astype(np.float64) + hi)
    perm = morton_order(cen)
    # Active segments: [start, end) ranges of `perm` that are inner nodes at this level.
    starts = np.array([0], np.int64)
    sizes = np.array([n], np.int64)
    level_nodes = []  # per level: (lo, hi, left_ref, right_ref); refs: >= 0 next-level index, < 0 leaf ~prim
    level = 0
    while len(starts):
        s_count = len(starts)
        seg = np.repeat(np.arange(s_count), sizes)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        pos = np.arange(len(seg)) - offsets[seg] + starts[seg]  # positions in perm
        prim = perm[pos]
        plo, phi, pc = lo[prim], hi[prim], cen[prim]
        node_lo = _segment_reduce(plo, offsets, np.minimum)
        node_hi = _segment_reduce(phi, offsets, np.maximum)
        split_right = np.zeros(len(seg), bool)
        use_middle = np.ones(s_count, bool)
        if level < MEDIAN_AFTER:
            cmin = _segment_reduce(pc, offsets, np.minimum)
            cmax = _segment_reduce(pc, offsets, np.maximum)
            extent = cmax - cmin
            scale = np.where(extent > 0, bins / np.where(extent > 0, extent, 1.0), 0.0)
            b = np.clip(((pc - cmin[seg]) * scale[seg]).astype(np.int64), 0, bins - 1)  # (P, 3)
            best_cost = np.full(s_count, np.inf)
            best_axis = np.zeros(s_count, np.int64)
            best_split = np.zeros(s_count, np.int64)
            for axis in range(3):
                key = seg * bins + b[:, axis]
                cnt = np.bincount(key, minlength=s_count * bins).reshape(s_count, bins)
                blo = np.full((s_count * bins, 3), np.inf, np.float32)
                bhi = np.full((s_count * bins, 3), -np.inf, np.float32)
                np.minimum.at(blo, key, plo)
                np.maximum.at(bhi, key, phi)
                blo = blo.reshape(s_count, bins, 3)
                bhi = bhi.reshape(s_count, bins, 3)
                # Split after bin i: left = bins 0..i, right = bins i+1..
                llo = np.minimum.accumulate(blo, axis=1)[:, :-1]
                lhi = np.maximum.accumulate(bhi, axis=1)[:, :-1]
                rlo = np.minimum.accumulate(blo[:, ::-1], axis=1)[:, ::-1][:, 1:]
                rhi = np.maximum.accumulate(bhi[:, ::-1], axis=1)[:, ::-1][:, 1:]
                lcnt = np.cumsum(cnt, axis=1)[:, :-1]
                rcnt = sizes[:, None] - lcnt
                with np.errstate(invalid="ignore"):
                    cost = half_area(llo, lhi) * lcnt + half_area(rlo, rhi) * rcnt
                cost = np.where((lcnt > 0) & (rcnt > 0), cost, np.inf)
                i = np.argmin(cost, axis=1)
                c = cost[np.arange(s_count), i]
                better = c < best_cost
                best_cost = np.where(better, c, best_cost)
                best_axis = np.where(better, axis, best_axis)
                best_split = np.where(better, i, best_split)
            use_middle = ~np.isfinite(best_cost)
            split_right = b[np.arange(len(seg)), best_axis[seg]] > best_split[seg]
        rank = np.arange(len(seg)) - offsets[seg]
        split_right = np.where(use_middle[seg], rank >= sizes[seg] // 2, split_right)
        # Stable partition inside each segment: lefts first, then rights.
        is_left = ~split_right
        left_before = np.cumsum(is_left) - is_left  # exclusive, global
        left_before = left_before - left_before[offsets][seg]
        n_left = np.add.reduceat(is_left.astype(np.int64), offsets)
        right_before = rank - left_before
        new_rank = np.where(is_left, left_before, n_left[seg] + right_before)
        perm[starts[seg] + new_rank] = prim
        # Children: single primitives become leaves, the rest inner nodes of the next level.
        child_start = np.stack([starts, starts + n_left], axis=1)  # (S, 2)
        child_size = np.stack([n_left, sizes - n_left], axis=1)
        inner = child_size > 1
        ref = np.where(inner, 0, ~perm[child_start])  # leaves: ~prim (negative)
        ref[inner] = np.arange(int(np.count_nonzero(inner)))
        level_nodes.append((node_lo, node_hi, ref[:, 0], ref[:, 1]))
        starts, sizes = child_start[inner], child_size[inner]
        level += 1

    # Number internal nodes bottom-up: the deepest level gets the smallest ids.
    total = 2 * n - 1
    out_lo = np.empty((total, 3), np.float32)
    out_hi = np.empty((total, 3), np.float32)
    out_lo[:n], out_hi[:n] = lo, hi
    left = np.full(total, -1, np.int64)
    right = np.full(total, -1, np.int64)
    levels = []
    next_id = n
    next_level_base = 0
    for node_lo, node_hi, lref, rref in reversed(level_nodes):
        count = len(node_lo)
        ids = np.arange(next_id, next_id + count)
        out_lo[ids], out_hi[ids] = node_lo, node_hi
        left[ids] = np.where(lref < 0, ~lref, next_level_base + lref)
        right[ids] = np.where(rref < 0, ~rref, next_level_base + rref)
        levels.append((next_id, next_id + count))
        next_level_base = next_id
        next_id += count
    return BinaryTree(out_lo, out_hi, left, right, levels)
