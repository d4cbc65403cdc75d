"""The hash grid over SPPM's visible points, built in vectorised numpy.

Every visible point is listed in each cell of a uniform grid that its search sphere
overlaps; the cell edge is the largest radius (pbrt-v3's choice), so a sphere spans at
most three cells along each axis (27 in all; a sphere of diameter 2 r straddles the
cell boundaries on both sides of its centre's cell). Cells are stored by spatial hash (Teschner et al.
2003, the hash of ``shaders/common/hash.glsl`` grid_hash) in a table with one slot per
visible point: ``cells[h] .. cells[h + 1]`` are the positions in ``cells`` of the pixel
indices listed under hash ``h``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_PRIMES = np.array([73856093, 19349663, 83492791], np.uint64)
_MASK = np.uint64(0xFFFFFFFF)
# spheres are listed with this much slack, so a float32 cell lookup on the device
# near a cell boundary finds the points a float64 one would
_SLACK = 1e-3


@dataclass
class HashGrid:
    cells: np.ndarray        # uint32: table_size + 1 offsets, then pixel indices
    size: np.ndarray         # cells along x, y, z (uint32)
    table_size: int          # 0: no grid (no visible points)
    lo: np.ndarray           # corner of cell (0, 0, 0)
    cell: float              # cell edge length

    @property
    def max_cell_entries(self) -> int:
        """The most pixel indices listed under one hash (what one photon may visit)."""
        if self.table_size == 0:
            return 0
        return int(np.diff(self.cells[:self.table_size + 1]).max())


def grid_hash(cell: np.ndarray) -> np.ndarray:
    """The 32-bit spatial hash of integer cell coordinates (N, 3), as in GLSL's grid_hash."""
    c = cell.astype(np.uint64) * _PRIMES
    return (c[:, 0] ^ c[:, 1] ^ c[:, 2]) & _MASK


def build_grid(positions: np.ndarray, radius: np.ndarray, pixels: np.ndarray) -> HashGrid:
    """The grid over points ``positions`` (N, 3) with search radii ``radius`` (N,),
    listing their ``pixels`` (N,) indices."""
    n = len(positions)
    if n == 0:
        return HashGrid(np.zeros(2, np.uint32), np.zeros(3, np.uint32), 0, np.zeros(3), 1.0)
    p = np.asarray(positions, np.float64)
    r = np.asarray(radius, np.float64)[:, None] * (1 + _SLACK)
    cell = float(r.max())
    lo = (p - r).min(axis=0) - _SLACK * cell
    hi = (p + r).max(axis=0)
    size = np.minimum(np.floor((hi - lo) / cell).astype(np.int64) + 1, 1 << 30)
    c0 = np.clip(np.floor((p - r - lo) / cell).astype(np.int64), 0, size - 1)
    c1 = np.clip(np.floor((p + r - lo) / cell).astype(np.int64), 0, size - 1)
    hashes, owners = [], []
    for offset in np.ndindex(3, 3, 3):
        c = c0 + np.array(offset)
        keep = np.all(c <= c1, axis=1)
        hashes.append(grid_hash(c[keep]) % np.uint64(n))
        owners.append(np.asarray(pixels)[keep])
    # one entry per (hash, pixel): two cells of one sphere that share a hash must not
    # list it twice (a photon there would be counted twice)
    keys = np.sort((np.concatenate(hashes) << np.uint64(32)) | np.concatenate(owners).astype(np.uint64))
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]   # (np.unique's hash path: 100x slower)
    h = (keys >> np.uint64(32)).astype(np.int64)
    entries = (keys & _MASK).astype(np.uint32)
    counts = np.bincount(h, minlength=n)
    offsets = (n + 1) + np.concatenate([[0], np.cumsum(counts)])
    cells = np.concatenate([offsets.astype(np.uint32), entries])
    return HashGrid(cells, size.astype(np.uint32), n, lo, cell)


