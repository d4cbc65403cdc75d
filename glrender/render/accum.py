"""The renderer's exact accumulation on the host (the twin of shaders/film/accum.glsl).

Every sample value is added on the device as a 128-bit two's-complement fixed-point
number with ``FRACTION`` fractional bits, stored as four little-endian 32-bit words. Sums
of integers do not depend on the order or grouping of the additions, so accumulations of
disjoint sample ranges (passes, dispatches, units of a distributed render) add up to
the same bits as one accumulation of all of them: :func:`add` is that addition.

Per pixel (``Renderer.state()``): ``sums`` (N, 4, 4) words — the sums of r, g, b and
(finite count, dropped count, truncated paths, 0); ``squares`` (N, 3, 4) — the sums of squares;
``aov`` (N, 10, 4) — the sums of albedo rgb, normal xyz, depth and seen emission rgb
(AOV renders; :func:`aov_images` names them).
:func:`statistics` turns them into the mean, M2 and counts a :class:`Film` holds, in
float64 rounded to float32: a pure function of the integers.
"""
from __future__ import annotations

import numpy as np

FRACTION = 48                 # kAccumFraction
LIMIT = float(2 ** 30)        # kAccumLimit: samples with a component this large are dropped
AOV_CHANNELS = 10             # kAovChannels: albedo rgb, normal xyz, depth, emission rgb


def add(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a + b for arrays of 128-bit words (..., 4) uint32, modulo 2^128 (exact)."""
    a64 = np.ascontiguousarray(a, np.uint32).view(np.uint64)   # (..., 2): low, high halves
    b64 = np.ascontiguousarray(b, np.uint32).view(np.uint64)
    out = np.empty_like(a64)
    lo = a64[..., 0] + b64[..., 0]
    carry = (lo < a64[..., 0]).astype(np.uint64)
    out[..., 0] = lo
    out[..., 1] = a64[..., 1] + b64[..., 1] + carry
    return out.view(np.uint32)


def add_counts(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The sums block of two accumulations added: 128-bit channel sums and the counts word."""
    out = add(a, b)
    out[..., 3, :] = a[..., 3, :] + b[..., 3, :]   # counts: plain 32-bit integers
    return out


def fixed_sums(words: np.ndarray) -> np.ndarray:
    """Signed 64-bit fixed-point sums (the splat and photon-view buffers, in units of
    1/SPLAT_SCALE) from their (low, high) uint32 word pairs."""
    pairs = np.asarray(words, np.uint32).reshape(-1, 2).astype(np.uint64)
    return ((pairs[:, 1] << np.uint64(32)) | pairs[:, 0]).view(np.int64)


def values(words: np.ndarray) -> np.ndarray:
    """128-bit fixed-point words (..., 4) as float64 values (...)."""
    w = np.ascontiguousarray(words, np.uint32).view(np.uint64)
    hi = w[..., 1].view(np.int64).astype(np.float64)
    lo = w[..., 0].astype(np.float64)
    return hi * 2.0 ** (64 - FRACTION) + lo * 2.0 ** -FRACTION


def fixed(x) -> np.ndarray:
    """Values as 128-bit fixed-point words (..., 4), vectorized: the nearest multiple of
    2^-FRACTION, ties away from zero, as the device converts its float32 samples. Exact
    for float32 and float64 values of magnitude below 2^(127 - FRACTION) (the scaled
    value, its floor and fraction are exact in float64; beyond 2^53 it is an integer)."""
    x = np.asarray(x)
    x = x.astype(np.float64) if x.dtype != np.float64 else x
    a = np.abs(x) * 2.0 ** FRACTION                 # exact: a power-of-two scale
    q = np.floor(a)
    q += a - q >= 0.5
    hi = np.floor(q / 2.0 ** 64)
    lo = q - hi * 2.0 ** 64                          # exact: the bits of q below 2^64
    words = np.stack([lo.astype(np.uint64), hi.astype(np.uint64)], axis=-1).view(np.uint32)
    negative = x < 0
    if negative.any():
        one = np.zeros(4, np.uint32)
        one[0] = 1
        words[negative] = add(~words[negative], one)
    return words


def aov_images(means: np.ndarray, height: int, width: int) -> dict[str, np.ndarray]:
    """The first-hit AOV images from their per-pixel means (N, AOV_CHANNELS) (rows top to
    bottom): albedo, normal, emission (H, W, 3) and depth (H, W)."""
    a = np.asarray(means, np.float32).reshape(height, width, AOV_CHANNELS)
    return {"albedo": a[..., 0:3].copy(), "normal": a[..., 3:6].copy(),
            "depth": a[..., 6].copy(), "emission": a[..., 7:10].copy()}


def truncated(sums: np.ndarray) -> np.ndarray:
    """(N,) uint32: per pixel, the paths a depth cap cut short (the counts word's third
    entry; see ``integrators/integrator_common.glsl``, g_truncated_paths)."""
    return np.asarray(sums, np.uint32).reshape(-1, 4, 4)[:, 3, 2].copy()


def statistics(sums: np.ndarray, squares: np.ndarray, aov: np.ndarray | None = None):
    """(mean (N, 3), M2 (N, 3), count (N,), dropped (N,), aovs (N, AOV_CHANNELS) or None), float32.

    mean = S / n and M2 = Q - S^2 / n (at least 0) in float64 from the exact sums."""
    sums = np.asarray(sums, np.uint32).reshape(-1, 4, 4)
    n = sums[:, 3, 0].astype(np.float64)
    dropped = sums[:, 3, 1].astype(np.float32)
    safe = np.where(n > 0, n, 1.0)[:, None]
    s = values(sums[:, :3])
    q = values(np.asarray(squares, np.uint32).reshape(-1, 3, 4))
    mean = s / safe
    m2 = np.maximum(q - s * mean, 0.0)
    means = None
    if aov is not None:
        means = (values(np.asarray(aov, np.uint32).reshape(-1, AOV_CHANNELS, 4)) / safe
                 ).astype(np.float32)
    return mean.astype(np.float32), m2.astype(np.float32), n.astype(np.float32), dropped, means
