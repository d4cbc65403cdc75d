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
from .tree import BinaryTree, as_boxes, half_area, single_leaf_tree

DEFAULT_BINS = 32
SMALL_SEGMENT = 48  # segments of at most this many primitives use SMALL_BINS bins
SMALL_BINS = 8
MEDIAN_AFTER = 64


def _best_splits(plo, phi, b, seg, sizes, bins):
    """Cheapest SAH split (cost, axis, last left bin) of each segment.

    ``plo``/``phi`` (3, P) primitive boxes by component, ``b`` (P, 3) bin indices.
    """
    s_count = len(sizes)
    best_cost = np.full(s_count, np.inf, np.float32)
    best_axis = np.zeros(s_count, np.int64)
    best_split = np.zeros(s_count, np.int64)
    rows = np.arange(s_count)
    for axis in range(3):
        key = seg * bins + b[:, axis]
        cnt = np.bincount(key, minlength=s_count * bins).reshape(s_count, bins)
        blo = np.full((s_count * bins, 3), np.inf, np.float32)
        bhi = np.full((s_count * bins, 3), -np.inf, np.float32)
        for c in range(3):  # one-dimensional ufunc.at is many times faster than on rows
            col_lo = np.full(s_count * bins, np.inf, np.float32)
            col_hi = np.full(s_count * bins, -np.inf, np.float32)
            np.minimum.at(col_lo, key, plo[c])
            np.maximum.at(col_hi, key, phi[c])
            blo[:, c], bhi[:, c] = col_lo, col_hi
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
        c = cost[rows, i]
        better = c < best_cost
        best_cost = np.where(better, c, best_cost)
        best_axis = np.where(better, axis, best_axis)
        best_split = np.where(better, i, best_split)
    return best_cost, best_axis, best_split


def build_binned_sah(lo: np.ndarray, hi: np.ndarray, bins: int = DEFAULT_BINS) -> BinaryTree:
    """A binary BVH over boxes ``lo``/``hi`` (n, 3) by binned SAH, one primitive per leaf."""
    lo, hi = as_boxes(lo, hi)
    n = len(lo)
    if n <= 1:
        return single_leaf_tree(lo, hi)
    cen = 0.5 * (lo + hi)
    lo_t, hi_t = np.ascontiguousarray(lo.T), np.ascontiguousarray(hi.T)  # (3, n): contiguous components
    cen_t = np.ascontiguousarray(cen.T)
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
        plo_t, phi_t, pc_t = lo_t[:, prim], hi_t[:, prim], cen_t[:, prim]
        node_lo = np.minimum.reduceat(plo_t, offsets, axis=1).T
        node_hi = np.maximum.reduceat(phi_t, offsets, axis=1).T
        split_right = np.zeros(len(seg), bool)
        use_middle = np.ones(s_count, bool)
        if level < MEDIAN_AFTER:
            cmin = np.minimum.reduceat(pc_t, offsets, axis=1)  # (3, S)
            cmax = np.maximum.reduceat(pc_t, offsets, axis=1)
            best_axis = np.zeros(s_count, np.int64)
            best_split = np.zeros(s_count, np.int64)
            best_bin = np.zeros(len(seg), np.int64)
            # Small segments need few bins: 32 bins for 2 primitives would only cost time.
            for group, nb in ((sizes > SMALL_SEGMENT, bins), (sizes <= SMALL_SEGMENT, SMALL_BINS)):
                if not group.any():
                    continue
                members = group[seg]
                local = np.cumsum(group) - 1
                gseg = local[seg[members]]
                extent = (cmax - cmin)[:, group]
                scale = np.where(extent > 0, nb / np.where(extent > 0, extent, 1), 0).astype(np.float32)
                b = ((pc_t[:, members] - cmin[:, group][:, gseg]) * scale[:, gseg]).astype(np.int64)
                b = np.clip(b, 0, nb - 1).T  # (P, 3)
                cost, axis, split = _best_splits(plo_t[:, members], phi_t[:, members], b, gseg,
                                                 sizes[group], nb)
                use_middle[group] = ~np.isfinite(cost)
                best_axis[group], best_split[group] = axis, split
                best_bin[members] = b[np.arange(len(b)), axis[gseg]]
            split_right = best_bin > best_split[seg]
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
