"""Partial accumulations of a band and how they merge.

A :class:`Partial` holds one band's per-pixel Welford statistics in the renderer's
layout (``Renderer.state()``): ``mean`` (N, 4) = mean RGB and the count of finite
samples, ``m2`` (N, 4) = M2 RGB and the count of dropped non-finite samples,
``aov`` (N, AOV_VEC4S, 4) = running means of first-hit albedo, normal/depth and seen
emission (or None).
A unit's partial is float32, as the device accumulated it; merged partials are
float64. :func:`merge` combines two partials of disjoint sample ranges with Chan,
Golub and LeVeque's pairwise update (1979):

    n = na + nb,  delta = mean_b - mean_a,
    mean = mean_a + delta nb / n,  M2 = M2_a + M2_b + delta^2 na nb / n

evaluated in float64 in a fixed order (the plan's merge tree), so the result is
the same bits wherever it runs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.layout import AOV_VEC4S, aov_images


@dataclass
class Partial:
    mean: np.ndarray
    m2: np.ndarray
    aov: np.ndarray | None
    samples: tuple[int, int]     # the sample indices [start, stop) it holds
    seconds: float = 0.0         # render time on the worker (units), summed by merges
    splat: np.ndarray | None = None   # splatting integrators: the whole film's fixed-point
                                      # sums, (W*H, 3) int64 (they add exactly)

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.mean, self.m2, self.aov, self.splat) if a is not None)


def from_state(state: dict, pixels: int, aovs: bool, samples, seconds: float = 0.0,
               splat: bool = False) -> Partial:
    """A unit's partial from ``Renderer.state()``."""
    mean = state["mean"].reshape(pixels, 4)
    m2 = state["m2"].reshape(pixels, 4)
    aov = state["aov"].reshape(pixels, AOV_VEC4S, 4) if aovs else None
    sums = None
    if splat:   # two 32-bit words (low, high) per pixel and channel, as the device adds them
        words = np.asarray(state["splat"], np.uint32).reshape(-1, 2).astype(np.uint64)
        sums = ((words[:, 1] << np.uint64(32)) | words[:, 0]).view(np.int64).reshape(-1, 3)
    return Partial(mean, m2, aov, tuple(samples), seconds, sums)


def merge(a: Partial, b: Partial) -> Partial:
    """Chan et al.'s merge of ``a`` (earlier samples) and ``b`` (the next ones), in float64."""
    if a.samples[1] != b.samples[0]:
        raise ValueError(f"merge: sample ranges {a.samples} and {b.samples} are not adjacent")
    ma, mb = a.mean.astype(np.float64), b.mean.astype(np.float64)
    na, nb = ma[:, 3:], mb[:, 3:]
    n = na + nb
    safe = np.where(n > 0, n, 1.0)
    w = nb / safe
    delta = mb[:, :3] - ma[:, :3]
    mean = np.empty_like(ma)
    mean[:, :3] = ma[:, :3] + delta * w
    mean[:, 3:] = n
    m2 = a.m2.astype(np.float64) + b.m2.astype(np.float64)   # M2 sums, non-finite counts add
    m2[:, :3] += delta * delta * (na * nb / safe)
    aov = None
    if a.aov is not None:
        aa, ab = a.aov.astype(np.float64), b.aov.astype(np.float64)
        aov = aa + (ab - aa) * w[:, None, :]
    splat = None if a.splat is None else a.splat + b.splat
    return Partial(mean, m2, aov, (a.samples[0], b.samples[1]), a.seconds + b.seconds, splat)


def merge_tree(tree, leaves: list):
    """Merge ``leaves`` (partials, in range order) along ``tree`` (Plan.merge_tree)."""
    if isinstance(tree, int):
        return leaves[tree]
    return merge(merge_tree(tree[0], leaves), merge_tree(tree[1], leaves))


class FrameImage:
    """A frame assembled from its bands' partials (rows top to bottom)."""

    def __init__(self, width: int, height: int, aovs: bool):
        self.width, self.height, self.aovs = width, height, aovs
        self.mean = np.zeros((height, width, 4), np.float32)
        self.m2 = np.zeros((height, width, 4), np.float32)
        self.aov = np.zeros((height, width, AOV_VEC4S, 4), np.float32) if aovs else None
        self.splat = None      # fixed-point splat sums of the whole film (whole-frame bands)
        self.bands_done: set[int] = set()

    def place(self, band: int, first_row: int, partial: Partial) -> None:
        """Put a band's final partial at tile row ``first_row`` (float64 merges round to
        float32 here, the precision of the device's accumulation and of the outputs)."""
        y0 = 8 * first_row
        h = len(partial.mean) // self.width
        self.mean[y0:y0 + h] = partial.mean.reshape(h, self.width, 4)
        self.m2[y0:y0 + h] = partial.m2.reshape(h, self.width, 4)
        if self.aov is not None:
            self.aov[y0:y0 + h] = partial.aov.reshape(h, self.width, AOV_VEC4S, 4)
        if partial.splat is not None:
            self.splat = partial.splat if self.splat is None else self.splat + partial.splat
        self.bands_done.add(band)

    def film(self, spp: int, sampler: str):
        from ..film import Film

        aovs = aov_images(self.aov, self.height, self.width) if self.aov is not None else {}
        mean = self.mean
        if self.splat is not None:
            # as Renderer.film and splat_image: the sums over the light paths (one per
            # camera sample of every pixel), rounded to float32, added in float32
            from ..render.renderer import SPLAT_SCALE

            paths = max(spp, 1) * self.width * self.height
            image = (self.splat.astype(np.float64) / (SPLAT_SCALE * paths)).astype(np.float32)
            mean = mean.copy()
            mean[..., :3] += image.reshape(self.height, self.width, 3)
        return Film(mean=mean[..., :3].copy(), m2=self.m2[..., :3].copy(),
                    count=self.mean[..., 3].copy(), nonfinite=self.m2[..., 3].copy(), spp=spp,
                    aovs=aovs, sampler=sampler)
