"""Random and low-discrepancy sample generators: numpy twins of the GLSL ones.

Mirrors ``shaders/common/hash.glsl``, ``shaders/sampling/sobol.glsl``,
``shaders/sampling/stratified.glsl`` and ``shaders/sampling/sampler.glsl``
bit for bit (all arithmetic on uint32 arrays wraps modulo 2^32 as in GLSL), for
tests and for measuring discrepancy on the host.
"""
from __future__ import annotations

import functools
import math

import numpy as np

SAMPLERS = {"independent": 0, "stratified": 1, "sobol": 2}

_U32 = np.uint32
_REV8 = np.array([int(f"{b:08b}"[::-1], 2) for b in range(256)], np.uint32)


def _u32(x) -> np.ndarray:
    return np.asarray(x).astype(np.uint32)


def _wrapping(fn):
    """uint32 arithmetic wraps modulo 2^32 as in GLSL: silence numpy's scalar overflow warning."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with np.errstate(over="ignore"):
            return fn(*args, **kwargs)
    return wrapper


def bit_reverse(x) -> np.ndarray:
    x = _u32(x)
    return ((_REV8[x & 0xFF] << 24) | (_REV8[(x >> 8) & 0xFF] << 16) |
            (_REV8[(x >> 16) & 0xFF] << 8) | _REV8[x >> 24]).astype(np.uint32)


@_wrapping
def pcg_hash(v) -> np.ndarray:
    state = _u32(v) * _U32(747796405) + _U32(2891336453)
    word = ((state >> ((state >> _U32(28)) + _U32(4))) ^ state) * _U32(277803737)
    return (word >> _U32(22)) ^ word


@_wrapping
def pcg3d(x, y, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z = np.broadcast_arrays(_u32(x), _u32(y), _u32(z))
    a, b, c = 1664525, 1013904223, 16
    x = x * _U32(a) + _U32(b)
    y = y * _U32(a) + _U32(b)
    z = z * _U32(a) + _U32(b)
    x = x + y * z
    y = y + z * x
    z = z + x * y
    x, y, z = x ^ (x >> _U32(c)), y ^ (y >> _U32(c)), z ^ (z >> _U32(c))
    x = x + y * z
    y = y + z * x
    z = z + x * y
    return x, y, z


@_wrapping
def hash_combine(seed, v) -> np.ndarray:
    seed, v = _u32(seed), _u32(v)
    return pcg_hash(seed ^ (v + _U32(0x9E3779B9) + (seed << _U32(6)) + (seed >> _U32(2))))


def uint_to_unit_float(x) -> np.ndarray:
    return (_u32(x) >> _U32(8)).astype(np.float32) * np.float32(2.0 ** -24)


# -- Owen-scrambled Sobol' --------------------------------------------------------------
@_wrapping
def owen_mix_reversed(v, seed) -> np.ndarray:
    v, seed = _u32(v), _u32(seed)
    v = v ^ (v * _U32(0x3D20ADEA))
    v = v + seed
    v = v * ((seed >> _U32(16)) | _U32(1))
    v = v ^ (v * _U32(0x05526C56))
    v = v ^ (v * _U32(0x53A22864))
    return v


@_wrapping
def owen_scramble(v, seed) -> np.ndarray:
    return bit_reverse(owen_mix_reversed(bit_reverse(v), seed))


@_wrapping
def sobol_dim1_reversed(index) -> np.ndarray:
    x = _u32(index)
    for shift, mask in ((1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF),
                        (16, 0x0000FFFF)):
        x = x ^ ((x >> _U32(shift)) & _U32(mask))
    return x


def sobol_2d_bits(index) -> tuple[np.ndarray, np.ndarray]:
    return bit_reverse(index), bit_reverse(sobol_dim1_reversed(index))


@_wrapping
def owen_sobol_2d_bits(index, seeds) -> tuple[np.ndarray, np.ndarray]:
    i = owen_scramble(index, seeds[0])
    return (bit_reverse(owen_mix_reversed(i, seeds[1])),
            bit_reverse(owen_mix_reversed(sobol_dim1_reversed(i), seeds[2])))


def owen_sobol_2d(index, seeds) -> np.ndarray:
    x, y = owen_sobol_2d_bits(index, seeds)
    return np.stack([uint_to_unit_float(x), uint_to_unit_float(y)], axis=-1)


# -- stratified -----------------------------------------------------------------------------
@_wrapping
def permute_index(i, l, p) -> np.ndarray:
    """Kensler's hashed permutation of [0, l) at i (cycle walking capped at 32 steps)."""
    i, p = _u32(i).copy(), _u32(p)
    i, p = np.broadcast_arrays(i, p)
    i, p = i.copy(), p.copy()
    l = int(l)
    if l <= 1:
        return np.zeros_like(i)
    w = l - 1
    for s in (1, 2, 4, 8, 16):
        w |= w >> s
    w = _U32(w)
    start = i.copy()
    result = np.full_like(i, 0)
    done = np.zeros(i.shape, bool)
    for _ in range(32):
        i = i ^ p
        i = i * _U32(0xE170893D)
        i = i ^ (p >> _U32(16))
        i = i ^ ((i & w) >> _U32(4))
        i = i ^ (p >> _U32(8))
        i = i * _U32(0x0929EB3F)
        i = i ^ (p >> _U32(23))
        i = i ^ ((i & w) >> _U32(1))
        i = i * (_U32(1) | (p >> _U32(27)))
        i = i * _U32(0x6935FA69)
        i = i ^ ((i & w) >> _U32(11))
        i = i * _U32(0x74DCB303)
        i = i ^ ((i & w) >> _U32(2))
        i = i * _U32(0x9E501CC3)
        i = i ^ ((i & w) >> _U32(2))
        i = i * _U32(0xC860A3DF)
        i = i & w
        i = i ^ (i >> _U32(5))
        hit = (~done) & (i < _U32(l))
        result[hit] = ((i[hit].astype(np.uint64) + p[hit]) % l).astype(np.uint32)
        done |= hit
        if done.all():
            break
    result[~done] = start[~done] % _U32(l)
    return result