@dataclass
class PointGrid:
    """A hash grid over points, each listed once, in the cell holding it: ``order`` sorts
    the points by hash, and ``offsets[h] .. offsets[h + 1]`` are the sorted positions of
    the points under hash ``h`` (a table of ``table_size`` hashes; other cells with the
    same hash included: the lookup checks distances). A lookup of radius at most
    ``cell / 2`` visits the 2 x 2 x 2 cells around its point
    (``shaders/photon/photon_gather.glsl``)."""

    order: np.ndarray        # int64 (N,): point indices in the grid's order
    offsets: np.ndarray      # uint32 (table_size + 1,)
    size: np.ndarray         # cells along x, y, z (uint32)
    table_size: int          # 0: no grid (no points)
    lo: np.ndarray           # corner of cell (0, 0, 0)
    cell: float              # cell edge length

    @property
    def max_cell_entries(self) -> int:
        """The most points listed under one hash."""
        return int(np.diff(self.offsets).max()) if self.table_size else 0


def stable_argsort_u32(values: np.ndarray) -> np.ndarray:
    """np.argsort(values, kind="stable") for unsigned 32-bit values, 3-4x sooner: two
    passes of numpy's radix sort over the 16-bit halves (low half first)."""
    a = np.asarray(values, np.uint32)
    low = np.argsort((a & np.uint32(0xFFFF)).astype(np.uint16), kind="stable")
    high = np.argsort((a[low] >> np.uint32(16)).astype(np.uint16), kind="stable")
    return low[high]


def build_point_grid(positions: np.ndarray, radius: float) -> PointGrid:
    """The grid over ``positions`` (N, 3) for lookups of radius up to ``radius``: cell
    edge 2 radius (with the grid's slack), a table of N hashes."""
    n = len(positions)
    if n == 0:
        return PointGrid(np.zeros(0, np.int64), np.zeros(2, np.uint32), np.zeros(3, np.uint32), 0,
                         np.zeros(3), 1.0)
    p = np.asarray(positions, np.float64)
    cell = 2.0 * float(radius) * (1 + _SLACK)
    lo = p.min(axis=0) - _SLACK * cell
    size = np.minimum(np.floor((p.max(axis=0) - lo) / cell).astype(np.int64) + 1, 1 << 30)
    c = np.clip(np.floor((p - lo) / cell).astype(np.int64), 0, size - 1)
    h = (grid_hash(c) % np.uint64(n)).astype(np.int64)
    order = stable_argsort_u32(h).astype(np.int64)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(h, minlength=n))]).astype(np.uint32)
    return PointGrid(order, offsets, size.astype(np.uint32), n, lo, cell)


def typical_radius(positions: np.ndarray, k: int, queries: int = 128, subset: int = 1 << 15,
                   dims: int = 2, quantile: float = 0.5) -> float:
    """The radius of a disk around a typical point of ``positions`` (N, 3) that holds ``k``
    of them: the median over ``queries`` points (a fixed pseudo-random choice) of the
    distance to the k-th nearest, found among ``subset`` of the points and scaled to all
    of them (a surface density: the count grows with r^2; ``dims`` 3: a ball's in a volume,
    r^3); ``quantile``: that quantile of the distances instead of the median. 0 for fewer
    than 2 points."""
    n = len(positions)
    if n < 2:
        return 0.0
    rng = np.random.default_rng(0x5eed)
    p = np.asarray(positions, np.float32)
    q = p[rng.choice(n, size=min(queries, n), replace=False)]
    s = p[rng.choice(n, size=min(subset, n), replace=False)]
    scale = len(s) / n
    kk = int(min(len(s) - 1, max(1, round(k * scale))))
    d2 = ((q[:, None, :] - s[None, :, :]) ** 2).sum(axis=-1)
    # the query itself may be in the subset at distance 0: take the kk-th after it
    dk = np.sqrt(np.partition(d2, kk, axis=1)[:, kk].astype(np.float64))
    ratio = k * scale / kk
    typical = np.median(dk) if quantile == 0.5 else np.quantile(dk, quantile)
    return float(typical * (math.sqrt(ratio) if dims == 2 else ratio ** (1.0 / dims)))
