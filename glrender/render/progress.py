"""A one-line terminal progress bar for renders.

    [#########...........]  24/64 spp  2.31 Msamples/s  0:03 elapsed  ETA 0:05

Redrawn in place (carriage return) at most ``max_rate`` times a second, fitted to the
terminal's width. With a time budget the bar and the ETA follow whichever of the sample
target and the budget ends first.

:class:`UnitsBar` is the line of a render whose samples run elsewhere in units (a cluster):

    [##########....................] 5/16 units  2.31 Msamples/s  0:03 elapsed
"""
from __future__ import annotations

import shutil
import time


def format_seconds(seconds: float) -> str:
    """0:07, 1:02:03."""
    s = int(max(seconds, 0.0) + 0.5)
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class ProgressBar:
    def __init__(self, stream, *, pixels: int, spp_start: int, spp_target: int | None,
                 seconds: float | None = None, max_rate: float = 10.0, clock=time.monotonic):
        self.stream, self.pixels = stream, pixels
        self.spp_start, self.spp_target, self.seconds = spp_start, spp_target, seconds
        self.min_interval = 1.0 / max_rate
        self.clock = clock
        self._last_draw = None
        self._drawn = False

    def line(self, spp_done: int, elapsed: float, width: int) -> str:
        """The bar's text for ``spp_done`` samples per pixel after ``elapsed`` seconds."""
        new = spp_done - self.spp_start
        rate = new * self.pixels / elapsed if elapsed > 0 else 0.0
        fractions, etas = [], []
        if self.spp_target:
            fractions.append((spp_done - self.spp_start) / max(self.spp_target - self.spp_start, 1))
            if new > 0:
                etas.append((self.spp_target - spp_done) * elapsed / new)
        if self.seconds:
            fractions.append(elapsed / self.seconds)
            etas.append(self.seconds - elapsed)
        fraction = min(max(max(fractions, default=0.0), 0.0), 1.0)
        total = f"/{self.spp_target}" if self.spp_target else ""
        eta = f"ETA {format_seconds(min(etas))}" if etas else "ETA ?"
        text = (f" {spp_done}{total} spp  {rate / 1e6:.2f} Msamples/s  "
                f"{format_seconds(elapsed)} elapsed  {eta}")
        bar_width = max(10, min(40, width - len(text) - 3))
        filled = int(round(bar_width * fraction))
        return f"[{'#' * filled}{'.' * (bar_width - filled)}]{text}"

    def update(self, spp_done: int, elapsed: float, force: bool = False) -> None:
        now = self.clock()
        if not force and self._last_draw is not None and now - self._last_draw < self.min_interval:
            return
        self._last_draw = now
        width = shutil.get_terminal_size((80, 24)).columns
        text = self.line(spp_done, elapsed, width)[:max(width - 1, 20)]
        self.stream.write("\r" + text + "\033[K")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """End the bar's line (the summary goes below it)."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False


class UnitsBar:
    """One aggregated line: units finished of all, samples/s over the cluster."""

    def __init__(self, stream, clock=time.monotonic):
        self.stream, self.clock, self.last = stream, clock, 0.0

    def update(self, done: int, total: int, pixel_samples: int, seconds: float,
               force: bool = False) -> None:
        now = self.clock()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        width = 30
        filled = int(round(width * done / max(total, 1)))
        rate = pixel_samples / seconds / 1e6 if seconds > 0 else 0.0
        self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} units  "
                          f"{rate:.2f} Msamples/s  {format_seconds(seconds)} elapsed\033[K")
        self.stream.flush()

    def close(self) -> None:
        self.stream.write("\n")
        self.stream.flush()
