"""Strategy images of bidirectional path tracing: the host side of
``shaders/integrators/strategy_images.glsl`` (storage block 8) and the PNG pyramids.

A path of k segments can be made by the strategies (s, t) with s + t - 1 = k, s light
subpath vertices and t camera subpath vertices; each strategy's weighted images of one
length add up to that length's part of the bdpt image, and each unweighted image is an
estimate of it on its own, noisier where the strategy is a poor way to find the paths
(Veach 1997, fig. 10.3). (1, 1), the lens joined to a light point, is not a bdpt strategy
here (s = 0, t = 2 sees the lights), so its images stay black.

vcm adds the merges: a path of k segments can also be made by merging at each of its inner
vertices, q light subpath segments and t camera subpath vertices with q + t - 1 = k (q = 1
.. k - 1). Their images follow the connections' in the buffer and make a pyramid of their
own, where merging takes over (caustics) shows as the connections' images fade.
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


def merges(depth: int) -> list[tuple[int, int]]:
    """(q, t) of vcm's merges of the path lengths 2 .. depth, in the buffer's order (after
    the connections)."""
    return [(q, k + 1 - q) for k in range(2, depth + 1) for q in range(1, k)]


def buffer_bytes(depth: int, width: int, height: int, with_merges: bool = False) -> int:
    count = len(strategies(depth)) + (len(merges(depth)) if with_merges else 0)
    return 4 * WORDS_PER_PIXEL * count * width * height


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
    n = len(strategies(depth))
    per = words[:n * height * width * WORDS_PER_PIXEL].reshape(n, height, width, WORDS_PER_PIXEL)
    out = {}
    for j, (s, t) in enumerate(strategies(depth)):
        if t >= 2:
            v = per[j, ..., :6].copy().view(np.float32).astype(np.float64) / max(spp, 1)
        else:
            sums = fixed_sums(per[j]).reshape(height, width, 6)
            v = sums.astype(np.float64) / (splat_scale * max(spp, 1) * width * height)
        out[(s, t)] = (v[..., :3], v[..., 3:])
    return out


def read_merges(words: np.ndarray, depth: int, width: int, height: int,
                spp: int) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
    """{(q, t): (weighted, unweighted)} of vcm's merges, each (H, W, 3) float64: sums over
    the samples per pixel, from the words after the connections'."""
    first = len(strategies(depth)) * width * height * WORDS_PER_PIXEL
    per = words[first:].reshape(len(merges(depth)), height, width, WORDS_PER_PIXEL)
    out = {}
    for j, qt in enumerate(merges(depth)):
        v = per[j, ..., :6].copy().view(np.float32).astype(np.float64) / max(spp, 1)
        out[qt] = (v[..., :3], v[..., 3:])
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


def pyramid(images: dict[tuple[int, int], np.ndarray], depth: int, encode,
            merged: bool = False) -> np.ndarray:
    """Veach's pyramid: row k holds the strategies of length k, s = 0 .. k from the left,
    centred (``merged``: the merges, q = 1 .. k - 1, from length 2); ``encode`` turns a
    float image into 8-bit RGB."""
    name = "m" if merged else ""
    tiles = {st: _label(encode(img), f"{name}({st[0]},{st[1]})") for st, img in images.items()}
    th, tw = next(iter(tiles.values())).shape[:2]
    gap = 4
    rows = []
    width = (depth + 1) * (tw + gap)
    for k in range(2 if merged else 1, depth + 1):
        row = np.zeros((th, width, 3), np.uint8)
        firsts = range(1, k) if merged else range(k + 1)
        x0 = (width - len(firsts) * (tw + gap)) // 2
        for i, s in enumerate(firsts):
            tile = tiles[(s, k + 1 - s)]
            x = x0 + i * (tw + gap)
            row[:tile.shape[0], x:x + tile.shape[1]] = tile
        rows += [row, np.zeros((gap, width, 3), np.uint8)]
    return np.concatenate(rows)


def write(folder: Path, images: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]],
          depth: int, *, exposure: float = 0.0, curve: str = "clamp", srgb: bool = True,
          merge_images: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] | None = None) -> list[str]:
    """``weighted.png`` and ``unweighted.png`` (the pyramids, all at the same exposure as
    the render) and ``strategies.npz`` (the float images, keys w_S_T and u_S_T) in folder;
    with vcm's ``merge_images`` also ``merges-weighted.png`` and ``merges-unweighted.png``
    and their float images (keys wm_Q_T and um_Q_T)."""
    from PIL import Image

    from ..film.io import atomic_write
    from ..film.tonemap import tonemap

    folder.mkdir(parents=True, exist_ok=True)

    def encode(img: np.ndarray) -> np.ndarray:
        return tonemap(img.astype(np.float32), exposure, curve, srgb)

    written = []
    sets = [("", images, False)] + ([("merges-", merge_images, True)] if merge_images and depth >= 2 else [])
    for prefix, imgs, merged in sets:
        for which, name in ((0, "weighted"), (1, "unweighted")):
            grid = pyramid({st: pair[which] for st, pair in imgs.items()}, depth, encode, merged)
            path = folder / f"{prefix}{name}.png"
            atomic_write(path, lambda tmp, grid=grid: Image.fromarray(grid).save(tmp, format="PNG"))
            written.append(str(path))
    arrays = {f"{p}_{s}_{t}": pair[i].astype(np.float32) for (s, t), pair in images.items()
              for i, p in enumerate("wu")}
    arrays.update({f"{p}m_{q}_{t}": pair[i].astype(np.float32) for (q, t), pair in (merge_images or {}).items()
                   for i, p in enumerate("wu")})

    def write_arrays(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)

    atomic_write(folder / "strategies.npz", write_arrays)
    written.append(str(folder / "strategies.npz"))
    return written
