"""Strategy images of bidirectional path tracing: the host side of
``shaders/integrators/strategy_images.glsl`` (storage block 8) and the PNG pyramids.

A path of k segments can be made by the strategies (s, t) with s + t - 1 = k, s light
subpath vertices and t camera subpath vertices; each strategy's weighted images of one
length add up to that length's part of the bdpt image, and each unweighted image is an
estimate of it on its own, noisier where the strategy is a poor way to find the paths
(Veach 1997, fig. 10.3). (1, 1), the lens joined to a light point, is not a bdpt strategy
here (s = 0, t = 2 sees the lights), so its images stay black.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError
from .accum import fixed_sums

WORDS_PER_PIXEL = 12       # six floats (t >= 2) or six 64-bit fixed-point sums (t = 1)
DEFAULT_DEPTH = 5


def strategies(depth: int) -> list[tuple[int, int]]:
    """(s, t) of the path lengths 1 .. depth, in the buffer's order."""
    return [(s, k + 1 - s) for k in range(1, depth + 1) for s in range(k + 1)]


def buffer_bytes(depth: int, width: int, height: int) -> int:
    return 4 * WORDS_PER_PIXEL * len(strategies(depth)) * width * height


def check_depth(depth: int, max_depth: int, cap: int) -> None:
    """``depth`` must be a path length the render can make (1 .. max_depth, at most the cap)."""
    longest = cap if max_depth < 0 else min(max_depth, cap)
    if not (isinstance(depth, int) and 1 <= depth <= longest):
        raise UsageError(f"--strategy-depth {depth}: expected a path length in 1..{longest} "
                         f"(the render's max depth{', capped at %d' % cap if longest == cap else ''})")


def read(words: np.ndarray, depth: int, width: int, height: int, spp: int,
         splat_scale: float) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
    """{(s, t): (weighted, unweighted)}, each (H, W, 3) float64, from the block's words:
    camera-side sums over the samples per pixel, splat sums over the light paths (one per
    camera sample of every pixel)."""
    per = words.reshape(len(strategies(depth)), height, width, WORDS_PER_PIXEL)
    out = {}
    for j, (s, t) in enumerate(strategies(depth)):
        if t >= 2:
            v = per[j, ..., :6].copy().view(np.float32).astype(np.float64) / max(spp, 1)
        else:
            sums = fixed_sums(per[j]).reshape(height, width, 6)
            v = sums.astype(np.float64) / (splat_scale * max(spp, 1) * width * height)
        out[(s, t)] = (v[..., :3], v[..., 3:])
    return out


def _label(tile: np.ndarray, text: str) -> np.ndarray:
    """An 8-bit RGB tile with a strip above it that names it."""
    from PIL import Image, ImageDraw, ImageFont

    scale = -(-40 // tile.shape[1])   # small films: whole-pixel magnification, room to label
    tile = tile.repeat(scale, axis=0).repeat(scale, axis=1)
    h, w = tile.shape[:2]
    font = ImageFont.load_default()
    strip = 14
    img = Image.new("RGB", (max(w, 6 * len(text) + 4), h + strip), (32, 32, 32))
    img.paste(Image.fromarray(tile), (0, strip))
    ImageDraw.Draw(img).text((2, 1), text, fill=(235, 235, 235), font=font)
    return np.asarray(img)


def pyramid(images: dict[tuple[int, int], np.ndarray], depth: int, encode) -> np.ndarray:
    """Veach's pyramid: row k holds the strategies of length k, s = 0 .. k from the left,
    centred; ``encode`` turns a float image into 8-bit RGB."""
    tiles = {st: _label(encode(img), f"({st[0]},{st[1]})") for st, img in images.items()}
    th, tw = next(iter(tiles.values())).shape[:2]
    gap = 4
    rows = []
    width = (depth + 1) * (tw + gap)
    for k in range(1, depth + 1):
        row = np.zeros((th, width, 3), np.uint8)
        x0 = (width - (k + 1) * (tw + gap)) // 2
        for s in range(k + 1):
            tile = tiles[(s, k + 1 - s)]
            x = x0 + s * (tw + gap)
            row[:tile.shape[0], x:x + tile.shape[1]] = tile
        rows += [row, np.zeros((gap, width, 3), np.uint8)]
    return np.concatenate(rows)


def write(folder: Path, images: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]],
          depth: int, *, exposure: float = 0.0, curve: str = "clamp", srgb: bool = True) -> list[str]:
    """``weighted.png`` and ``unweighted.png`` (the pyramids, all at the same exposure as
    the render) and ``strategies.npz`` (the float images, keys w_S_T and u_S_T) in folder."""
    from PIL import Image

    from ..film.io import atomic_write
    from ..film.tonemap import tonemap

    folder.mkdir(parents=True, exist_ok=True)

    def encode(img: np.ndarray) -> np.ndarray:
        return tonemap(img.astype(np.float32), exposure, curve, srgb)

    written = []
    for which, name in ((0, "weighted"), (1, "unweighted")):
        grid = pyramid({st: pair[which] for st, pair in images.items()}, depth, encode)
        path = folder / f"{name}.png"
        atomic_write(path, lambda tmp, grid=grid: Image.fromarray(grid).save(tmp, format="PNG"))
        written.append(str(path))
    arrays = {f"{p}_{s}_{t}": pair[i].astype(np.float32) for (s, t), pair in images.items()
              for i, p in enumerate("wu")}

    def write_arrays(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)

    atomic_write(folder / "strategies.npz", write_arrays)
    written.append(str(folder / "strategies.npz"))
    return written
