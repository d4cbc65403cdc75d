"""A rendered image and its per-pixel statistics."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError


@dataclass
class Film:
    """The accumulation of a render, as numpy arrays (rows top to bottom).

    - ``mean``: (H, W, 3) linear RGB, the image.
    - ``m2``: (H, W, 3) Welford's sum of squared deviations per pixel.
    - ``count``: (H, W) finite samples per pixel; ``nonfinite``: dropped samples.
    - ``variance``: per-*sample* variance m2 / (count - 1). Under stratified or
      Sobol' sampling samples are not independent and this overstates the error of
      the mean (it is an upper bound); tests take error bars from independent seeds.
    """

    mean: np.ndarray
    m2: np.ndarray
    count: np.ndarray
    nonfinite: np.ndarray
    spp: int
    aovs: dict = field(default_factory=dict)
    loop_counts: np.ndarray | None = None
    sampler: str = "independent"
    stats: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.mean.shape[:2]

    @property
    def variance(self) -> np.ndarray:
        n = self.count[..., None]
        return np.where(n > 1, self.m2 / np.maximum(n - 1, 1), 0.0).astype(np.float32)

    @property
    def stderr(self) -> np.ndarray:
        """Standard error of each pixel's mean from the per-sample variance (exact for the
        independent sampler; an upper bound for stratified and Sobol')."""
        n = self.count[..., None]
        return np.sqrt(self.variance / np.maximum(n, 1)).astype(np.float32)

    @property
    def nonfinite_total(self) -> int:
        return int(self.nonfinite.sum())

    def aov(self, name: str) -> np.ndarray:
        if name == "variance":
            return self.variance
        if name not in self.aovs:
            have = ", ".join(["variance", *self.aovs]) or "variance"
            raise UsageError(f"AOV {name!r} was not rendered (available: {have}; "
                             f"render with aovs=True for albedo, normal, depth)")
        return self.aovs[name]

    def save(self, path, **options) -> None:
        from .io import write_image

        write_image(path, self.mean, aovs={**self.aovs, "variance": self.variance}, **options)
