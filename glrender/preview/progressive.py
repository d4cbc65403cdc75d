"""Frame-budgeted progressive rendering: a pass spread over as many frames as it needs.

:meth:`Renderer.step` runs whole passes, and one pass over a large image or a slow
scene takes far longer than a frame on llvmpipe (a 256x256 bunny pass at 1 spp:
~0.2 s). :class:`Progressive` dispatches the tiles of a pass in runs sized to a
time budget, so each frame adds what fits in ~30 ms and the window keeps
responding; the accumulation is the renderer's own, and as the renderer sums each
pixel's samples in index order, the image at N spp is bitwise the one
``Renderer.step(N)`` gives (tests/preview/test_progressive.py).

Passes ramp up: 1 spp first (a whole noisy image soon after the camera moves),
then as many samples per pass as the image already has (1, 1, 2, 4, ...), up to
the renderer's ``samples_per_pass``. Between passes every pixel has the same
count, ``renderer.spp_done``; during a pass the pixels of finished tiles have more.
A restart in the middle of a pass (the camera moves every frame during a drag)
begins the next pass where the interrupted one stopped in the kernel's tile order,
so successive restarts sweep the whole image instead of redoing its first tiles.

This drives the renderer's dispatch step directly: its parameter block
(``_param_block``), bindings (``_bind``), uniform buffer (``_params``) and kernel
(``program``), the same calls ``Renderer._run_pass`` makes per dispatch.
"""
from __future__ import annotations

import time

import numpy as np

from ..render import accum
from ..render.renderer import Renderer

MAX_TILES_PER_DISPATCH = 65535   # GL's guaranteed work group count along x


class Progressive:
    """Adds samples to ``renderer`` within a time budget per call; ``target_spp``
    (None: unbounded) stops it."""

    def __init__(self, renderer: Renderer, target_spp: int | None = None):
        self.renderer = renderer
        self.target_spp = target_spp
        self.tiles = renderer.tiles_x * renderer.tiles_y
        self.pass_samples = 0      # samples per pixel of the pass in progress (0: none)
        self.next_tile = 0         # tiles of the pass in progress rendered so far
        self.origin = 0            # where passes start in the kernel's (permuted) tile order
        self._params = None
        self._tile_seconds = None  # measured seconds per tile and sample per pixel
        self.samples_added = 0     # pixel samples dispatched since the last reset

    def reset(self) -> None:
        """Forget every sample (the renderer's accumulation too)."""
        self.renderer.reset()
        self.origin = (self.origin + self.next_tile) % self.tiles
        self.pass_samples = self.next_tile = 0
        self.samples_added = 0

    @property
    def spp(self) -> int:
        """Samples in every pixel (whole passes)."""
        return self.renderer.spp_done

    @property
    def done(self) -> bool:
        return self.pass_samples == 0 and self.target_spp is not None and self.spp >= self.target_spp

    def _start_pass(self) -> bool:
        r = self.renderer
        k = min(r.samples_per_pass, max(1, r.spp_done))
        if self.target_spp is not None:
            k = min(k, self.target_spp - r.spp_done)
        if k <= 0:
            return False
        self.pass_samples, self.next_tile = k, 0
        r.prepare_pass(r.spp_done, k)     # vcm: the iteration's light pass and merge grid
        self._params = r.param_block(r.spp_done, k)
        return True

    def _dispatch(self, count: int) -> None:
        """Render the pass's next ``count`` tiles (fewer where the tile order wraps around)."""
        r, prm = self.renderer, self._params
        first = (self.origin + self.next_tile) % self.tiles
        count = min(count, self.tiles - first)
        r.bind()
        prm["dispatch"][0], prm["dispatch"][1] = first, count
        r.write_params(prm)
        t0 = time.perf_counter()
        r.program.run(group_x=count)
        r.gl.finish()
        rate = (time.perf_counter() - t0) / (count * self.pass_samples)
        self._tile_seconds = rate if self._tile_seconds is None else 0.7 * self._tile_seconds + 0.3 * rate
        self.next_tile += count
        # tiles differ in size at the image's edges: count the pass's share
        self.samples_added += count * r.width * r.height * self.pass_samples / self.tiles
        if self.next_tile >= self.tiles:
            r.spp_done += self.pass_samples
            self.pass_samples = self.next_tile = 0

    def advance(self, budget: float) -> bool:
        """Render for about ``budget`` seconds (at least one dispatch, unless done);
        returns whether anything was rendered."""
        deadline = time.perf_counter() + budget
        rendered = False
        while True:
            if self.pass_samples == 0 and not self._start_pass():
                return rendered
            left = deadline - time.perf_counter()
            if self._tile_seconds is None:
                count = 4
            else:
                count = int(left / (self._tile_seconds * self.pass_samples))
            count = max(1, min(count, self.tiles - self.next_tile, MAX_TILES_PER_DISPATCH))
            if rendered and left <= 0:
                return True
            self._dispatch(count)
            rendered = True
            if time.perf_counter() >= deadline:
                return True

    def finish_pass(self) -> None:
        """Complete the pass in progress, however long it takes (before a screenshot:
        every pixel then has ``spp`` samples)."""
        while self.pass_samples:
            self._dispatch(min(self.tiles - self.next_tile, MAX_TILES_PER_DISPATCH))


