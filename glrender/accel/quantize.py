"""Compressed wide nodes: child boxes quantised to 8 bits per plane.

The traversal on llvmpipe is bound by memory traffic, so a 4-wide node is one
64-byte record (4 rgba32ui texels) instead of 112 bytes of float boxes (cf. Ylitie,
Karras & Laine 2017, "Efficient incoherent ray traversal on GPUs through
compressed wide BVHs"), and an 8-wide node one 96-byte record (6 texels)
instead of 224 bytes. Width 4 (what the GLSL traversal reads):

===========  ===============================================================
texel 0      origin p.xyz (float bits), w = biased exponents e.x | e.y << 8 | e.z << 16
texel 1      the four child references (see :mod:`glrender.accel.bvh`)
texel 2      per child (byte k = child k): q_lo.x, q_hi.x, q_lo.y, q_hi.y
texel 3      q_lo.z, q_hi.z, 0, 0
===========  ===============================================================

Width 8:

===========  ===============================================================
texel 0      origin and exponents, as for width 4
texel 1      child references 0..3
texel 2      child references 4..7
texel 3      q_lo.x of children 0-3 (byte k = child k), q_lo.x of children 4-7
             (byte k = child 4 + k), q_hi.x of children 0-3, q_hi.x of children 4-7
texel 4      the same for y
texel 5      the same for z
===========  ===============================================================

A plane decodes as ``p + q * 2^e`` with ``q`` in 0..255: ``q * 2^e`` is exact.
Every plane is rounded outwards so that the exact real ``p + q * 2^e`` (which the
traversal's fused slab test, geometry/bvh.glsl, works from) and so also its
float32 rounding contain the child's float box, and the slab test stays as
conservative as with float boxes (watertight traversal is kept). Empty slots decode to an inverted box
(``q_lo = 255 > q_hi = 0``) that no ray can enter.
"""
from __future__ import annotations

import numpy as np

_TEXELS_BY_WIDTH = {4: 4, 8: 6}
EXPONENT_BIAS = 127
_MAX_FIX_STEPS = 4


def texels_per_node(width: int) -> int:
    """rgba32ui texels of one packed node of ``width`` children (4 -> 4, 8 -> 6)."""
    try:
        return _TEXELS_BY_WIDTH[width]
    except KeyError:
        raise ValueError(f"node width must be one of {tuple(_TEXELS_BY_WIDTH)}, got {width}") from None


def _pow2(e: np.ndarray) -> np.ndarray:
    return np.ldexp(np.float32(1.0), e).astype(np.float32)


