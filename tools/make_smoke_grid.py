#!/usr/bin/env python3
"""Write scenes/smoke/plume.vol: a rising plume of smoke as a 40^3 density grid (Mitsuba's
.vol format), from a seeded sum of smooth noise octaves, so the scene's grid can be made
again exactly.

    .venv/bin/python tools/make_smoke_grid.py
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
N = 40


def smooth_noise(rng: np.random.Generator, n: int, cells: int) -> np.ndarray:
    """Values on a coarse lattice of ``cells``^3, trilinearly upsampled to n^3, in [0, 1]."""
    coarse = rng.random((cells + 1,) * 3)
    x = np.linspace(0, cells, n)
    i = np.minimum(x.astype(int), cells - 1)
    f = x - i
    out = coarse
    for axis in range(3):
        out = np.take(out, i, axis=axis) * (1 - f.reshape([-1 if a == axis else 1 for a in range(3)])) + \
            np.take(out, i + 1, axis=axis) * f.reshape([-1 if a == axis else 1 for a in range(3)])
    return out


def plume(n: int = N, seed: int = 11) -> np.ndarray:
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 3, indexing="ij")
    turb = sum(smooth_noise(rng, n, c) / c for c in (3, 6, 12)) / sum(1 / c for c in (3, 6, 12))
    # a column that rises from a source near the floor, leans and widens with height
    cx = 0.5 + 0.12 * np.sin(4.0 * y) + 0.08 * (turb - 0.5)
    cz = 0.5 + 0.06 * np.cos(5.0 * y)
    width = 0.07 + 0.22 * y
    column = np.exp(-(((x - cx) ** 2 + (z - cz) ** 2) / width ** 2))
    fade = np.clip(y / 0.08, 0, 1) * np.clip((1.0 - y) / 0.25, 0, 1)
    density = column * fade * (0.1 + 2.0 * turb ** 3) / (0.3 + 2.5 * y)
    return (density / density.max()).astype(np.float32)


def main() -> None:
    from glrender.scene.loaders.volumes import write_vol

    out = ROOT / "scenes" / "smoke" / "plume.vol"
    write_vol(out, plume()[..., None])
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
