"""Collapse a binary BVH into a wide one: 4 children per node (the layout the GLSL
traversal reads) or 8.

Top-down over the wide levels, vectorised: each wide node starts from the two
children of its binary node and repeatedly opens the internal child of largest
surface area until it has ``width`` children or none can be opened (the greedy
collapse of Wald et al. 2008 / Pinto 2010). Binary subtrees chosen as leaves by
:meth:`BinaryTree.leaf_mask` end the descent and become leaf references.

Depth bound: the traversal's stack is sized for inner nodes at depth <=
``max_depth``. Should the greedy collapse go deeper, it is redone with the
exact collapsed height of every subtree (:func:`collapsed_heights`): a child at
depth ``max_depth - range_levels(width)`` whose subtree would end too deep is
built instead as a balanced wide tree over its triangles (its contiguous range
of the triangle order split in ``width`` near-equal parts, recursively: at most
R = :func:`range_levels` further levels, the smallest R with
width^(R + 1) >= 2^28, the triangles a leaf reference can address; 13 for width
4, 9 for width 8). Ordinary meshes never need it (PLOC on a 10^6-triangle mesh:
4-wide depth ~20 against the bound of 31, 8-wide ~10 against 21); adversarial
ones (geometric size progressions, nested shells) do, and only their deep parts
change.

Nodes come out in breadth-first order, so the inner children of one node sit
next to each other; triangles come out in the depth-first leaf order of the
binary tree, so every leaf is one contiguous range of the reordered triangles.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tree import BinaryTree

WIDTHS = (4, 8)
DEFAULT_WIDTH = 4
MAX_LEAF_SIZE = 4  # the default leaf bound, and the leaf size of balanced range subtrees
EMPTY = -1
RANGE_TRIANGLES = 1 << 28  # triangles a leaf reference can address (bvh.LEAF_FIRST_MASK + 1)
COUNT_MASK = (1 << 33) - 1
KIND_EMPTY, KIND_INNER, KIND_LEAF = 0, 1, 2


def range_levels(width: int) -> int:
    """Inner levels below a balanced range subtree's root: the smallest R with
    ``width^(R + 1) >= 2^28`` (4 -> 13, 8 -> 9)."""
    r = 0
    while width ** (r + 1) < RANGE_TRIANGLES:
        r += 1
    return r


@dataclass
class BvhArrays:
    """A wide BVH (``width`` = 4 or 8 children per node) in structure-of-arrays form (no GL types)."""

    child_lo: np.ndarray  # (N, width, 3) float32; +inf for empty slots
    child_hi: np.ndarray  # (N, width, 3) float32; -inf for empty slots
    child_kind: np.ndarray  # (N, width) int8: KIND_EMPTY, KIND_INNER or KIND_LEAF
    child_index: np.ndarray  # (N, width) int64: node index, or first triangle of a leaf
    child_count: np.ndarray  # (N, width) int64: triangles under the child (0 if empty)
    depth: np.ndarray  # (N,) int64: root = 0
    prim_order: np.ndarray  # (T,) int64: BVH-order triangle -> builder primitive

    @property
    def node_count(self) -> int:
        return len(self.child_kind)

    @property
    def width(self) -> int:
        return self.child_kind.shape[1]


def _open_largest(cand: np.ndarray, openable: np.ndarray, area: np.ndarray,
                  left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Replace, in each row, the openable candidate of largest area by its two children.

    ``cand`` (F, k) binary node ids (or EMPTY); returns (F, k + 1), children in
    place of their parent so the left-to-right (depth-first) order is kept.
    """
    f, k = cand.shape
    score = np.where(openable, area[np.maximum(cand, 0)], -1.0)
    j = np.argmax(score, axis=1)
    rows_open = score[np.arange(f), j] >= 0
    col = np.arange(k + 1)[None, :]
    jj = np.where(rows_open, j, k + 1)[:, None]
    src = np.clip(np.where(col < jj, col, col - 1), 0, k - 1)
    out = np.take_along_axis(cand, src, axis=1)
    out[~rows_open, k] = EMPTY
    r = np.nonzero(rows_open)[0]
    parent = cand[r, j[r]]
    out[r, j[r]] = left[parent]
    out[r, j[r] + 1] = right[parent]
    return out


