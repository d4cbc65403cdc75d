"""The preview's denoised view: Open Image Denoise in a background thread.

The frame loop hands the accumulation (mean, albedo, normal, emission, read back on the
thread that owns the GL context) to :class:`DenoisedView` when a new denoised image is
worth making:
the first one as soon as an accumulation has samples, then each time its samples per
pixel have doubled (each halves the noise variance again), and never while a denoise is
still running, so the window keeps drawing at its frame rate whatever OIDN takes. OIDN
runs with one thread fewer than the cores (at least one), unpinned, so llvmpipe's
threads keep rendering beside it, at OIDN's "balanced" quality; ``cleanAux`` as for
``glrender render --denoise``. As there, the emission the camera sees (the emission AOV)
is kept out of the filter and added back; the preview adds back the accumulation's own
(no separate pass: the light's edges converge with the accumulation).
"""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass

import numpy as np


def oidn_threads() -> int:
    """OIDN's threads in the preview: all cores but one (llvmpipe renders meanwhile)."""
    return max(1, (os.cpu_count() or 2) - 1)


@dataclass
class Denoised:
    image: np.ndarray        # (H, W, 3) linear radiance
    spp: int                 # samples per pixel of the accumulation it came from
    generation: int          # which accumulation (a camera move or new kernel starts another)
    seconds: float


class DenoisedView:
    """Denoises accumulations in a worker thread; :attr:`latest` is the newest result."""

    def __init__(self, clean_aux: bool, threads: int | None = None, on_done=None):
        from ..denoise import Denoiser

        self.clean_aux = clean_aux
        self.on_done = on_done        # called from the worker (glfw.post_empty_event wakes the loop)
        # OIDN's "balanced" quality, its setting for interactive previews: measured 2.3x
        # faster than "high" with cleanAux on the Cornell box, at 1.4x the MSE (4 spp)
        self.denoiser = Denoiser(threads=threads or oidn_threads(), quality="balanced")
        self.latest: Denoised | None = None
        self.runs = 0
        self.seconds = 0.0
        self._busy = threading.Event()
        self._last_request: tuple[int, int] | None = None    # (generation, spp)
        self._thread: threading.Thread | None = None

    @property
    def busy(self) -> bool:
        return self._busy.is_set()

    def wants(self, generation: int, spp: int, final: bool = False) -> bool:
        """Whether an accumulation at ``spp`` should be denoised now (``final``: it has
        reached its sample target and will not grow)."""
        if spp <= 0 or self.busy:
            return False
        last = self._last_request
        return (last is None or last[0] != generation or spp >= 2 * last[1]
                or (final and spp != last[1]))

    def current(self, generation: int) -> Denoised | None:
        """The newest result of this accumulation, if any."""
        d = self.latest
        return d if d is not None and d.generation == generation else None

    def submit(self, film, generation: int) -> None:
        """Denoise ``film`` (a :class:`Film` read back now) in the background."""
        import time

        from ..denoise import film_aux

        self._busy.set()
        self._last_request = (generation, film.spp)
        color, aux = film.mean, film_aux(film)

        def work():
            try:
                t0 = time.perf_counter()
                image = self.denoiser.denoise(color, *aux, clean_aux=self.clean_aux)
                seconds = time.perf_counter() - t0
                self.latest = Denoised(image, film.spp, generation, seconds)
                self.runs += 1
                self.seconds += seconds
            finally:
                self._busy.clear()
                if self.on_done is not None:
                    self.on_done()

        self._thread = threading.Thread(target=work, name="glrender-denoise", daemon=True)
        self._thread.start()

    def close(self) -> None:
        if self._thread is not None:
            self._thread.join()
        self.denoiser.close()
