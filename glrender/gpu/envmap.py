"""The environment map's importance table, sized to the device.

The table is a piecewise-constant density over the map's (u, v) square: luminance x
sin(theta) per texel, dilated to the 3x3 neighbourhood maximum (u wraps) so that every
direction the bilinear lookup lights has pdf > 0. Its cells need not be the image's
texels: sampling and pdf evaluation use the table's own resolution, so a large map gets
a coarser table (each cell the maximum of a block of texels, which keeps the pdf > 0
wherever the image is bright) and stays unbiased; only the match between pdf and
radiance within a block is lost. ``MAX_CELLS`` keeps the table (density plus CDFs,
about 8 bytes per cell) far below a device's 128 MiB storage-buffer limit.
"""
from __future__ import annotations

import numpy as np

from ..errors import SceneError

MAX_CELLS = 1 << 22           # 4M cells (e.g. 2048 x 2048): 32 MiB of table
LUMINANCE = np.array([0.212671, 0.715160, 0.072169], np.float32)


def importance_weights(image: np.ndarray, max_cells: int | None = None) -> np.ndarray:
    """Non-negative weights (rows = v, columns = u) proportional to the sampling density."""
    max_cells = MAX_CELLS if max_cells is None else max_cells
    h, w = image.shape[:2]
    lum = image[..., :3] @ LUMINANCE
    padded = np.pad(lum, ((1, 1), (1, 1)), mode="edge")
    padded[:, 0], padded[:, -1] = padded[:, -2], padded[:, 1]   # u wraps around
    dil = np.max([padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)], axis=0)
    rows = np.sin((np.arange(h) + 0.5) / h * np.pi)
    if h * w > max_cells:
        # blocks of f x f texels, the last ones padded by repeating the edge: each cell is
        # its block's maximum; sin(theta) at the block's largest texel row keeps the
        # weight > 0 wherever a texel of the block has one
        f = int(np.ceil(np.sqrt(h * w / max_cells)))
        hp, wp = -(-h // f) * f, -(-w // f) * f
        dil = np.pad(dil, ((0, hp - h), (0, wp - w)), mode="edge")
        dil = dil.reshape(hp // f, f, wp // f, f).max(axis=(1, 3))
        rows = np.pad(rows, (0, hp - h), mode="edge").reshape(hp // f, f).max(axis=1)
    weights = dil * rows[:, None]
    if not weights.sum() > 0:
        weights = np.ones_like(weights) * rows[:, None]
    return weights.astype(np.float32)


def check_texture_size(image: np.ndarray, max_size: int, where: str) -> None:
    """A map wider or taller than the device's largest texture is refused, by name."""
    h, w = image.shape[:2]
    if w > max_size or h > max_size:
        raise SceneError(f"{where}: the environment image is {w} x {h} pixels; this device's "
                         f"textures hold at most {max_size} x {max_size} (resample it)")
