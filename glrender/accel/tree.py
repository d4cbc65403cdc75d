"""Binary BVHs as flat arrays, and the bottom-up / top-down passes over them.

Every builder here (PLOC, binned SAH) produces the same representation, so the
leaf decisions, the collapse to a 4- or 8-wide BVH and the cost model are shared and
two trees over one mesh can be compared fairly.

Node ``i < n`` is the leaf holding primitive ``i``; nodes ``n .. 2n-2`` are
internal, with ``left``/``right`` children. ``levels`` partitions the internal
ids into consecutive ranges such that the children of a range lie in earlier
ranges or are leaves: a pass over the ranges in order is bottom-up, in reverse
top-down, and each range is one vectorised numpy step (the Python loop runs once
per level, never once per node).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


def half_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half the surface area of boxes (..., 3), in their dtype; empty boxes (lo > hi) give 0."""
    e = np.subtract(hi, lo)  # empty slots (+inf, -inf): -inf, clamped to 0
    np.maximum(e, 0, out=e)
    x, y, z = e[..., 0], e[..., 1], e[..., 2]
    return x * y + z * (x + y)


@dataclass
class BinaryTree:
    """A binary BVH over ``n`` primitives (see the module doc for the numbering)."""

    lo: np.ndarray  # (2n-1, 3) float32
    hi: np.ndarray  # (2n-1, 3) float32
    left: np.ndarray  # (2n-1,) int64, -1 for leaves
    right: np.ndarray  # (2n-1,) int64, -1 for leaves
    levels: list[tuple[int, int]] = field(default_factory=list)

    @cached_property
    def area(self) -> np.ndarray:
        """Half surface area of every node box (float32)."""
        return half_area(self.lo, self.hi)

    @property
    def n(self) -> int:
        return (len(self.lo) + 1) // 2

    @property
    def root(self) -> int:
        return len(self.lo) - 1

    def bottom_up(self):
        """Ranges of internal ids, children before parents."""
        return self.levels

    def top_down(self):
        """Ranges of internal ids, parents before children."""
        return self.levels[::-1]

    def counts(self) -> np.ndarray:
        """Primitives under each node."""
        count = np.ones(len(self.lo), np.int64)
        for s, e in self.bottom_up():
            count[s:e] = count[self.left[s:e]] + count[self.right[s:e]]
        return count

    def depths(self) -> np.ndarray:
        """Edges from the root to each node."""
        depth = np.zeros(len(self.lo), np.int64)
        for s, e in self.top_down():
            depth[self.left[s:e]] = depth[s:e] + 1
            depth[self.right[s:e]] = depth[s:e] + 1
        return depth

    def heights(self) -> np.ndarray:
        """Edges on the longest path from each node down to a leaf."""
        height = np.zeros(len(self.lo), np.int64)
        for s, e in self.bottom_up():
            height[s:e] = 1 + np.maximum(height[self.left[s:e]], height[self.right[s:e]])
        return height

    def first_prim(self, count: np.ndarray) -> np.ndarray:
        """Position of each node's first primitive in depth-first (left first) order.

        The primitives under any node form the contiguous range
        ``[first, first + count)`` of that order, so leaves of several
        primitives become ranges of a reordered triangle array.
        """
        first = np.zeros(len(self.lo), np.int64)
        for s, e in self.top_down():
            first[self.left[s:e]] = first[s:e]
            first[self.right[s:e]] = first[s:e] + count[self.left[s:e]]
        return first

    def leaf_mask(self, count: np.ndarray, max_leaf: int, c_node: float,
                  c_tri: float) -> np.ndarray:
        """Nodes whose whole subtree is better stored as one leaf (SAH, bottom-up).

        A node of at most ``max_leaf`` primitives becomes a leaf when
        ``A * count * c_tri <= A * c_node + cost(left) + cost(right)``, the
        usual SAH comparison (costs in area-weighted units; MacDonald & Booth 1990).
        """
        area = self.area.astype(np.float64)
        cost = area * c_tri  # single-primitive leaves
        leaf = np.ones(len(self.lo), bool)
        for s, e in self.bottom_up():
            split = area[s:e] * c_node + cost[self.left[s:e]] + cost[self.right[s:e]]
            as_leaf = area[s:e] * count[s:e] * c_tri
            ok = (count[s:e] <= max_leaf) & (as_leaf <= split)
            leaf[s:e] = ok
            cost[s:e] = np.where(ok, as_leaf, split)
        return leaf

    def sah_cost(self, c_node: float = 1.0, c_tri: float = 1.0) -> float:
        """SAH cost of the binary tree with one primitive per leaf, relative to the root box."""
        area = self.area.astype(np.float64)
        root_area = area[self.root] if len(area) else 0.0
        if root_area <= 0:
            return float(c_tri * self.n)
        inner = area[self.n:].sum()
        leaves = area[:self.n].sum()
        return float((c_node * inner + c_tri * leaves) / root_area)


def as_boxes(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Box corners as contiguous float32 (n, 3) arrays, the builders' input."""
    return (np.ascontiguousarray(lo, np.float32).reshape(-1, 3),
            np.ascontiguousarray(hi, np.float32).reshape(-1, 3))


def single_leaf_tree(lo: np.ndarray, hi: np.ndarray) -> BinaryTree:
    """The tree of zero or one primitive."""
    n = len(lo)
    return BinaryTree(np.asarray(lo, np.float32).reshape(n, 3), np.asarray(hi, np.float32).reshape(n, 3),
                      np.full(n, -1, np.int64), np.full(n, -1, np.int64), [])