def node_exponents(origin: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Per node and axis the smallest exponent e with ``origin + 255 * 2^e >= top`` in float32.

    The scale is also at least a few ulps of ``origin`` so that the 256 levels
    are distinct even for a flat (zero-extent) node.
    """
    extent = top.astype(np.float64) - origin
    with np.errstate(divide="ignore"):
        e = np.ceil(np.log2(np.maximum(extent, 1e-300) / 255.0))
        e_ulp = np.floor(np.log2(np.maximum(np.abs(origin.astype(np.float64)), 1e-300))) - 22
    e = np.clip(np.maximum(e, e_ulp), -126, 127).astype(np.int64)
    for _ in range(_MAX_FIX_STEPS):  # float32 rounding of origin + 255 * 2^e
        short = (origin + np.float32(255.0) * _pow2(e)) < top
        if not short.any():
            break
        e = np.where(short & (e < 127), e + 1, e)
    return e


def _per_child(node_values: np.ndarray, width: int) -> np.ndarray:
    """(N, 3) per-node values repeated for the children: (N, width, 3), contiguous."""
    return np.repeat(node_values[:, None, :], width, axis=1)


def _fold(op, x: np.ndarray) -> np.ndarray:
    """``op`` over axis 1 of (N, width, 3) as a pairwise tree of slices (a reduction over
    a short axis is 4x slower): op(op(x0, x1), op(x2, x3)) for width 4."""
    parts = [x[:, k] for k in range(x.shape[1])]
    while len(parts) > 1:
        parts = [op(parts[k], parts[k + 1]) for k in range(0, len(parts), 2)]
    return parts[0]


def _bytes4(q: np.ndarray) -> np.ndarray:
    """(N, 4, ...) values 0..255 -> (N, ...) uint32 words, byte k = q[:, k]."""
    return q[:, 0] | (q[:, 1] << np.uint32(8)) | (q[:, 2] << np.uint32(16)) | (q[:, 3] << np.uint32(24))


def exact_sign(p: np.ndarray, qs: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """Sign of the exact real ``p + qs - bound`` for float32 arrays (qs = q * 2^e, exact).

    The float64 sum x is exact or off by the two-sum error r (Knuth), itself exact:
    ``p + qs = x + r``. A plane contained by this test is contained both as the exact
    real the traversal's fused decode uses and as its float32 rounding (rounding is
    monotonic and ``bound`` is a float32).
    """
    a, b = p.astype(np.float64), qs.astype(np.float64)
    x = a + b
    bb = x - a
    r = (a - (x - bb)) + (b - bb)
    c = bound.astype(np.float64)
    return np.where(x != c, np.sign(x - c), np.sign(r))


def _planes(lo: np.ndarray, hi: np.ndarray, p: np.ndarray, s: np.ndarray,
            valid3: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Outward-rounded planes (float32 0..255) of boxes ``lo``/``hi`` given each one's origin
    ``p`` and scale ``s`` (arrays of one shape); where ``valid3`` is False: 255 and 0."""
    # s is a power of two: multiplying by 1 / s (exact in float64) is the division, faster
    inv = 1.0 / s.astype(np.float64)
    with np.errstate(invalid="ignore"):
        qlo = np.floor((lo.astype(np.float64) - p) * inv)
        qhi = np.ceil((hi.astype(np.float64) - p) * inv)
    if valid3 is not None:
        qlo, qhi = np.where(valid3, qlo, 255), np.where(valid3, qhi, 0)
    qlo = np.clip(qlo, 0, 255).astype(np.float32)
    qhi = np.clip(qhi, 0, 255).astype(np.float32)
    for _ in range(_MAX_FIX_STEPS):  # fix rounding, outwards: the exact planes contain the box
        over = exact_sign(p, qlo * s, lo) > 0
        under = exact_sign(p, qhi * s, hi) < 0
        if valid3 is not None:
            over &= valid3
            under &= valid3
        if not (over.any() or under.any()):
            break
        qlo = np.where(over, qlo - 1, qlo)
        qhi = np.where(under, qhi + 1, qhi)
    return qlo, qhi


