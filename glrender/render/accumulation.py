"""The render kernel's accumulation on the device: per pixel of a band of tile rows, exact
128-bit fixed-point sums of the samples and of their squares (shaders/film/accum.glsl,
glrender/render/accum.py), the first-hit AOVs' sums and a debug counter; for the whole
film, the splatted light paths and bdpt's strategy images.

:class:`Accumulation` owns those buffers: it allocates them for a band, binds them (the
per-pixel ones in slices that fit one storage-buffer binding), keeps the copy that undoes a
stopped pass, reads them back as a :class:`~glrender.film.Film` and saves and restores them
for checkpoints. It knows nothing of the kernel that fills them.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..film import Film
from ..gpu import bindings
from . import accum, strategies

TILE = 8
SPLAT_SCALE = 65536.0   # kSplatScale: fixed-point units per unit of splatted value
# bytes per pixel of the accumulation (glrender/render/accum.py): 128-bit sums of r, g, b
# and the counts; sums of squares; the AOVs' sums
SUM_BYTES, SQUARE_BYTES, AOV_BYTES = 64, 48, 16 * accum.AOV_CHANNELS


class Accumulation:
    """The accumulation buffers of a ``width`` x ``height`` film on ``gl`` (a moderngl
    context). ``aovs``, ``counting`` (loop or ray counters), ``splatting`` and
    ``strategy_depth`` say which buffers have a per-pixel size (the others hold 16 bytes);
    ``binding_limit()`` answers the bytes one storage-buffer binding may hold."""

    def __init__(self, gl: Any, width: int, height: int, *, aovs: bool, counting: bool,
                 splatting: bool, strategy_depth: int, binding_limit: Callable[[], int],
                 strategy_merges: bool = False) -> None:
        self.gl = gl
        self.width, self.height = width, height
        self.tiles_x, self.tiles_y = -(-width // TILE), -(-height // TILE)
        self.aovs, self.counting, self.splatting = aovs, counting, splatting
        self.strategy_depth = strategy_depth
        self.strategy_merges = strategy_merges     # vcm's merges have images too
        self.binding_limit = binding_limit
        self.rows = (0, self.tiles_y)      # the tile rows accumulated: (first, count)
        self._snapshot: list[Any] | None = None
        self.sums = self.squares = self.aov = self.debug = self.splat = self.strategies = None

    @property
    def band_height(self) -> int:
        """Pixel rows in the accumulation (the film's height unless ``rows`` is a band)."""
        first, count = self.rows
        return min(self.height, TILE * (first + count)) - TILE * first

    def allocate(self, rows: tuple[int, int]) -> None:
        """Empty buffers for tile rows ``rows`` (first, count), replacing any before."""
        self.release()
        self.rows = (int(rows[0]), int(rows[1]))
        gl, n = self.gl, self.width * self.band_height
        self.sums = gl.buffer(reserve=SUM_BYTES * n)
        self.squares = gl.buffer(reserve=SQUARE_BYTES * n)
        self.aov = gl.buffer(reserve=AOV_BYTES * n if self.aovs else 16)
        self.debug = gl.buffer(reserve=4 * n if self.counting else 16)
        # splats land anywhere on the film: the whole image, two words per pixel and channel
        self.splat = gl.buffer(reserve=24 * self.width * self.height if self.splatting else 16)
        depth = self.strategy_depth
        self.strategies = gl.buffer(
            reserve=strategies.buffer_bytes(depth, self.width, self.height, self.strategy_merges)
            if depth else 16)
        for buf in self.buffers():
            buf.clear()

    def buffers(self) -> tuple[Any, ...]:
        return (self.sums, self.squares, self.aov, self.debug, self.splat, self.strategies)

    # -- binding ------------------------------------------------------------------------------
    def bind(self) -> None:
        """Bind every buffer to its storage-buffer slot (the per-pixel ones whole)."""
        self.bind_film()
        self.debug.bind_to_storage_buffer(bindings.SSBO_DEBUG_COUNTERS)
        self.splat.bind_to_storage_buffer(bindings.SSBO_ACCUM_SPLAT)
        if self.strategy_depth:
            self.strategies.bind_to_storage_buffer(bindings.SSBO_STRATEGY_IMAGES)

    def bind_film(self) -> None:
        """Bind the sums, squares and AOVs alone (what the preview's display reads)."""
        self.sums.bind_to_storage_buffer(bindings.SSBO_ACCUM_SUM)
        self.squares.bind_to_storage_buffer(bindings.SSBO_ACCUM_SQ)
        self.aov.bind_to_storage_buffer(bindings.SSBO_ACCUM_AOV)

    def _per_pixel(self) -> list[tuple[Any, int, int]]:
        """The per-pixel buffers in use: (buffer, bytes per pixel, binding)."""
        bufs = [(self.sums, SUM_BYTES, bindings.SSBO_ACCUM_SUM),
                (self.squares, SQUARE_BYTES, bindings.SSBO_ACCUM_SQ)]
        if self.aovs:
            bufs.append((self.aov, AOV_BYTES, bindings.SSBO_ACCUM_AOV))
        if self.counting:
            bufs.append((self.debug, 4, bindings.SSBO_DEBUG_COUNTERS))
        return bufs

    def slices(self) -> list[tuple[int, int]]:
        """The band's tile rows in slices (first row, rows) whose part of every per-pixel
        buffer fits one storage-buffer binding (llvmpipe: 128 MiB, so a film of more than
        2.1M pixels, or 0.84M with AOVs, takes several), each starting at an offset the
        device can bind."""
        limit = self.binding_limit()
        widest = max(bpp for _, bpp, _ in self._per_pixel())
        row_bytes = TILE * self.width * widest
        first, count = self.rows
        if row_bytes * count <= limit:
            return [(first, count)]
        align = max(1, int(_ssbo_alignment()))
        # rows of a slice: a multiple of k, so that every buffer's offset stays aligned
        smallest = min(bpp for _, bpp, _ in self._per_pixel())
        k = align // math.gcd(align, TILE * self.width * smallest)
        per = (limit // row_bytes) // k * k
        if per < 1:
            raise UsageError(f"a {self.width}-pixel-wide image does not fit this device's "
                             f"storage buffers ({limit} bytes a binding): render fewer columns")
        return [(r, min(per, first + count - r)) for r in range(first, first + count, per)]

    def bind_slice(self, first_row: int, n_rows: int) -> None:
        """Bind the part of the per-pixel buffers that holds tile rows [first_row, +n_rows)."""
        top = TILE * (first_row - self.rows[0])
        rows = min(self.height, TILE * (first_row + n_rows)) - TILE * first_row
        for buf, bpp, slot in self._per_pixel():
            buf.bind_to_storage_buffer(slot, offset=top * self.width * bpp,
                                       size=rows * self.width * bpp)

    def device_bytes_per_pixel(self) -> int:
        """Bytes of device memory per accumulated pixel: the per-pixel buffers, the
        whole-image splat and strategy images, and the copy that undoes a stopped pass."""
        per = sum(bpp for _, bpp, _ in self._per_pixel())
        if self.splatting:
            per += 24
        if self.strategy_depth:
            per += strategies.buffer_bytes(self.strategy_depth, 1, 1, self.strategy_merges)
        return 2 * per

    # -- undoing a stopped pass ------------------------------------------------------------
    def take_snapshot(self) -> None:
        """Copy every buffer (the kernel's writes so far made visible first)."""
        if self._snapshot is None:
            self._snapshot = [self.gl.buffer(reserve=buf.size) for buf in self.buffers()]
        self.gl.memory_barrier()
        for copy, buf in zip(self._snapshot, self.buffers()):
            self.gl.copy_buffer(copy, buf)

    def restore_snapshot(self) -> None:
        """Put the copies back: the accumulation as it was at :meth:`take_snapshot`."""
        assert self._snapshot is not None
        self.gl.memory_barrier()
        for copy, buf in zip(self._snapshot, self.buffers()):
            self.gl.copy_buffer(buf, copy)
        self.gl.finish()

    def release_snapshot(self) -> None:
        for copy in self._snapshot or ():
            copy.release()
        self._snapshot = None

    # -- reading back ----------------------------------------------------------------------
    @staticmethod
    def _words(buf: Any) -> np.ndarray:
        return np.frombuffer(buf.read(), np.uint32)

    def film(self, spp: int, paths: int, sampler: str, loop_counts: bool) -> Film:
        """The band as a :class:`Film` after ``spp`` samples per pixel, with the splatted
        part of ``paths`` light paths added (see :meth:`splat_image`) and, with
        ``loop_counts``, the debug counters as its loop counts."""
        h = self.band_height
        aov = self._words(self.aov) if self.aovs else None
        sums = self._words(self.sums)
        mean, m2, count, dropped, aov_means = accum.statistics(sums, self._words(self.squares), aov)
        mean = mean.reshape(h, self.width, 3)
        aovs = {}
        if aov_means is not None:
            aovs = accum.aov_images(aov_means, h, self.width)
        if self.splatting:
            first = TILE * self.rows[0]
            mean += self.splat_image(paths)[first:first + h]
        return Film(mean=mean, m2=m2.reshape(h, self.width, 3), count=count.reshape(h, self.width),
                    nonfinite=dropped.reshape(h, self.width), spp=spp, aovs=aovs,
                    truncated=accum.truncated(sums).reshape(h, self.width),
                    loop_counts=self.debug_counters() if loop_counts else None, sampler=sampler)

    def debug_counters(self) -> np.ndarray:
        """The per-pixel debug counter of the band, uint32 (H, W)."""
        h = self.band_height
        return self._words(self.debug)[:h * self.width].reshape(h, self.width).copy()

    def splat_image(self, paths: int) -> np.ndarray:
        """The splatted part of the image, (H, W, 3) float32: the fixed-point sums over the
        number of light paths splatted."""
        if not self.splatting:
            return np.zeros((self.height, self.width, 3), np.float32)
        sums = accum.fixed_sums(self._words(self.splat))
        image = sums.astype(np.float64) / (SPLAT_SCALE * max(paths, 1))
        return image.reshape(self.height, self.width, 3).astype(np.float32)

    def strategy_words(self) -> np.ndarray:
        return self._words(self.strategies)

    def load(self, sums: np.ndarray, squares: np.ndarray) -> None:
        """Replace the sums and sums of squares with words made elsewhere."""
        self.sums.write(np.ascontiguousarray(sums, np.uint32).tobytes())
        self.squares.write(np.ascontiguousarray(squares, np.uint32).tobytes())

    # -- checkpoints -----------------------------------------------------------------------
    def state(self) -> dict[str, np.ndarray]:
        """Every buffer as uint32 words (exact sums: those of disjoint sample ranges add up,
        accum.add, to the bits of one render of all of them)."""
        return {"sums": self._words(self.sums).copy(), "squares": self._words(self.squares).copy(),
                "aov": self._words(self.aov).copy(), "splat": self._words(self.splat).copy(),
                "strategies": self._words(self.strategies).copy()}

    def restore(self, state: dict[str, Any]) -> None:
        """Load :meth:`state`'s words, each checked against its buffer's size."""
        for name, buf in (("sums", self.sums), ("squares", self.squares), ("aov", self.aov)):
            self._write_checked(buf, state[name], f"{name} has")
        self._write_checked(self.splat, state.get("splat", np.zeros(self.splat.size // 4)),
                            "splat image has")
        if self.strategy_depth:
            self._write_checked(self.strategies, state.get("strategies", ()), "strategy images have")

    @staticmethod
    def _write_checked(buf: Any, words: Any, what: str) -> None:
        data = np.ascontiguousarray(words, np.uint32)
        if data.nbytes != buf.size:
            raise UsageError(f"the saved accumulation's {what} {data.nbytes} bytes, "
                             f"expected {buf.size}")
        buf.write(data.tobytes())

    def release(self) -> None:
        for buf in self.buffers():
            if buf is not None:
                buf.release()
        self.release_snapshot()
        self.sums = self.squares = self.aov = self.debug = self.splat = self.strategies = None


def _ssbo_alignment() -> int:
    from ..gl.egl import gl as raw_gl

    return int(raw_gl.get_integer(0x90DF))   # GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT
