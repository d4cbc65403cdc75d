"""The "compiling kernels" line of the commands that build kernels (render, preview, lab,
sampling):

    glrender: compiling kernels … 4.2 s (cached for next time)

A kernel's first use on llvmpipe can take seconds: the driver compiles and links the
program, and generates its machine code at the first dispatch (``glrender/gl/shaders.py``
reports both). The line counts the seconds of both, summed over every kernel built until
something else is printed, and appears once they pass :data:`THRESHOLD` (a kernel loaded
from Mesa's disk cache takes a fraction of that, so a warm run shows nothing).

On a terminal the line counts up while the driver works. The driver holds Python's global
interpreter lock through a compile and a first dispatch (measured: a Python thread that
ticks every 0.1 s ticked once in 7 s of building and first dispatch), so no thread of this
process could redraw it; a small child process (:class:`Ticker`) does, told by a pipe when
the clock runs and what it has counted, and ends when the pipe closes (the command's end
included, however it ends). Elsewhere the line is written once, when it is complete.

Anything else written to standard output or error first ends the line
(:func:`compile_notice` guards both streams), so the line never shares a row with the
render's own messages or its progress bar. A command that fails leaves its error as its
one line: the count not yet written is dropped (erased from a terminal).
"""
from __future__ import annotations

import subprocess
import sys
import time
from contextlib import contextmanager
from typing import Callable, Iterator, TextIO

#: Seconds of compiling after which the line appears.
THRESHOLD = 1.0

#: The line, with its seconds as a %-format.
TEXT = "glrender: compiling kernels \u2026 %.1f s"

#: The child that redraws the line on a terminal: reads "R SECONDS" (the clock runs from
#: SECONDS) and "P SECONDS" (it stands at SECONDS) from its stdin, draws TEXT % seconds on
#: its stderr ten times a second once past THRESHOLD, and exits at end of input.
_TICKER_SOURCE = r"""
import os, select, signal, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
threshold, text = float(sys.argv[1]), sys.argv[2]
counted, since, pending = 0.0, None, b""
while True:
    ready, _, _ = select.select([0], [], [], 0.1)
    if ready:
        data = os.read(0, 4096)
        if not data:
            break
        *lines, pending = (pending + data).split(b"\n")
        for line in lines:
            kind, _, value = line.partition(b" ")
            counted = float(value)
            since = time.monotonic() if kind == b"R" else None
    shown = counted + (time.monotonic() - since if since is not None else 0.0)
    if shown >= threshold:
        os.write(2, ("\r" + text % shown + "\033[K").encode("utf-8", "replace"))
"""


class Ticker:
    """The child process that redraws the line on the terminal ``stream`` while the
    driver holds the interpreter."""

    def __init__(self, stream: TextIO, threshold: float, text: str):
        stream.flush()
        self._proc = subprocess.Popen(
            [sys.executable, "-I", "-S", "-c", _TICKER_SOURCE, repr(threshold), text],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=stream.fileno(),
            close_fds=True)

    def _send(self, kind: str, seconds: float) -> None:
        try:
            assert self._proc.stdin is not None
            self._proc.stdin.write(f"{kind} {seconds:.6f}\n".encode())
            self._proc.stdin.flush()
        except OSError:         # the child is gone: the final line still comes
            pass

    def run(self, seconds: float) -> None:
        self._send("R", seconds)

    def pause(self, seconds: float) -> None:
        self._send("P", seconds)

    def stop(self) -> None:
        try:
            assert self._proc.stdin is not None
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()


class CompileNotice:
    """Counts the seconds the driver spends compiling (a :class:`CompileListener` of
    ``glrender.gl.shaders``) and shows them on ``stream``.

    ``live``: redraw the line while counting (default: when ``stream`` is a terminal);
    ``cached``: Mesa keeps what it compiled for the next run, and the line says so;
    ``clock`` and ``ticker`` (a factory of :class:`Ticker`-like objects) are for tests.
    """

    def __init__(self, stream: TextIO, *, live: bool | None = None, cached: bool = True,
                 threshold: float | None = None, clock: Callable[[], float] = time.monotonic,
                 ticker: Callable[[TextIO, float, str], Ticker] | None = None):
        self.stream = stream
        self.live = _isatty(stream) if live is None else live
        self.cached, self.clock = cached, clock
        self.threshold = THRESHOLD if threshold is None else threshold
        self._make_ticker = Ticker if ticker is None else ticker
        self._ticker: Ticker | None = None
        self._counted = 0.0           # seconds of the line's finished compiles
        self._since: float | None = None
        self._depth = 0

    def text(self, seconds: float, done: bool = False) -> str:
        cached = " (cached for next time)" if done and self.cached else ""
        return TEXT % seconds + cached

    @property
    def seconds(self) -> float:
        """The seconds counted on the line so far."""
        running = self.clock() - self._since if self._since is not None else 0.0
        return self._counted + running

    def started(self) -> None:
        self._depth += 1
        if self._depth > 1:
            return
        self._since = self.clock()
        if self.live:
            if self._ticker is None:
                try:
                    self._ticker = self._make_ticker(self.stream, self.threshold, TEXT)
                except (OSError, ValueError):       # no child process: the line at the end
                    self.live = False
            if self._ticker is not None:
                self._ticker.run(self._counted)

    def stopped(self) -> None:
        self._depth = max(self._depth - 1, 0)
        if self._depth or self._since is None:
            return
        self._counted += self.clock() - self._since
        self._since = None
        if self._ticker is not None:
            self._ticker.pause(self._counted)

    def close(self) -> None:
        """End the line: write its final text once past the threshold, and start a new
        count. Called before anything else is written, and at the end."""
        if self._since is None and self._counted == 0.0 and self._ticker is None:
            return
        seconds = self.seconds
        if self._since is not None:          # ended inside a compile (an error, a signal)
            self._counted, self._since = seconds, self.clock()
        ticker, self._ticker = self._ticker, None
        if ticker is not None:
            ticker.stop()
        if seconds >= self.threshold:
            text = self.text(seconds, done=self._since is None)
            self.stream.write(f"\r{text}\033[K\n" if self.live else f"{text}\n")
            self.stream.flush()
        self._counted = 0.0

    def discard(self) -> None:
        """The command failed: its error is the one line it leaves, so the count is erased
        from the terminal and not written elsewhere."""
        shown = self.live and self._ticker is not None and self.seconds >= self.threshold
        ticker, self._ticker = self._ticker, None
        if ticker is not None:
            ticker.stop()
        if shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
        self._counted, self._since = 0.0, None


class _Guarded:
    """A text stream that ends the compile line before anything is written to it."""

    def __init__(self, stream: TextIO, notice: CompileNotice):
        self._stream, self._notice = stream, notice

    def write(self, text: str) -> int:
        if text:
            self._notice.close()
        return self._stream.write(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


@contextmanager
def compile_notice(enabled: bool = True, **options) -> Iterator[CompileNotice | None]:
    """Show the compiling line on standard error for the commands run inside the block
    (nothing when not ``enabled``, e.g. under --quiet)."""
    if not enabled or sys.stderr is None:
        yield None
        return
    from ..gl.context import shader_cache_location
    from ..gl.shaders import compile_listener

    stderr, stdout = sys.stderr, sys.stdout
    options.setdefault("cached", shader_cache_location() != "disabled")
    notice = CompileNotice(stderr, **options)
    sys.stderr = _Guarded(stderr, notice)            # type: ignore[assignment]
    if stdout is not None:
        sys.stdout = _Guarded(stdout, notice)        # type: ignore[assignment]
    try:
        with compile_listener(notice):
            yield notice
    except BaseException:
        sys.stderr, sys.stdout = stderr, stdout
        notice.discard()
        raise
    sys.stderr, sys.stdout = stderr, stdout
    notice.close()
