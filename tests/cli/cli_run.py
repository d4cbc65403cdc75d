"""Running the command line in a subprocess, as users do, and the in-process reference."""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"
COMMAND = [sys.executable, "-m", "glrender"]


def glrender(*args, timeout: float = 120, **kwargs) -> subprocess.CompletedProcess:
    """``python -m glrender ARGS``, its output captured as text."""
    return subprocess.run([*COMMAND, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, **kwargs)


class Running:
    """A ``glrender`` process in the background whose stderr lines are collected."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([*COMMAND, *map(str, args)], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, text: str, timeout: float = 60) -> None:
        end = time.monotonic() + timeout
        while not any(text in line for line in self.lines):
            if self.proc.poll() is not None or time.monotonic() > end:
                raise AssertionError(f"no {text!r} from glrender; stderr: {self.lines}")
            time.sleep(0.01)

    def wait(self, timeout: float = 60) -> int:
        rc = self.proc.wait(timeout=timeout)
        self._reader.join(timeout=5)
        self.proc.stdout.close()
        self.proc.stderr.close()
        return rc

    @property
    def stderr(self) -> str:
        return "\n".join(self.lines)


def reference_film(scene_path=CORNELL, *, width: int, height: int, spp: int, seed: int = 0,
                   aovs: bool = False, **overrides):
    """The same render in this process through the Python API (same device, same bits)."""
    import glrender
    from glrender.render.renderer import Renderer, settings_from_scene

    scene = glrender.load(scene_path)
    scene.film = replace(scene.film, width=width, height=height)
    settings = settings_from_scene(scene, spp=spp, seed=seed, aovs=aovs, **overrides)
    renderer = Renderer(scene, settings)
    try:
        renderer.step(spp)
        return renderer.film()
    finally:
        renderer.release()


def one_error_line(result: subprocess.CompletedProcess) -> str:
    """The single stderr line of a failed command (exit 2, no traceback)."""
    assert result.returncode == 2, (result.returncode, result.stderr)
    assert "Traceback" not in result.stderr, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]
