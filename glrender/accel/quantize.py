"""Compressed 4-wide nodes: child boxes quantised to 8 bits per plane.

The traversal on llvmpipe is bound by memory traffic, so a node is one 64-byte
record (4 rgba32ui texels) instead of 112 bytes of float boxes (cf. Ylitie,
Karras & Laine 2017, "Efficient incoherent ray traversal on GPUs through
compressed wide BVHs"):

===========  ===============================================================
texel 0      origin p.xyz (float bits), w = biased exponents e.x | e.y << 8 | e.z << 16
texel 1      the four child references (see :mod:`glrender.accel.bvh`)
texel 2      per child (byte k = child k): q_lo.x, q_hi.x, q_lo.y, q_hi.y
texel 3      q_lo.z, q_hi.z, 0, 0
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

TEXELS_PER_NODE = 4
EXPONENT_BIAS = 127
_MAX_FIX_STEPS = 4


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


def _per_child(node_values: np.ndarray) -> np.ndarray:
    """(N, 3) per-node values repeated for the four children: (N, 4, 3), contiguous."""
    return np.repeat(node_values[:, None, :], 4, axis=1)


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


def quantize_planes(lo: np.ndarray, hi: np.ndarray, valid: np.ndarray,
                    origin: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward-rounded 8-bit planes of boxes ``lo``/``hi`` (N, 4, 3) in their node's grid."""
    # per plane, in full (N, 4, 3) copies: broadcasting the (N, 1, 3) node values would
    # make numpy's inner loops 3 elements long (2-5x slower); these coalesce into one
    p, s = _per_child(origin), _per_child(scale)
    valid3 = np.repeat(valid, 3, axis=1).reshape(lo.shape)
    # s is a power of two: multiplying by 1 / s (exact in float64) is the division, faster
    inv = 1.0 / s.astype(np.float64)
    with np.errstate(invalid="ignore"):
        qlo = np.floor((lo.astype(np.float64) - p) * inv)
        qhi = np.ceil((hi.astype(np.float64) - p) * inv)
    qlo = np.clip(np.where(valid3, qlo, 255), 0, 255).astype(np.float32)
    qhi = np.clip(np.where(valid3, qhi, 0), 0, 255).astype(np.float32)
    for _ in range(_MAX_FIX_STEPS):  # fix rounding, outwards: the exact planes contain the box
        over = valid3 & (exact_sign(p, qlo * s, lo) > 0)
        under = valid3 & (exact_sign(p, qhi * s, hi) < 0)
        if not (over.any() or under.any()):
            break
        qlo = np.where(over, qlo - 1, qlo)
        qhi = np.where(under, qhi + 1, qhi)
    return qlo.astype(np.uint32), qhi.astype(np.uint32)


def decode_planes(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Child boxes (N, 4, 3) as the shader decodes them from packed (4N, 4) uint32 nodes."""
    n = len(nodes) // TEXELS_PER_NODE
    rec = nodes.reshape(n, TEXELS_PER_NODE, 4)
    p = rec[:, 0, :3].copy().view(np.float32)
    e = np.stack([(rec[:, 0, 3] >> (8 * a)) & 255 for a in range(3)], axis=1).astype(np.int64)
    s = _pow2(e - EXPONENT_BIAS)
    words = np.stack([rec[:, 2, 0], rec[:, 2, 2], rec[:, 3, 0],
                      rec[:, 2, 1], rec[:, 2, 3], rec[:, 3, 1]], axis=1)  # lo xyz, hi xyz
    q = np.stack([(words >> (8 * k)) & 255 for k in range(4)], axis=1).astype(np.float32)  # (N,4,6)
    lo = p[:, None, :] + q[..., :3] * s[:, None, :]
    hi = p[:, None, :] + q[..., 3:] * s[:, None, :]
    return lo.astype(np.float32), hi.astype(np.float32)


def pack_nodes(child_lo: np.ndarray, child_hi: np.ndarray, valid: np.ndarray,
               refs: np.ndarray) -> np.ndarray:
    """Packed nodes (4N, 4) uint32 from child boxes (N, 4, 3), validity (N, 4), refs (N, 4)."""
    n = len(valid)
    valid3 = np.repeat(valid, 3, axis=1).reshape(child_lo.shape)   # not broadcast: see above
    lo = np.where(valid3, child_lo, np.float32(np.inf)).astype(np.float32)
    hi = np.where(valid3, child_hi, np.float32(-np.inf)).astype(np.float32)
    # over the 4 children: slice by slice (a reduction over a short axis is 4x slower)
    origin = np.minimum(np.minimum(lo[:, 0], lo[:, 1]), np.minimum(lo[:, 2], lo[:, 3]))
    top = np.maximum(np.maximum(hi[:, 0], hi[:, 1]), np.maximum(hi[:, 2], hi[:, 3]))
    empty = ~np.isfinite(origin)
    origin = np.where(empty, 0, origin).astype(np.float32)
    top = np.where(empty, 0, top).astype(np.float32)
    e = node_exponents(origin, top)
    qlo, qhi = quantize_planes(lo, hi, valid, origin, _pow2(e))
    def word(q):        # (N, 3): byte k = child k
        return q[:, 0] | (q[:, 1] << np.uint32(8)) | (q[:, 2] << np.uint32(16)) | (q[:, 3] << np.uint32(24))
    wlo, whi = word(qlo), word(qhi)
    out = np.zeros((n, TEXELS_PER_NODE, 4), np.uint32)
    out[:, 0, :3] = origin.view(np.uint32)
    biased = (e + EXPONENT_BIAS).astype(np.uint32)
    out[:, 0, 3] = biased[:, 0] | (biased[:, 1] << 8) | (biased[:, 2] << 16)
    out[:, 1] = refs
    out[:, 2] = np.stack([wlo[:, 0], whi[:, 0], wlo[:, 1], whi[:, 1]], axis=1)
    out[:, 3, 0], out[:, 3, 1] = wlo[:, 2], whi[:, 2]
    return out.reshape(n * TEXELS_PER_NODE, 4)
