"""The "compiling kernels" line: what it counts, when it shows, and on a terminal."""
from __future__ import annotations

import io
import re
import sys

import pytest

from cli_run import CORNELL
from test_cli_progress import run_on_terminal
from glrender.commands import compile_notice as cn


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class _Ticker:
    """Records what the notice tells the child process."""
    made: list["_Ticker"] = []

    def __init__(self, stream, threshold, text):
        self.calls = [("make", threshold, text)]
        _Ticker.made.append(self)

    def run(self, seconds):
        self.calls.append(("run", seconds))

    def pause(self, seconds):
        self.calls.append(("pause", seconds))

    def stop(self):
        self.calls.append(("stop",))


def _compile(notice, clock, seconds, nested=False):
    notice.started()
    if nested:                     # a build inside a build counts once
        notice.started()
        notice.stopped()
    clock.now += seconds
    notice.stopped()


@pytest.mark.parametrize("live, cached, steps, shown", [
    # a build and a first dispatch with host work between them: only the two count
    (False, True, [2.0, 1.5], "glrender: compiling kernels \u2026 3.5 s (cached for next time)\n"),
    (False, False, [0.5, 0.75], "glrender: compiling kernels \u2026 1.2 s\n"),
    (False, True, [0.25, 0.5], ""),                  # a warm cache: under the threshold
    (True, True, [2.0], "\rglrender: compiling kernels \u2026 2.0 s (cached for next time)\x1b[K\n"),
])
def test01_counts_compiles_until_closed(live, cached, steps, shown):
    clock, stream = _Clock(), io.StringIO()
    _Ticker.made.clear()
    notice = cn.CompileNotice(stream, live=live, cached=cached, threshold=1.0, clock=clock,
                              ticker=_Ticker)
    for seconds in steps:
        _compile(notice, clock, seconds, nested=True)
        clock.now += 10.0                                 # not counted
    assert notice.seconds == pytest.approx(sum(steps))
    assert stream.getvalue() == ""                        # nothing before the line ends
    notice.close()
    assert stream.getvalue() == shown
    notice.close()                                        # ended once
    assert stream.getvalue() == shown
    if live:       # one child per line, told when the clock runs and what it has counted
        [ticker] = _Ticker.made
        assert ticker.calls == [("make", 1.0, cn.TEXT), ("run", 0.0), ("pause", 2.0), ("stop",)]
    else:
        assert _Ticker.made == []


def test02_other_output_ends_the_line(capsys):
    clock = _Clock()
    with cn.compile_notice(live=False, cached=True, clock=clock) as notice:
        _compile(notice, clock, 4.2)
        print("glrender: rendering", file=sys.stderr)
        _compile(notice, clock, 0.5)                      # a second line, under the threshold
        print("/out")
    assert not isinstance(sys.stderr, cn._Guarded)
    captured = capsys.readouterr()
    assert captured.err == ("glrender: compiling kernels \u2026 4.2 s (cached for next time)\n"
                            "glrender: rendering\n")
    assert captured.out == "/out\n"
    with cn.compile_notice(enabled=False) as notice:     # --quiet
        assert notice is None and not isinstance(sys.stderr, cn._Guarded)


def test03_interrupted_inside_a_compile():
    clock, stream = _Clock(), io.StringIO()
    notice = cn.CompileNotice(stream, live=False, cached=True, clock=clock)
    notice.started()
    clock.now += 3.0
    notice.close()                                        # no "cached": it did not finish
    assert stream.getvalue() == "glrender: compiling kernels \u2026 3.0 s\n"


def test04_command_line(tmp_path, monkeypatch, capsys):
    """Every command runs inside the notice: a render's line comes before its first line."""
    from glrender.commands.cli import main

    monkeypatch.setattr(cn, "THRESHOLD", 0.0)
    assert main(["render", str(CORNELL), "-o", str(tmp_path / "a.png"), "--width", "8",
                 "--height", "8", "--spp", "1", "--integrator", "ao"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert re.fullmatch(r"glrender: compiling kernels \u2026 \d+\.\d s( \(cached for next time\))?",
                        lines[0]), lines
    assert lines[1].startswith("glrender: rendering") and len(lines) == 3
    assert main(["render", str(CORNELL), "-o", str(tmp_path / "b.png"), "--width", "8",
                 "--height", "8", "--spp", "1", "--integrator", "ao", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test05_counts_up_on_a_terminal(tmp_path, monkeypatch):
    """A cold compile (Mesa's cache off, on llvmpipe): the line counts up while the driver
    holds the interpreter, then ends before the render's own lines. The line shows from the
    start here (threshold 0), so a fast machine counts too."""
    import test_cli_progress

    monkeypatch.setenv("MESA_SHADER_CACHE_DISABLE", "1")
    monkeypatch.setattr(test_cli_progress, "COMMAND", [
        sys.executable, "-c", "import sys; from glrender.commands import compile_notice as cn; "
        "cn.THRESHOLD = 0.0; from glrender.commands.cli import main; sys.exit(main())"])
    rc, shown = run_on_terminal("render", CORNELL, "-o", tmp_path / "t.png", "--width", 8,
                                "--height", 8, "--spp", 1, "--integrator", "ao", "--device", "cpu")
    assert rc == 0, shown
    frames = [f for f in re.split(r"[\r\n]", shown) if f.startswith("glrender: compiling")]
    counts = [float(re.search(r"\u2026 (\d+\.\d) s", f).group(1)) for f in frames]
    assert len(set(counts)) >= 2 and counts == sorted(counts), frames
    final = frames[-1].replace("\x1b[K", "")
    assert re.fullmatch(r"glrender: compiling kernels \u2026 \d+\.\d s", final), frames
    assert shown.index(final) < shown.index("glrender: rendering")


@pytest.mark.parametrize("live", [False, True])
def test06_a_failed_command_leaves_only_its_error(live):
    clock, stream = _Clock(), io.StringIO()
    _Ticker.made.clear()
    notice = cn.CompileNotice(stream, live=live, cached=True, clock=clock, ticker=_Ticker)
    _compile(notice, clock, 5.0)
    notice.discard()
    assert stream.getvalue() == ("\r\x1b[K" if live else "")
    assert [c[0] for c in _Ticker.made[0].calls][-1] == "stop" if live else _Ticker.made == []
