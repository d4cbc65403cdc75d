"""Stopping by noise without biasing the image: the sample count from an independent pilot.

A render that stops when its own error estimate falls below a threshold decides with
the samples it averages, and that decision biases the mean (renders that happened to
look converged stop early). Here the decision is made on an independent pilot render
(a different seed, never part of the image): its per-pixel variances predict the
mean relative error of the image at any sample count n,

    e(n) = e_pilot * sqrt(m / n)         (m: the pilot's samples per pixel),

because the standard error of a pixel falls as 1 / sqrt(n) for the same per-sample
variance. The image is then rendered with n = ceil(m (e_pilot / R)^2) samples: a count
fixed before any of its samples exist, so the image is exactly as unbiased as a render
with a fixed sample count. The pilot costs m samples per pixel.

The error measure is the one the CLI reports (``mean_relative_stderr``): the mean over
the lit pixel channels of stderr / mean, with the stderr from the per-sample variance
(exact for the independent sampler, an upper bound for stratified and Sobol' sampling,
so the threshold is then met with room to spare).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError
from ..film import Film

PILOT_SPP = 32


def mean_relative_stderr(film: Film) -> float | None:
    """Mean over lit pixel channels (mean > 0) of stderr / mean; None for a black image."""
    lit = film.mean > 0
    if not lit.any():
        return None
    return float(np.mean(film.stderr[lit] / film.mean[lit]))


def pilot_seed(seed: int) -> int:
    """A seed whose samples are independent of ``seed``'s (a different hash key)."""
    return (int(seed) * 0x9E3779B1 + 0x7F4A7C15) & 0x7FFFFFFF


@dataclass(frozen=True)
class NoisePlan:
    """The sample count that meets ``threshold``, and the pilot it came from."""

    threshold: float
    spp: int                 # samples per pixel the image needs (at least 1)
    pilot_spp: int
    pilot_error: float | None   # the pilot's mean relative stderr (None: black image)
    pilot_seconds: float

    def predicted_error(self, spp: int | None = None) -> float | None:
        """The image's mean relative stderr predicted at ``spp`` (default: self.spp)."""
        if self.pilot_error is None:
            return None
        return self.pilot_error * math.sqrt(self.pilot_spp / (spp or self.spp))


def crop_rows(region) -> tuple[int, int]:
    """The tile rows (first, count) that hold the pixel rows of region (x0, y0, x1, y1)."""
    from .accumulation import TILE

    first = region[1] // TILE
    return first, -(-region[3] // TILE) - first


def crop_band(film: Film, region, rows: tuple[int, int]) -> Film:
    """The region's pixels of a film that holds the tile rows ``rows`` of the image."""
    from .accumulation import TILE

    x0, y0, x1, y1 = region
    top = TILE * rows[0]
    return film.crop(x0, y0 - top, x1, y1 - top)


def check_threshold(threshold: float) -> float:
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or \
            not math.isfinite(threshold) or not 0 < threshold < 1:
        raise UsageError(f"noise threshold {threshold!r}: expected a relative error in (0, 1), "
                         f"e.g. 0.02 for 2%")
    return float(threshold)


def plan_spp(scene, settings, threshold: float, *, pilot_spp: int = PILOT_SPP, ctx=None,
             max_spp: int | None = None, region=None, share=None) -> NoisePlan:
    """Render an independent pilot of ``pilot_spp`` samples per pixel and return the sample
    count at which the image's mean relative stderr is predicted to reach ``threshold``
    (capped at ``max_spp``); ``region`` (x0, y0, x1, y1): measure (and render) only
    those pixels. ``share``: a renderer of the scene whose device data the pilot reuses."""
    plan, renderer = run_pilot(scene, settings, threshold, pilot_spp=pilot_spp, ctx=ctx,
                               max_spp=max_spp, region=region, share=share)
    renderer.release()
    return plan


def run_pilot(scene, settings, threshold: float, *, pilot_spp: int = PILOT_SPP, ctx=None,
              max_spp: int | None = None, region=None, share=None):
    """:func:`plan_spp`, returning the plan and the pilot's renderer, not yet released: the
    render that follows shares its scene data (``Renderer(..., share=pilot)``) instead of
    packing the scene and building its BVH again."""
    import time

    from .renderer import Renderer

    threshold = check_threshold(threshold)
    if pilot_spp < 2:
        raise UsageError(f"pilot spp {pilot_spp}: expected at least 2 (a variance needs two)")
    sampler = replace(settings.sampler, seed=pilot_seed(settings.sampler.seed), spp=pilot_spp)
    pilot = replace(settings, sampler=sampler, aovs=False)
    t0 = time.perf_counter()
    renderer = Renderer(scene, pilot, ctx=ctx, share=share)
    try:
        if region is not None:
            renderer.reset(rows=crop_rows(region))
        renderer.step(pilot_spp)
        film = renderer.film()
        if region is not None:
            film = crop_band(film, region, renderer.rows)
    except BaseException:
        renderer.release()
        raise
    seconds = time.perf_counter() - t0
    error = mean_relative_stderr(film)
    spp = 1 if error is None else max(1, math.ceil(pilot_spp * (error / threshold) ** 2))
    if max_spp is not None:
        spp = min(spp, int(max_spp))
    return NoisePlan(threshold, spp, pilot_spp, error, seconds), renderer
