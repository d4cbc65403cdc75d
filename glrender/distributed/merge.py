"""Partial accumulations of a band and how they merge.

A :class:`Partial` holds one band's per-pixel exact sums in the renderer's layout
(``Renderer.state()``, glrender.render.accum): ``sums`` (N, 4, 4) uint32 words, the
128-bit fixed-point sums of r, g, b and the (finite, dropped) sample counts;
``squares`` (N, 3, 4), the sums of squares; ``aov`` (N, AOV_CHANNELS, 4), the sums of
the first-hit AOVs: albedo, normal/depth and seen emission (or None). :func:`merge`
adds two partials of adjacent sample ranges: integer addition, exact and associative,
so a band merged from any split of its samples, along any tree, holds the bits of one
process rendering all its samples.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..render import accum


@dataclass
class Partial:
    sums: np.ndarray
    squares: np.ndarray
    aov: np.ndarray | None
    samples: tuple[int, int]     # the sample indices [start, stop) it holds
    seconds: float = 0.0         # render time on the worker (units), summed by merges
    splat: np.ndarray | None = None   # splatting integrators: the whole film's fixed-point
                                      # sums, (W*H, 3) int64 (they add exactly)

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.sums, self.squares, self.aov, self.splat)
                   if a is not None)


def from_state(state: dict, pixels: int, aovs: bool, samples, seconds: float = 0.0,
               splat: bool = False) -> Partial:
    """A unit's partial from ``Renderer.state()``."""
    sums = state["sums"].reshape(pixels, 4, 4)
    squares = state["squares"].reshape(pixels, 3, 4)
    aov = state["aov"].reshape(pixels, accum.AOV_CHANNELS, 4) if aovs else None
    sums_splat = None
    if splat:   # two 32-bit words (low, high) per pixel and channel, as the device adds them
        sums_splat = accum.fixed_sums(state["splat"]).reshape(-1, 3)
    return Partial(sums, squares, aov, tuple(samples), seconds, sums_splat)


def band_layout(plan, frame, band: int, aovs: bool) -> dict | None:
    """The arrays of band ``band`` of ``frame`` once every unit of it is merged under
    ``plan`` (a :class:`~glrender.distributed.plan.Plan`): {"sums", "squares", "aov",
    "splat": shape (None: absent), "samples": its range}; None when the plan has no such
    band. What a checkpoint's band must hold to be resumed."""
    if frame not in plan.frames or type(band) is not int or not 0 <= band < len(plan.bands):
        return None
    n = plan.width * plan.band_height(band)
    return {"sums": (n, 4, 4), "squares": (n, 3, 4),
            "aov": (n, accum.AOV_CHANNELS, 4) if aovs else None,
            "splat": (plan.width * plan.height, 3) if plan.whole_frame else None,
            "samples": (0, plan.spp)}


def merge(a: Partial, b: Partial) -> Partial:
    """The partial of ``a``'s samples and the next ones, ``b``'s: exact sums."""
    if a.samples[1] != b.samples[0]:
        raise ValueError(f"merge: sample ranges {a.samples} and {b.samples} are not adjacent")
    aov = None if a.aov is None else accum.add(a.aov, b.aov)
    splat = None if a.splat is None else a.splat + b.splat
    return Partial(accum.add_counts(a.sums, b.sums), accum.add(a.squares, b.squares), aov,
                   (a.samples[0], b.samples[1]), a.seconds + b.seconds, splat)


def merge_tree(tree, leaves: list):
    """Merge ``leaves`` (partials, in range order) along ``tree`` (Plan.merge_tree)."""
    if isinstance(tree, int):
        return leaves[tree]
    return merge(merge_tree(tree[0], leaves), merge_tree(tree[1], leaves))


class FrameImage:
    """A frame assembled from its bands' partials (rows top to bottom)."""

    def __init__(self, width: int, height: int, aovs: bool):
        self.width, self.height, self.aovs = width, height, aovs
        self.sums = np.zeros((height * width, 4, 4), np.uint32)
        self.squares = np.zeros((height * width, 3, 4), np.uint32)
        self.aov = np.zeros((height * width, accum.AOV_CHANNELS, 4), np.uint32) if aovs else None
        self.splat = None      # fixed-point splat sums of the whole film (whole-frame bands)
        self.bands_done: set[int] = set()

    def place(self, band: int, first_row: int, partial: Partial) -> None:
        """Put a band's final partial at tile row ``first_row``."""
        p0 = 8 * first_row * self.width
        n = len(partial.sums)
        self.sums[p0:p0 + n] = partial.sums
        self.squares[p0:p0 + n] = partial.squares
        if self.aov is not None:
            self.aov[p0:p0 + n] = partial.aov
        if partial.splat is not None:
            self.splat = partial.splat if self.splat is None else self.splat + partial.splat
        self.bands_done.add(band)

    def film(self, spp: int, sampler: str):
        from ..film import Film

        h, w = self.height, self.width
        mean, m2, count, dropped, aov = accum.statistics(self.sums, self.squares, self.aov)
        mean = mean.reshape(h, w, 3)
        aovs = accum.aov_images(aov, h, w) if aov is not None else {}
        if self.splat is not None:
            # as Renderer.film and splat_image: the sums over the light paths (one per
            # camera sample of every pixel), rounded to float32, added in float32
            from ..render.accumulation import SPLAT_SCALE

            paths = max(spp, 1) * w * h
            image = (self.splat.astype(np.float64) / (SPLAT_SCALE * paths)).astype(np.float32)
            mean += image.reshape(h, w, 3)
        return Film(mean=mean, m2=m2.reshape(h, w, 3), count=count.reshape(h, w),
                    nonfinite=dropped.reshape(h, w), spp=spp, aovs=aovs, sampler=sampler,
                    truncated=accum.truncated(self.sums).reshape(h, w))
