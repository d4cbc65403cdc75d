"""Work units and the merge tree of a distributed render: pure functions of the image
size, the sample count and the unit size, never of timing or of the worker count.

A unit renders one *band* (whole rows of 8x8 tiles, full image width) of one frame
over one range of sample indices. The unit size is a budget in pixel-samples
(pixels x samples per pixel):

- when a tile row at the full sample count fits it, a band takes as many tile rows as
  fit and one range holds every sample;
- otherwise each band is one tile row and its samples are split into ranges (whole
  passes of ``samples_per_pass``), merged pairwise along a fixed balanced tree.

Either way the merged image is bitwise the single-process image, whatever the unit
size: the renderer accumulates exact 128-bit fixed-point sums (glrender.render.accum),
and sums of disjoint sample ranges add up, in any grouping, to the bits of one
accumulation of all of them. Integrators that splat light paths onto the whole film
(light tracing, BDPT) render whole frames (``whole_frame``: one band) split into
sample ranges: their splats are 64-bit fixed-point sums, exact in the same way.

A unit's transfer is its band's accumulation: 112 bytes per pixel (272 with AOVs),
``width x 8 x rows`` pixels, e.g. 3.4 MB for one tile row of a 3840-pixel-wide image.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

TILE = 8
SAMPLES_PER_PASS = 8
MIN_UNIT_SIZE = 1 << 12


@dataclass(frozen=True)
class Unit:
    """One task: samples [start, stop) of tile rows [first, first + count) of a frame
    (None: the scene as loaded, no animation)."""

    frame: int | None
    band: int
    rows: tuple[int, int]
    samples: tuple[int, int]

    @property
    def name(self) -> str:
        f = "still" if self.frame is None else f"f{self.frame}"
        return f"{f}-b{self.band}-s{self.samples[0]}-{self.samples[1]}"


@dataclass(frozen=True)
class Plan:
    width: int
    height: int
    spp: int
    unit_size: int
    frames: tuple = (None,)
    samples_per_pass: int = SAMPLES_PER_PASS
    whole_frame: bool = False     # one band of every tile row (integrators that splat)

    def __post_init__(self):
        if self.unit_size < MIN_UNIT_SIZE:
            raise ValueError(f"unit size {self.unit_size}: expected at least {MIN_UNIT_SIZE} "
                             f"pixel-samples")
        if self.spp < 1 or self.width < 1 or self.height < 1:
            raise ValueError("plan: width, height and spp must be positive")

    @property
    def tile_rows(self) -> int:
        return -(-self.height // TILE)

    @cached_property
    def rows_per_band(self) -> int:
        if self.whole_frame:
            return self.tile_rows
        row_cost = self.width * TILE * self.spp
        return max(1, min(self.tile_rows, self.unit_size // row_cost))

    @cached_property
    def bands(self) -> tuple[tuple[int, int], ...]:
        """(first tile row, tile rows) of each band, top to bottom."""
        per_band = self.rows_per_band
        return tuple((r, min(per_band, self.tile_rows - r)) for r in range(0, self.tile_rows, per_band))

    @cached_property
    def ranges(self) -> tuple[tuple[int, int], ...]:
        """The sample ranges [start, stop) every band is split into."""
        band_pixels = self.width * min(self.height, TILE * self.rows_per_band)
        if band_pixels * self.spp <= self.unit_size:
            return ((0, self.spp),)
        k = self.samples_per_pass
        per = max(k, self.unit_size // band_pixels // k * k)
        return tuple((s, min(s + per, self.spp)) for s in range(0, self.spp, per))

    def band_height(self, band: int) -> int:
        first, count = self.bands[band]
        return min(self.height, TILE * (first + count)) - TILE * first

    def units(self) -> list[Unit]:
        """Every unit, in the order a single process renders them."""
        return [Unit(f, b, rows, r) for f in self.frames for b, rows in enumerate(self.bands)
                for r in self.ranges]

    def band_units(self, frame, band: int) -> list[Unit]:
        return [Unit(frame, band, self.bands[band], r) for r in self.ranges]

    def unit_pixel_samples(self, unit: Unit) -> int:
        return self.width * self.band_height(unit.band) * (unit.samples[1] - unit.samples[0])

    @property
    def pixel_samples(self) -> int:
        return self.width * self.height * self.spp * len(self.frames)

    def merge_tree(self):
        """The order in which a band's ranges are merged: nested pairs of range indices,
        e.g. ((0, 1), (2, (3, 4))) for 5 ranges (halves, the larger half second)."""
        def build(lo: int, hi: int):
            if hi - lo == 1:
                return lo
            mid = lo + (hi - lo) // 2
            return (build(lo, mid), build(mid, hi))
        return build(0, len(self.ranges))

    def record(self) -> dict:
        """What a checkpoint or statistics file keeps to reproduce the plan."""
        return {"width": self.width, "height": self.height, "spp": self.spp,
                "unit_size": self.unit_size, "samples_per_pass": self.samples_per_pass,
                "frames": list(self.frames), "whole_frame": self.whole_frame,
                "bands": len(self.bands), "ranges": len(self.ranges),
                "units": len(self.bands) * len(self.ranges) * len(self.frames)}


def tree_ranges(tree) -> tuple[int, int]:
    """The first and last range index (inclusive) under a merge-tree node."""
    if isinstance(tree, int):
        return tree, tree
    return tree_ranges(tree[0])[0], tree_ranges(tree[1])[1]


# the largest default unit in pixel-samples when nothing was measured: ~2-4 s on one
# llvmpipe thread for the Cornell box (benchmarks/scale.py measured ~1-2 M pixel-samples/s
# per thread), long enough that a task's scheduling and transfer overhead (~10 ms) is
# below 1%
NOMINAL_UNIT_SIZE = 1 << 22
# seconds of work per unit that a calibrated unit size aims at
UNIT_SECONDS = 2.0
# a render gets at least this many units (when each keeps MIN_UNIT_SIZE): work for as
# many task slots
MIN_UNITS = 32


def default_unit_size(width: int, height: int, spp: int, frames: int = 1,
                      largest: int = NOMINAL_UNIT_SIZE) -> int:
    """The unit size when none is given: ``largest`` (the calibrated size, see
    glrender.distributed.calibrate) unless the render is small, then about 1/MIN_UNITS
    of a frame's pixel-samples, rounded up to a power of two (at least MIN_UNIT_SIZE).
    A pure function of the render and the calibration, never of the cluster."""
    total = width * height * spp
    size = 1 << max(12, math.ceil(math.log2(max(total / MIN_UNITS, 1))))
    return max(min(size, largest), MIN_UNIT_SIZE)


def calibrated_unit_size(pixel_samples_per_second: float, seconds: float = UNIT_SECONDS) -> int:
    """A unit size from a measured rate: about ``seconds`` of work per unit, rounded to
    a power of two (so nearby measurements give the same plan)."""
    target = max(pixel_samples_per_second * seconds, MIN_UNIT_SIZE)
    return 1 << max(12, min(40, round(math.log2(target))))