def _range_boxes(prim_lo: np.ndarray, prim_hi: np.ndarray, start: np.ndarray,
                 size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of the primitive ranges [start, start + size) (sizes >= 1)."""
    if len(start) == 0:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32)
    order = np.argsort(start, kind="stable")
    bounds = np.stack([start[order], start[order] + size[order]], axis=1).ravel()
    pad_lo = np.concatenate([prim_lo, prim_lo[:1]])  # reduceat needs indices < len
    pad_hi = np.concatenate([prim_hi, prim_hi[:1]])
    lo = np.empty((len(start), 3), np.float32)
    hi = np.empty((len(start), 3), np.float32)
    lo[order] = np.minimum.reduceat(pad_lo, bounds, axis=0)[0::2]
    hi[order] = np.maximum.reduceat(pad_hi, bounds, axis=0)[0::2]
    return lo, hi


def _binary_rows(tree, roots, is_inner, area, width):
    """Candidate children (F, width) of wide nodes made from binary nodes ``roots``."""
    cand = np.stack([tree.left[roots], tree.right[roots]], axis=1)
    for _ in range(width - 2):
        openable = (cand >= 0) & is_inner[np.maximum(cand, 0)]
        cand = _open_largest(cand, openable, area, tree.left, tree.right)
    return cand


def _range_rows(start, size, width):
    """``width`` near-equal parts (F, width) of each range [start, start + size), size >
    MAX_LEAF_SIZE (8-wide, a range of fewer than 8 triangles has parts of size 0)."""
    q, r = size // width, size % width
    part = q[:, None] + (np.arange(width)[None, :] < r[:, None])
    first = start[:, None] + np.concatenate([np.zeros((len(size), 1), np.int64),
                                             np.cumsum(part, axis=1)[:, :-1]], axis=1)
    return first, part


def collapsed_heights(tree: BinaryTree, is_inner: np.ndarray, area: np.ndarray,
                      width: int = DEFAULT_WIDTH) -> np.ndarray:
    """Inner wide levels the greedy collapse makes from each binary subtree (0 for leaves).

    The wide node made from binary node c depends only on c's subtree, so this is
    a bottom-up pass: 1 + the largest height among the node's inner children.
    """
    height = np.zeros(len(tree.lo), np.int64)
    for s, e in tree.bottom_up():
        ids = np.arange(s, e)
        ids = ids[is_inner[ids]]
        if len(ids) == 0:
            continue
        cand = _binary_rows(tree, ids, is_inner, area, width)
        safe = np.maximum(cand, 0)
        below = np.where((cand >= 0) & is_inner[safe], height[safe], 0)
        height[ids] = 1 + below.max(axis=1)
    return height


def collapse_to_bvh(tree: BinaryTree, leaf: np.ndarray, count: np.ndarray,
                    first: np.ndarray, max_depth: int, width: int = DEFAULT_WIDTH) -> BvhArrays:
    """Collapse ``tree`` given its leaf decisions (``leaf``), counts and first positions
    into a ``width``-wide BVH whose inner nodes lie at depth <= ``max_depth``."""
    if width not in WIDTHS:
        raise ValueError(f"width must be one of {WIDTHS}, got {width}")
    if max_depth < range_levels(width):
        raise ValueError(f"max_depth must be at least {range_levels(width)} for width {width}")
    area = tree.area
    is_inner = ~leaf
    arrays = _collapse(tree, leaf, count, first, area, None, max_depth, width)
    if len(arrays.depth) and arrays.depth.max() > max_depth:
        height = collapsed_heights(tree, is_inner, area, width)
        arrays = _collapse(tree, leaf, count, first, area, height, max_depth, width)
    return arrays


def _collapse(tree: BinaryTree, leaf: np.ndarray, count: np.ndarray, first: np.ndarray,
              area: np.ndarray, height: np.ndarray | None, max_depth: int, width: int) -> BvhArrays:
    """The collapse; with ``height``, subtrees that would end too deep become ranges."""
    n = tree.n
    if n == 0:  # one root with empty slots only
        return BvhArrays(np.full((1, width, 3), np.inf, np.float32),
                         np.full((1, width, 3), -np.inf, np.float32),
                         np.zeros((1, width), np.int8), np.zeros((1, width), np.int64),
                         np.zeros((1, width), np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))
    is_inner = ~leaf
    switch_depth = max_depth - range_levels(width)
    prim_order = np.empty(n, np.int64)
    prim_order[first[:n]] = np.arange(n)
    prim_lo = prim_hi = None  # triangle boxes in BVH order, gathered if ranges are needed

    # What each level gathers per child (gathers dominate the time): first primitive,
    # count and inner flag packed in one int64, and the box corners.
    info = (first << 34) | (np.minimum(count, COUNT_MASK) << 1) | is_inner
    node_lo, node_hi = np.ascontiguousarray(tree.lo), np.ascontiguousarray(tree.hi)  # np.take copies others

    # The root is always an inner wide node; a tree that is one leaf hangs below it.
    bin_roots = np.zeros(0, np.int64)
    rng_start = np.zeros(0, np.int64)
    rng_size = np.zeros(0, np.int64)
    first_level = None
    if leaf[tree.root]:
        first_level = np.full((1, width), EMPTY, np.int64)
        first_level[0, 0] = tree.root
    else:
        bin_roots = np.array([tree.root])

    chunks = []
    depth = 0
    next_index = 1
    while True:
        # Binary rows: children from opening binary nodes.
        cand = (first_level if first_level is not None
                else _binary_rows(tree, bin_roots, is_inner, area, width))
        first_level = None
        valid = cand >= 0
        safe = np.maximum(cand, 0)
        packed = np.take(info, safe)
        inner = valid & ((packed & 1) == 1)
        kind = np.where(valid, np.where(inner, KIND_INNER, KIND_LEAF), KIND_EMPTY).astype(np.int8)
        start, size = packed >> 34, np.where(valid, (packed >> 1) & COUNT_MASK, 0)
        # np.take of rows, then the empty slots' rows: 3x faster than indexing and a
        # (F, width, 1)-broadcast np.where (whose inner loops are 3 elements long)
        lo, hi = np.take(node_lo, safe, axis=0), np.take(node_hi, safe, axis=0)
        empty = ~valid
        if empty.any():
            lo[empty], hi[empty] = np.float32(np.inf), np.float32(-np.inf)
        binary_id = cand
        # Inner children whose subtree may end too deep switch to balanced ranges.
        mode = np.zeros(cand.shape, np.int8)  # 0: binary subtree, 1: range
        if height is not None and depth + 1 == switch_depth:
            mode[inner & (depth + height[safe] > max_depth)] = 1
        if len(rng_start):  # range rows: ``width`` near-equal parts of each range
            if prim_lo is None:
                prim_lo, prim_hi = tree.lo[:n][prim_order], tree.hi[:n][prim_order]
            r_first, r_size = _range_rows(rng_start, rng_size, width)
            r_kind = np.where(r_size > MAX_LEAF_SIZE, KIND_INNER, KIND_LEAF).astype(np.int8)
            part = r_size.ravel() > 0  # 8-wide: a range of 5..7 triangles leaves empty parts
            if part.all():
                r_lo, r_hi = _range_boxes(prim_lo, prim_hi, r_first.ravel(), r_size.ravel())
            else:
                r_kind[r_size == 0] = KIND_EMPTY
                r_lo = np.full((r_size.size, 3), np.inf, np.float32)
                r_hi = np.full((r_size.size, 3), -np.inf, np.float32)
                r_lo[part], r_hi[part] = _range_boxes(prim_lo, prim_hi, r_first.ravel()[part],
                                                      r_size.ravel()[part])
            kind = np.concatenate([kind, r_kind])
            start = np.concatenate([start, r_first])
            size = np.concatenate([size, r_size])
            mode = np.concatenate([mode, np.ones(r_size.shape, np.int8)])
            binary_id = np.concatenate([cand, np.full_like(r_size, EMPTY)])
            lo = np.concatenate([lo, r_lo.reshape(-1, width, 3)])
            hi = np.concatenate([hi, r_hi.reshape(-1, width, 3)])

        is_child_node = kind == KIND_INNER
        n_inner = int(np.count_nonzero(is_child_node))
        index = np.where(kind == KIND_LEAF, start, 0)
        index[is_child_node] = next_index + np.arange(n_inner)  # row-major: breadth-first
        rows = len(kind)
        chunks.append((lo, hi, kind, index, size, np.full(rows, depth, np.int64)))
        next_index += n_inner
        # Next level: inner children keep their order (binary ones, then ranges, as indexed).
        child_mode, child_bin = mode[is_child_node], binary_id[is_child_node]
        child_start, child_size = start[is_child_node], size[is_child_node]
        if np.any(child_mode == 1) and np.any(child_mode == 0):
            # Keep index order = row order of the next level: binary rows must come first.
            order = np.argsort(child_mode, kind="stable")
            if np.any(order != np.arange(len(order))):
                _renumber(chunks[-1], next_index - n_inner, order)
                child_mode, child_bin = child_mode[order], child_bin[order]
                child_start, child_size = child_start[order], child_size[order]
        bin_roots = child_bin[child_mode == 0]
        rng_start, rng_size = child_start[child_mode == 1], child_size[child_mode == 1]
        depth += 1
        if n_inner == 0:
            break

    def cat(i):
        return np.concatenate([c[i] for c in chunks])

    return BvhArrays(cat(0), cat(1), cat(2), cat(3), cat(4), cat(5), prim_order)


def _renumber(chunk, base: int, order: np.ndarray) -> None:
    """Give the inner children of this level the indices of their sorted positions."""
    kind, index = chunk[2], chunk[3]
    inner = kind == KIND_INNER
    old = index[inner] - base  # 0..k-1 in row-major order
    new_of_old = np.empty_like(order)
    new_of_old[order] = np.arange(len(order))
    index[inner] = base + new_of_old[old]

