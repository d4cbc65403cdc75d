"""``glrender preview`` without a window: help, option errors, no display (one line, exit 2)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from glrender.preview.keys import KEYS, MOUSE, key_label

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"


def preview(*args, display: str | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    if display is not None:
        env["DISPLAY"] = display
    return subprocess.run([sys.executable, "-m", "glrender", "preview", *map(str, args)],
                          capture_output=True, text=True, timeout=120, env=env)


def test01_help_lists_every_key():
    out = preview("--help")
    assert out.returncode == 0
    for names, _, text in KEYS:
        assert f"{key_label(names)}" in out.stdout and text in out.stdout, names
    for gesture, text in MOUSE:
        assert gesture in out.stdout and text in out.stdout
    assert "xvfb-run" in out.stdout and "exit codes" in out.stdout


@pytest.mark.parametrize("display,why", [
    (None, "DISPLAY is not set"),
    (":1999", "cannot open the display :1999"),   # no X server there
])
def test02_without_a_display_one_line_exit_2(display, why):
    out = preview(CORNELL, display=display)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith("glrender: error: ") and why in lines[0]
    assert "glrender render" in lines[0] and "xvfb-run" in lines[0]
    assert out.stdout == ""


@pytest.mark.parametrize("args,message", [
    (("--spp", "0"), "--spp 0: expected a positive number"),
    (("--frame-budget", "0"), "--frame-budget 0.0: expected milliseconds"),
    (("--max-depth", "0"), "--max-depth 0: expected -1"),
    (("--device", "1"), "device 1: an EGL device index picks a headless device"),
])
def test03_option_errors(args, message):
    out = preview(CORNELL, *args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], out.stderr


def test04_missing_scene_before_the_window():
    out = preview(ROOT / "no-such-scene.toml")
    assert out.returncode == 2 and "no such scene file" in out.stderr
