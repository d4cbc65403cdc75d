"""What every render driver offers: the interface :class:`~glrender.render.job.RenderJob`, the
command line, the API, the preview and the cluster use, whatever the integrator.

:class:`~glrender.render.renderer.Renderer` is the driver of every integrator that runs in the
render kernel (path, direct, ao, lighttrace, bdpt); photon mapping and SPPM have their own
(:mod:`glrender.photon`). :func:`glrender.drivers.create_driver` makes the one an integrator
names in :mod:`glrender.integrators`.
"""
from __future__ import annotations

import hashlib
from typing import Any, Callable, Iterable, Protocol, runtime_checkable

from ..film import Film


@runtime_checkable
class RenderDriver(Protocol):
    """A scene on the device, accumulating samples progressively."""

    #: the GL context it renders on (glrender.gl.context.Context)
    ctx: Any
    width: int
    height: int
    #: the sample count one pass adds, as the job's time policy sizes it
    samples_per_pass: int
    #: seconds of setup by phase ("pack", "build", "compile", ...)
    timings: dict[str, float]

    @property
    def spp_done(self) -> int:
        """Samples per pixel accumulated so far (SPPM: iterations)."""

    @property
    def band_height(self) -> int:
        """Rows of the film this driver accumulates (all of them unless reset to a band)."""

    def step(self, spp: int, callback: Callable[[int, int], None] | None = None,
             should_stop: Callable[[], bool] | None = None) -> int:
        """Add up to ``spp`` samples per pixel; returns those added (0: stopped first)."""

    def reset(self, start: int = 0, rows: tuple[int, int] | None = None) -> None:
        """Start again from sample ``start``, on tile rows ``rows`` (first, count) or all."""

    def film(self) -> Film:
        """The accumulated image, its error and its AOVs."""

    def state(self) -> dict[str, Any]:
        """The accumulation as arrays, for a checkpoint."""

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from a checkpoint's ``state``."""

    def fingerprint(self) -> str:
        """A digest of everything that decides the image: a checkpoint resumes only on a
        driver with the same one."""

    def fingerprint_parts(self) -> dict[str, str]:
        """The fingerprint's inputs digested part by part (:func:`part_digests`), so that a
        refused checkpoint can name what differs."""

    def stats(self) -> dict[str, Any]:
        """The integrator's own entries for ``--stats`` (photon maps, radii, ...; {} if none)."""

    def release(self) -> None:
        """Free the device resources."""


#: the length of a fingerprint part's digest, in hexadecimal digits
PART_DIGITS = 16


def part_digests(inputs: Iterable[tuple[str, bytes]]) -> dict[str, str]:
    """{part: digest} of (part, bytes) pairs, a part's bytes hashed in their order."""
    hashes: dict[str, Any] = {}
    for part, data in inputs:
        hashes.setdefault(part, hashlib.sha256()).update(data)
    return {part: h.hexdigest()[:PART_DIGITS] for part, h in hashes.items()}
