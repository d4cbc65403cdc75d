"""The visible points' hash grid (glrender/photon/grid.py): every point within a visible
point's radius finds it listed under its own cell, as the photon kernel looks it up."""
import numpy as np
import pytest

from glrender.photon.grid import build_grid, grid_hash


def lookup(grid, q):
    """The pixel indices listed under each query point's cell (the GLSL lookup in numpy)."""
    cell = np.floor((q - grid.lo) / grid.cell).astype(np.int64)
    inside = np.all((cell >= 0) & (cell < grid.size.astype(np.int64)), axis=1)
    h = grid_hash(np.clip(cell, 0, None)) % np.uint64(grid.table_size)
    ranges = np.stack([grid.cells[h], grid.cells[h + 1]], axis=1)
    return [set(grid.cells[a:b]) if ok else set() for (a, b), ok in zip(ranges, inside)]


@pytest.mark.parametrize("planar", [False, True])
def test01_points_within_radius_are_listed(planar):
    rng = np.random.default_rng(3)
    n = 2000
    p = rng.random((n, 3)) * (1.0, 1.0, 0.0 if planar else 1.0)
    r = rng.uniform(0.01, 0.05, n)
    grid = build_grid(p, r, np.arange(n, dtype=np.uint32))
    # queries on the spheres' surfaces (just inside) in random directions: the worst case
    k = rng.integers(0, n, 20000)
    d = rng.normal(size=(len(k), 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    q = p[k] + d * (r[k] * 0.999)[:, None]
    found = lookup(grid, q)
    missing = sum(int(i) not in f for i, f in zip(k, found))
    assert missing == 0, f"{missing} of {len(k)} points within a radius not listed in their cell"


def test02_empty_grid():
    grid = build_grid(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.uint32))
    assert grid.table_size == 0 and grid.max_cell_entries == 0


def test03_each_point_listed_once_per_hash():
    """Cells of one sphere that share a hash list it once (else a photon counts twice)."""
    rng = np.random.default_rng(4)
    n = 300
    p = rng.random((n, 3))
    grid = build_grid(p, rng.uniform(0.05, 0.2, n), np.arange(n, dtype=np.uint32))
    for h in range(grid.table_size):
        listed = grid.cells[grid.cells[h]:grid.cells[h + 1]]
        assert len(listed) == len(set(listed.tolist())), h