def quantize_planes(lo: np.ndarray, hi: np.ndarray, valid: np.ndarray,
                    origin: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward-rounded 8-bit planes of boxes ``lo``/``hi`` (N, width, 3) in their node's grid;
    empty slots get ``q_lo = 255``, ``q_hi = 0``."""
    if 3 * np.count_nonzero(valid) <= 2 * valid.size:
        # mostly empty slots (8-wide trees: about half): gather the valid ones, with their
        # node's origin and scale as (M, 3) rows, and scatter the planes back
        rows, cols = np.nonzero(valid)
        qlo, qhi = _planes(lo[rows, cols], hi[rows, cols], origin[rows], scale[rows], None)
        out_lo, out_hi = np.full(lo.shape, 255, np.uint32), np.zeros(hi.shape, np.uint32)
        out_lo[rows, cols], out_hi[rows, cols] = qlo, qhi
        return out_lo, out_hi
    # per plane, in full (N, width, 3) copies: broadcasting the (N, 1, 3) node values would
    # make numpy's inner loops 3 elements long (2-5x slower); these coalesce into one
    p, s = _per_child(origin, lo.shape[1]), _per_child(scale, lo.shape[1])
    valid3 = np.repeat(valid, 3, axis=1).reshape(lo.shape)
    qlo, qhi = _planes(lo, hi, p, s, valid3)
    return qlo.astype(np.uint32), qhi.astype(np.uint32)


def decode_planes(nodes: np.ndarray, width: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Child boxes (N, width, 3) as the traversal decodes them from packed
    (texels_per_node(width) N, 4) uint32 nodes."""
    t = texels_per_node(width)
    n = len(nodes) // t
    rec = nodes.reshape(n, t, 4)
    p = rec[:, 0, :3].copy().view(np.float32)
    e = np.stack([(rec[:, 0, 3] >> (8 * a)) & 255 for a in range(3)], axis=1).astype(np.int64)
    s = _pow2(e - EXPONENT_BIAS)
    if width == 4:
        words = np.stack([rec[:, 2, 0], rec[:, 2, 2], rec[:, 3, 0],
                          rec[:, 2, 1], rec[:, 2, 3], rec[:, 3, 1]], axis=1)[:, None]  # lo xyz, hi xyz
    else:  # (N, 2, 6): children 0-3 and 4-7
        words = np.stack([np.concatenate([rec[:, 3:6, g], rec[:, 3:6, 2 + g]], axis=1)
                          for g in range(2)], axis=1)
    q = np.stack([(words >> (8 * k)) & 255 for k in range(4)], axis=2)  # (N, groups, 4, 6)
    q = q.reshape(n, width, 6).astype(np.float32)
    lo = p[:, None, :] + q[..., :3] * s[:, None, :]
    hi = p[:, None, :] + q[..., 3:] * s[:, None, :]
    return lo.astype(np.float32), hi.astype(np.float32)


def pack_nodes(child_lo: np.ndarray, child_hi: np.ndarray, valid: np.ndarray,
               refs: np.ndarray) -> np.ndarray:
    """Packed nodes (texels_per_node(width) N, 4) uint32 from child boxes (N, width, 3),
    validity (N, width) and references (N, width), width 4 or 8."""
    n, width = valid.shape
    t = texels_per_node(width)
    valid3 = np.repeat(valid, 3, axis=1).reshape(child_lo.shape)   # not broadcast: see above
    lo = np.where(valid3, child_lo, np.float32(np.inf)).astype(np.float32)
    hi = np.where(valid3, child_hi, np.float32(-np.inf)).astype(np.float32)
    origin, top = _fold(np.minimum, lo), _fold(np.maximum, hi)
    empty = ~np.isfinite(origin)
    origin = np.where(empty, 0, origin).astype(np.float32)
    top = np.where(empty, 0, top).astype(np.float32)
    e = node_exponents(origin, top)
    qlo, qhi = quantize_planes(lo, hi, valid, origin, _pow2(e))
    out = np.zeros((n, t, 4), np.uint32)
    out[:, 0, :3] = origin.view(np.uint32)
    biased = (e + EXPONENT_BIAS).astype(np.uint32)
    out[:, 0, 3] = biased[:, 0] | (biased[:, 1] << 8) | (biased[:, 2] << 16)
    if width == 4:
        wlo, whi = _bytes4(qlo), _bytes4(qhi)  # (N, 3): byte k = child k
        out[:, 1] = refs
        out[:, 2] = np.stack([wlo[:, 0], whi[:, 0], wlo[:, 1], whi[:, 1]], axis=1)
        out[:, 3, 0], out[:, 3, 1] = wlo[:, 2], whi[:, 2]
    else:
        out[:, 1:3] = refs.reshape(n, 2, 4)
        for g in range(2):  # children 4g..4g+3: (N, 3) words per axis
            out[:, 3:6, g] = _bytes4(qlo[:, 4 * g:4 * g + 4])
            out[:, 3:6, 2 + g] = _bytes4(qhi[:, 4 * g:4 * g + 4])
    return out.reshape(n * t, 4)