class SppmProgressive:
    """:class:`Progressive` for SPPM (glrender.photon.SppmRenderer): an iteration is its
    camera pass, then its photon dispatches (PHOTONS_PER_DISPATCH photons each), spread
    over as many calls as the budget asks, so the window keeps responding; the image (the
    host's float64 estimate) is written into the inner renderer's accumulation buffer
    after every iteration, as sums over the iteration count, where the display reads it
    (the squares stay zero: SPPM has no per-sample variance). ``spp`` counts iterations."""

    def __init__(self, renderer, target_spp: int | None = None):
        self.renderer = renderer
        self.target_spp = target_spp
        self.samples_added = 0     # pixel samples (camera samples) since the last reset
        self._show()

    def reset(self) -> None:
        """Forget every iteration (radii back to the initial one)."""
        self.renderer.reset()
        self.samples_added = 0
        self._show()

    @property
    def spp(self) -> int:
        return self.renderer.iterations

    @property
    def done(self) -> bool:
        return not self.renderer.iteration_in_progress and self.target_spp is not None and self.spp >= self.target_spp

    def _show(self) -> None:
        r = self.renderer
        n = r.width * r.height
        sums = np.zeros((n, 4, 4), np.uint32)   # the accumulation's sums (glrender.render.accum)
        if r.iterations:
            # the estimate times the count, so that the display's sum / count is the estimate
            radiance = r.radiance().reshape(n, 3).astype(np.float64)
            sums[:, :3] = accum.fixed(radiance * r.iterations)
            sums[:, 3, 0] = r.iterations
        r.base.load_accumulation(sums, np.zeros((n, 3, 4), np.uint32))

    def _step(self) -> None:
        """One piece of work (SppmRenderer.iteration_piece): a slice's camera pass and its
        grid, or one photon dispatch (the last one ends the iteration)."""
        r = self.renderer
        finished = r.iteration_piece()
        r.gl.finish()
        if finished:
            self.samples_added += r.width * r.height
            self._show()

    def advance(self, budget: float) -> bool:
        """Work for about ``budget`` seconds (at least one piece, unless done); returns
        whether anything was rendered."""
        deadline = time.perf_counter() + budget
        rendered = False
        while not self.done:
            self._step()
            rendered = True
            if time.perf_counter() >= deadline:
                break
        return rendered

    def finish_pass(self) -> None:
        """Complete the iteration in progress (before a screenshot)."""
        while self.renderer.iteration_in_progress:
            self._step()
