"""A rendered image and its per-pixel statistics."""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import UsageError


@dataclass(repr=False)
class Film:
    """The accumulation of a render, as numpy arrays (rows top to bottom).

    - ``mean``: (H, W, 3) linear RGB, the image.
    - ``m2``: (H, W, 3) the sum of squared deviations from the mean per pixel.
    - ``count``: (H, W) finite samples per pixel; ``nonfinite``: dropped samples
      (non-finite, or with a component of 2^30 or more: glrender.render.accum).
    - ``truncated``: (H, W) paths a depth cap cut short where they would have gone on
      (max depth -1: every integrator stops at 256 segments, bdpt at 16; bdpt counts its
      camera and light subpaths); None where the integrator does not count them.
    - ``variance``: per-*sample* variance m2 / (count - 1). Under stratified or
      Sobol' sampling samples are not independent and this overstates the error of
      the mean (it is an upper bound); tests take error bars from independent seeds.
    - ``spp``: samples per pixel accumulated; ``sampler``: the sampler's kind.
    - ``aovs``: first-hit outputs by name (see :meth:`aov`).
    - ``stats``: what :func:`glrender.render` measured (timings in seconds, samples/s,
      passes, why it stopped); empty for a film read from a :class:`Renderer`.
    """

    mean: np.ndarray
    m2: np.ndarray
    count: np.ndarray
    nonfinite: np.ndarray
    spp: int
    aovs: dict[str, np.ndarray] = field(default_factory=dict)
    loop_counts: np.ndarray | None = None
    truncated: np.ndarray | None = None
    sampler: str = "independent"
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        return (int(self.mean.shape[0]), int(self.mean.shape[1]))

    @property
    def variance(self) -> np.ndarray:
        """(H, W, 3) float32: per-sample variance of each pixel's radiance (units of
        radiance squared), m2 / (count - 1); 0 where a pixel has fewer than 2 samples."""
        n = self.count[..., None]
        variance: np.ndarray = np.where(n > 1, self.m2 / np.maximum(n - 1, 1), 0.0).astype(np.float32)
        return variance

    @property
    def stderr(self) -> np.ndarray:
        """Standard error of each pixel's mean from the per-sample variance (exact for the
        independent sampler; an upper bound for stratified and Sobol')."""
        n = self.count[..., None]
        stderr: np.ndarray = np.sqrt(self.variance / np.maximum(n, 1)).astype(np.float32)
        return stderr

    @property
    def nonfinite_total(self) -> int:
        """Samples dropped in the whole image because they were NaN or infinite."""
        return int(self.nonfinite.sum())

    @property
    def truncated_total(self) -> int:
        """Paths a depth cap cut short in the whole image (0 where not counted)."""
        return 0 if self.truncated is None else int(self.truncated.astype(np.int64).sum())

    def aov(self, name: str) -> np.ndarray:
        """An arbitrary output by name: ``"variance"`` (always), and with ``aovs=True``
        ``"albedo"`` (H, W, 3, first-hit reflectance), ``"normal"`` (H, W, 3, world-space
        unit shading normal), ``"depth"`` (H, W, distance along the camera ray in scene
        units) and ``"emission"`` (H, W, 3, the part of ``mean`` emitted by the lights and
        environment the camera sees: directly, and for the path tracer in mirrors and
        through glass; ``mean - emission`` is the light surfaces reflect). Raises
        :class:`UsageError` naming the available ones otherwise."""
        if name == "variance":
            return self.variance
        if name not in self.aovs:
            have = ", ".join(["variance", *self.aovs]) or "variance"
            raise UsageError(f"AOV {name!r} was not rendered (available: {have}; "
                             f"render with aovs=True for albedo, normal, depth, emission)")
        return self.aovs[name]

    def crop(self, x0: int, y0: int, x1: int, y1: int) -> "Film":
        """The pixels x0 <= x < x1, y0 <= y < y1 of this film (its own pixel coordinates)
        as a new film, every array and AOV cut alike."""
        rows, cols = slice(y0, y1), slice(x0, x1)
        loops = None if self.loop_counts is None else self.loop_counts[rows, cols].copy()
        truncated = None if self.truncated is None else self.truncated[rows, cols].copy()
        return replace(self, mean=self.mean[rows, cols].copy(), m2=self.m2[rows, cols].copy(),
                       count=self.count[rows, cols].copy(),
                       nonfinite=self.nonfinite[rows, cols].copy(),
                       aovs={k: v[rows, cols].copy() for k, v in self.aovs.items()},
                       loop_counts=loops, truncated=truncated)

    def save(self, path: str | os.PathLike[str], *, exposure: float = 0.0, curve: str = "clamp",
             srgb: bool = True, half: bool = False) -> None:
        """Write the image; the format comes from the extension: ``.exr`` (float32 or
        ``half``, with the variance and AOVs as layers), ``.pfm``, ``.hdr``, ``.npy``
        (float32 linear RGB), ``.png``/``.jpg`` (8-bit: scaled by 2^``exposure`` stops, the
        tone ``curve`` clamp/filmic/aces, then sRGB-encoded unless ``srgb=False``). Written
        atomically (a temporary file, then a rename)."""
        from .io import write_image

        write_image(path, self.mean, aovs={**self.aovs, "variance": self.variance},
                    exposure=exposure, half=half, curve=curve, srgb=srgb)

    def to_srgb8(self, exposure: float = 0.0, curve: str = "clamp") -> np.ndarray:
        """(H, W, 3) uint8: the image as a PNG would store it (exposure in stops, tone
        curve, sRGB encoding)."""
        from .tonemap import tonemap

        return tonemap(self.mean, exposure, curve, True)

    def _repr_png_(self) -> bytes:
        """PNG bytes of :meth:`to_srgb8`: notebooks (IPython, Jupyter) show a Film as its image."""
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.to_srgb8()).save(buf, format="PNG")
        return buf.getvalue()

    def __repr__(self) -> str:
        h, w = self.shape
        return (f"Film({w}x{h}, spp={self.spp}, sampler={self.sampler!r}, "
                f"aovs={sorted(self.aovs)})")