def strata_columns(n: int) -> int:
    """Columns of the 2D stratum grid for n samples: the largest divisor of n <= sqrt(n)."""
    n = max(int(n), 1)
    nx = math.isqrt(n)
    while n % nx:
        nx -= 1
    return nx


@_wrapping
def stratified_1d(i, n: int, seeds) -> np.ndarray:
    i = _u32(i)
    epoch = i // _U32(n)
    stratum = permute_index(i % _U32(n), n, hash_combine(seeds[0], epoch))
    jitter = uint_to_unit_float(hash_combine(seeds[1], i))
    return np.minimum((stratum.astype(np.float32) + jitter) / np.float32(n), np.float32(0.99999994))


@_wrapping
def stratified_2d(i, n: int, nx: int, seeds) -> np.ndarray:
    i = _u32(i)
    ny = n // nx
    epoch = i // _U32(n)
    stratum = permute_index(i % _U32(n), n, hash_combine(seeds[0], epoch))
    cell = np.stack([stratum % _U32(nx), stratum // _U32(nx)], axis=-1).astype(np.float32)
    hx, hy, _ = pcg3d(seeds[1], seeds[2], i)
    jitter = np.stack([uint_to_unit_float(hx), uint_to_unit_float(hy)], axis=-1)
    return np.minimum((cell + jitter) / np.array([nx, ny], np.float32), np.float32(0.99999994))


# -- the sampler ------------------------------------------------------------------------------
@_wrapping
def pixel_hash(px, py, seed) -> np.ndarray:
    return hash_combine(hash_combine(pcg_hash(seed), px), py)


@_wrapping
def dimension_seeds(pixel_hash_value, dim):
    return pcg3d(pixel_hash_value, dim, 0x5BD1E995)


@_wrapping
def sample_2d(sampler: str, pixel_hash_value, index, dim, count: int = 1,
              columns: int | None = None) -> np.ndarray:
    """The values sampler_2d returns for (pixel hash, sample index, dimension)."""
    kind = SAMPLERS[sampler]
    pixel_hash_value, index, dim = np.broadcast_arrays(_u32(pixel_hash_value), _u32(index), _u32(dim))
    if kind == SAMPLERS["sobol"]:
        return owen_sobol_2d(index, dimension_seeds(pixel_hash_value, dim))
    if kind == SAMPLERS["stratified"]:
        columns = columns or strata_columns(count)
        return stratified_2d(index, count, columns, dimension_seeds(pixel_hash_value, dim))
    hx, hy, _ = pcg3d(pixel_hash_value, index, dim)
    return np.stack([uint_to_unit_float(hx), uint_to_unit_float(hy)], axis=-1)


@_wrapping
def sample_1d(sampler: str, pixel_hash_value, index, dim, count: int = 1) -> np.ndarray:
    """The value sampler_1d returns for (pixel hash, sample index, dimension)."""
    kind = SAMPLERS[sampler]
    pixel_hash_value, index, dim = np.broadcast_arrays(_u32(pixel_hash_value), _u32(index), _u32(dim))
    if kind == SAMPLERS["sobol"]:
        return owen_sobol_2d(index, dimension_seeds(pixel_hash_value, dim))[..., 0]
    if kind == SAMPLERS["stratified"]:
        return stratified_1d(index, count, dimension_seeds(pixel_hash_value, dim))
    return uint_to_unit_float(pcg3d(pixel_hash_value, index, dim)[0])


# -- discrepancy ---------------------------------------------------------------------------------
def l2_star_discrepancy(points: np.ndarray) -> float:
    """Warnock's closed form of the L2 star discrepancy of points in [0,1)^d."""
    x = np.asarray(points, np.float64)
    n, d = x.shape
    term1 = 3.0 ** -d
    term2 = np.prod((1.0 - x ** 2) / 2.0, axis=1).sum() * 2.0 / n
    pairwise = np.ones((n, n))
    for k in range(d):
        pairwise *= 1.0 - np.maximum(x[:, None, k], x[None, :, k])
    term3 = pairwise.sum() / n ** 2
    return math.sqrt(max(term1 - term2 + term3, 0.0))
