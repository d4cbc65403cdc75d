"""The progress bar on a terminal, the summary line, and --quiet."""
from __future__ import annotations

import os
import pty
import re
import subprocess

from cli_run import COMMAND, CORNELL, glrender
from glrender.render.progress import ProgressBar, format_seconds


def run_on_terminal(*args, timeout=120) -> tuple[int, str]:
    """Run glrender with stderr on a pseudo-terminal; return (exit code, what it showed)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([*COMMAND, *map(str, args)], stdout=subprocess.DEVNULL, stderr=slave,
                            env={**os.environ, "COLUMNS": "100"})
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:          # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return proc.wait(timeout=timeout), b"".join(chunks).decode(errors="replace")


def test01_bar_on_a_terminal(tmp_path):
    out = tmp_path / "p.png"
    rc, shown = run_on_terminal("render", CORNELL, "-o", out, "--width", 64, "--height", 64,
                                "--spp", 256)
    assert rc == 0, shown
    frames = [f for f in re.split(r"[\r\n]", shown) if f.startswith("[")]
    assert len(frames) >= 2                        # drawn at the start and at the end
    last = frames[-1]
    assert re.search(r"\[#+\] 256/256 spp  \d+\.\d\d Msamples/s  \d+:\d\d elapsed  ETA 0:00", last), last
    summary = shown.strip().splitlines()[-1]
    assert re.fullmatch(rf"glrender: 256 spp in \d+\.\d\d s \(\d+\.\d\d Mpaths/s\), "
                        rf"0 non-finite samples -> {re.escape(str(out))}", summary), summary


def test02_plain_output_and_quiet(tmp_path):
    r = glrender("render", CORNELL, "-o", tmp_path / "p.png", "--width", 16, "--height", 16,
                 "--spp", 8)
    assert r.returncode == 0 and r.stdout == ""
    lines = r.stderr.strip().splitlines()          # no bar when stderr is not a terminal
    lines = [line for line in lines                # (a cold compile adds its line first)
             if not (line is lines[0] and line.startswith("glrender: compiling kernels"))]
    assert len(lines) == 2 and lines[0].startswith("glrender: rendering") and "8 spp in" in lines[1]
    rc, shown = run_on_terminal("render", CORNELL, "-o", tmp_path / "q.png", "--width", 16,
                                "--height", 16, "--spp", 8, "--quiet")
    assert rc == 0 and shown == ""


class _Stream:
    def __init__(self):
        self.text = ""

    def write(self, s):
        self.text += s

    def flush(self):
        pass


def test03_bar_text():
    bar = ProgressBar(_Stream(), pixels=1_000_000, spp_start=0, spp_target=64)
    line = bar.line(16, 2.0, width=100)
    assert line.endswith("16/64 spp  8.00 Msamples/s  0:02 elapsed  ETA 0:06")
    assert line.count("#") == 10 and len(line) <= 100
    timed = ProgressBar(_Stream(), pixels=100, spp_start=8, spp_target=None, seconds=10.0)
    line = timed.line(24, 4.0, width=80)
    bar_width = line.index("]") - 1
    assert "] 24 spp " in line and line.endswith("ETA 0:06")          # the budget's end
    assert line.count("#") == round(0.4 * bar_width)                  # 4 of 10 s
    assert format_seconds(3725) == "1:02:05" and format_seconds(7.4) == "0:07"


def test04_throttled():
    stream = _Stream()
    t = [0.0]
    bar = ProgressBar(stream, pixels=1, spp_start=0, spp_target=8, clock=lambda: t[0])
    bar.update(1, 0.01)
    bar.update(2, 0.02)                 # within 0.1 s of the last draw: skipped
    t[0] = 0.2
    bar.update(3, 0.2)
    assert stream.text.count("\r") == 2
    bar.update(8, 0.21, force=True)
    bar.close()
    assert stream.text.count("\r") == 3 and stream.text.endswith("\n")
