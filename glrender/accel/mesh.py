"""Triangle soup preparation for the BVH builder: validation and clean-up.

Scene files come from strangers, so the builder never trusts its input:

- indices outside the vertex array are a :class:`SceneError` (nothing sensible
  can be drawn from them);
- triangles touching a NaN or infinite vertex are skipped with a count, or raise
  a :class:`SceneError` with ``on_invalid="raise"``;
- zero-area triangles (the cross product of two edges, computed in float64,
  is zero) are skipped with a count: the watertight test can never report a hit
  on them (its determinant is zero), so they would only cost traversal time;
- exact duplicates (the same three vertex positions, in any order) keep their
  first occurrence: duplicates fight for the same hits and, in bulk (10^6 copies
  of one triangle), would make every ray test every copy.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError, UsageError

INVALID_POLICIES = ("skip", "raise")


@dataclass
class PreparedTriangles:
    """Triangles ready to build over, and what was removed on the way."""

    corners: np.ndarray  # (T, 3, 3) float32: corner k of triangle i is corners[i, k]
    source: np.ndarray  # (T,) int64: index of each kept triangle in the input
    input_count: int
    skipped_invalid: int  # touching a NaN / Inf vertex
    skipped_degenerate: int  # zero area
    removed_duplicates: int

    @property
    def count(self) -> int:
        return len(self.corners)


def _as_arrays(vertices, triangles) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(vertices)
    triangles = np.asarray(triangles)
    if vertices.size == 0:
        vertices = vertices.reshape(0, 3)
    if triangles.size == 0:
        triangles = triangles.reshape(0, 3).astype(np.int64)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise UsageError(f"build_bvh: vertices must have shape (V, 3), got {vertices.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3:
        raise UsageError(f"build_bvh: triangles must have shape (T, 3), got {triangles.shape}")
    if not np.issubdtype(vertices.dtype, np.number) or np.issubdtype(vertices.dtype, np.complexfloating):
        raise UsageError(f"build_bvh: vertices must be real numbers, got dtype {vertices.dtype}")
    if not np.issubdtype(triangles.dtype, np.integer):
        raise UsageError(f"build_bvh: triangles must be integer vertex indices, "
                         f"got dtype {triangles.dtype}")
    if len(triangles) and (triangles.min() < 0 or triangles.max() >= len(vertices)):
        bad = int(np.count_nonzero((triangles < 0) | (triangles >= len(vertices))))
        raise SceneError(f"{bad} triangle indices lie outside the {len(vertices)} vertices "
                         f"(valid: 0..{len(vertices) - 1})")
    return vertices, triangles


def _mix64(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """A 64-bit finaliser (splitmix64): spreads every input bit over the whole word
    (into ``out`` when given, which may be ``x`` itself: in place, no temporaries)."""
    if out is None:
        out = x.copy()
    elif out is not x:
        np.copyto(out, x)
    x = out
    t = np.empty_like(x)
    np.right_shift(x, np.uint64(30), out=t)
    x ^= t
    x *= np.uint64(0xBF58476D1CE4E5B9)
    np.right_shift(x, np.uint64(27), out=t)
    x ^= t
    x *= np.uint64(0x94D049BB133111EB)
    np.right_shift(x, np.uint64(31), out=t)
    x ^= t
    return x


def _vertex_hashes(v32: np.ndarray) -> np.ndarray:
    """A 64-bit hash of each vertex position (equal positions, equal hashes).

    The coordinates' bits times odd constants, then one xor-shift: a third of the time
    of mixing each coordinate in. Hashes only group triangles for the exact comparison,
    so a collision can at worst leave a duplicate in place, never remove a distinct
    triangle; none occur on 128^3-point grids (integer, 1/128 and 0.1 spacing) or on
    3 x 10^6 random points.
    """
    bits = v32.view(np.uint32)
    h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)
    t = bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= t
    np.multiply(bits[:, 2], np.uint64(0x165667B19E3779F9), out=t)
    h += t
    np.right_shift(h, np.uint64(29), out=t)
    h ^= t
    return h


def _duplicate_mask(corners: np.ndarray, corner_hash: np.ndarray) -> np.ndarray:
    """True for every triangle whose vertex set equals that of an earlier triangle.

    Triangles are grouped by an order-independent hash of their corner
    positions (``corner_hash`` (T, 3)) and then compared exactly, so a hash
    collision can only leave a duplicate in place, never remove a distinct triangle.
    """
    t = len(corners)
    if t < 2:
        return np.zeros(t, bool)
    a, b, c = corner_hash[:, 0], corner_hash[:, 1], corner_hash[:, 2]
    low = np.minimum(np.minimum(a, b), c)           # the three sorted, without a sort per row
    high = np.maximum(np.maximum(a, b), c)
    middle = a ^ b ^ c ^ low ^ high
    th = _mix64(high)
    th ^= middle
    _mix64(th, out=th)
    th ^= low
    _mix64(th, out=th)
    if not (np.diff(np.sort(th)) == 0).any():      # no equal hashes (the usual case):
        return np.zeros(t, bool)                     # a plain sort is 5x faster than a stable argsort
    order = np.argsort(th, kind="stable")  # equal hashes: ascending triangle index
    th_sorted = th[order]
    same_hash = th_sorted[1:] == th_sorted[:-1]
    duplicate = np.zeros(t, bool)
    if not same_hash.any():
        return duplicate
    # Compare each triangle with the first member of its equal-hash run, corners
    # in a canonical order (by hash) so that any order of the same corners matches.
    run_start = np.concatenate([[True], ~same_hash])
    first = np.maximum.accumulate(np.where(run_start, np.arange(t), 0))
    cand = np.nonzero(~run_start)[0]
    a, b = order[cand], order[first[cand]]

    def canonical(i):
        corner_order = np.argsort(corner_hash[i], axis=1, kind="stable")
        return np.take_along_axis(corners[i], corner_order[..., None], axis=1).reshape(len(i), 9)

    equal = np.all(canonical(a) == canonical(b), axis=1)
    duplicate[a[equal]] = True
    return duplicate


def prepare_triangles(vertices, triangles, on_invalid: str = "skip",
                      remove_degenerate: bool = True,
                      remove_duplicates: bool = True) -> PreparedTriangles:
    """Gather triangle corners as float32 and drop what can never be hit.

    ``vertices`` (V, 3) float, ``triangles`` (T, 3) int. ``on_invalid``: ``"skip"``
    (drop triangles with a non-finite vertex, counted) or ``"raise"``
    (:class:`SceneError`).
    """
    if on_invalid not in INVALID_POLICIES:
        raise UsageError(f"build_bvh: on_invalid must be one of {INVALID_POLICIES}, "
                         f"got {on_invalid!r}")
    vertices, triangles = _as_arrays(vertices, triangles)
    input_count = len(triangles)

    # Coordinates beyond float32 become infinite: they are invalid too.
    with np.errstate(over="ignore", invalid="ignore"):
        v32 = vertices.astype(np.float32) + np.float32(0.0)  # + 0 turns -0.0 into +0.0
        # a sum in float64 cannot overflow from float32 terms: it is finite iff every one is
        all_finite = bool(np.isfinite(v32.sum(dtype=np.float64)))
    finite_vertex = None if all_finite else np.all(np.isfinite(v32), axis=1)
    # a triangle soup (vertex i of triangle t is 3t + i, as the renderer builds) needs no gather
    soup = triangles.size == len(v32) and \
        np.array_equal(triangles.reshape(-1), np.arange(len(v32)))
    corners = v32.reshape(-1, 3, 3) if soup else np.take(v32, triangles, axis=0)
    keep = np.ones(input_count, bool)
    skipped_invalid = 0
    if not all_finite:
        keep = np.all(finite_vertex[triangles], axis=1)
        skipped_invalid = int(input_count - np.count_nonzero(keep))
        if skipped_invalid and on_invalid == "raise":
            bad_vertex = int(np.nonzero(~finite_vertex)[0][0])
            raise SceneError(f"{skipped_invalid} of {input_count} triangles use a NaN or infinite "
                             f"vertex (first: vertex {bad_vertex} = "
                             f"{vertices[bad_vertex].tolist()})")

    skipped_degenerate = 0
    if remove_degenerate and input_count:
        # per axis, from contiguous float64 copies (2D strided arithmetic costs 2x)
        e1, e2 = [], []
        for axis in range(3):
            p0 = corners[:, 0, axis].astype(np.float64)
            e1.append(corners[:, 1, axis] - p0)
            e2.append(corners[:, 2, axis] - p0)
        with np.errstate(invalid="ignore"):
            area = e1[1] * e2[2] != e1[2] * e2[1]
            area |= e1[2] * e2[0] != e1[0] * e2[2]
            area |= e1[0] * e2[1] != e1[1] * e2[0]
        skipped_degenerate = int(np.count_nonzero(keep & ~area))
        keep &= area

    removed_duplicates = 0
    if remove_duplicates and input_count > 1:
        # Exact twins share validity and area, so the first of a group survives the
        # other filters whenever any of it does.
        hashes = _vertex_hashes(v32)
        corner_hash = hashes.reshape(-1, 3) if soup else np.take(hashes, triangles)
        duplicate = _duplicate_mask(corners, corner_hash) & keep
        removed_duplicates = int(np.count_nonzero(duplicate))
        keep &= ~duplicate

    source = np.arange(input_count, dtype=np.int64)
    if not keep.all():
        corners, source = corners[keep], source[keep]
    return PreparedTriangles(np.ascontiguousarray(corners, np.float32), source, input_count,
                             skipped_invalid, skipped_degenerate, removed_duplicates)
