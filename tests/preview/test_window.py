"""The preview in a real window under Xvfb, driven by real X events (xdotool).

One preview process of the Cornell box (96x96, --spp 64) serves the tests in order:
a screenshot through the preview's own key against headless renders of the same
view; a mouse drag that orbits; keys that change the settings in the title; closing
the window. Error bars come from headless renders with independent seeds (Owen-
scrambled Sobol': each seed is one full randomization), never from the render's own
per-sample variance.
"""
from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import glrender
from glrender.film.io import read_exr_layers
from glrender.film.tonemap import tonemap
from glrender.gl.context import default_context
from glrender.gpu.pack import pack_scene
from glrender.preview.camera import ORBIT_RADIANS_PER_PIXEL, ZOOM_PER_STEP
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.testing.images import compare_images
from preview_x11 import Xvfb, capture, missing_tools, request_close, window_name, wait_for, xdotool

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"
SIZE, SPP = 96, 64
SEEDS = (101, 102, 103, 104)     # headless renders for error bars (the preview uses the scene's 0)
STARTUP = 120.0                  # seconds: a cold shader cache on a busy 2-core machine
# 3 comparisons with a headless reference (first, orbited, zoomed view) share alpha = 0.01
COMPARISONS = 3


class Preview:
    """A ``glrender preview`` process, its stdout lines and its X window."""

    def __init__(self, display: str, *args):
        self.display = display
        env = dict(os.environ, DISPLAY=display)
        env.pop("WAYLAND_DISPLAY", None)
        self.proc = subprocess.Popen([sys.executable, "-m", "glrender", "preview", *map(str, args)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env=env)
        self.lines: list[str] = []
        self.errors: list[str] = []
        self._readers = [threading.Thread(target=self._read, args=(stream, sink), daemon=True)
                         for stream, sink in ((self.proc.stdout, self.lines),
                                              (self.proc.stderr, self.errors))]
        for reader in self._readers:
            reader.start()
        line = self.wait_line(r"preview of .* window (0x[0-9a-f]+)", STARTUP)
        self.window = int(re.search(r"window (0x[0-9a-f]+)", line).group(1), 16)

    @staticmethod
    def _read(stream, sink):
        for line in stream:
            sink.append(line.rstrip("\n"))

    def wait_line(self, pattern: str, timeout: float, start: int = 0) -> str:
        def found():
            exited = self.proc.poll() is not None
            if exited:   # read to the end of its output first
                for reader in self._readers:
                    reader.join(5)
            line = next((line for line in self.lines[start:] if re.search(pattern, line)), None)
            if line is None and exited:
                raise AssertionError(f"preview exited ({self.proc.returncode}): {self.errors}")
            return line
        return wait_for(found, timeout, what=f"{pattern!r} in {self.lines} {self.errors}")

    def title(self) -> str:
        return window_name(self.display, str(self.window))

    def wait_title(self, text: str, timeout: float = 60.0) -> str:
        """The title once it contains ``text`` (and the kernel is not compiling)."""
        def ready():
            t = self.title()
            return t if text in t and "compiling" not in t else None
        return wait_for(ready, timeout, what=f"{text!r} in the title (now {self.title()!r})")

    def key(self, *names: str) -> None:
        xdotool(self.display, "mousemove", "--window", str(self.window), "20", "20")
        xdotool(self.display, "key", "--delay", "30", *names)

    def drag(self, start: tuple[int, int], dx: int, dy: int, steps: int = 10) -> None:
        w = str(self.window)
        xdotool(self.display, "mousemove", "--window", w, *map(str, start))
        xdotool(self.display, "mousedown", "1")
        for i in range(1, steps + 1):
            x, y = start[0] + dx * i // steps, start[1] + dy * i // steps
            xdotool(self.display, "mousemove", "--window", w, str(x), str(y))
            time.sleep(0.02)
        xdotool(self.display, "mouseup", "1")

    def screenshot(self, timeout: float = 60.0) -> dict:
        """Press the screenshot key; the files it wrote, read back."""
        start = len(self.lines)
        self.key("p")
        line = self.wait_line(r"screenshot at \d+ spp -> ", timeout, start)
        png, hdr, meta = line.split(" -> ")[1].split(", ")
        return {"png": np.asarray(Image.open(png).convert("RGB")), "layers": read_exr_layers(hdr),
                "meta": json.loads(Path(meta).read_text()), "paths": (png, hdr, meta)}


@pytest.fixture(scope="module")
def xserver():
    missing = missing_tools()
    if missing:
        pytest.skip(f"{' and '.join(missing)} not installed (./dev.sh test installs them)")
    server = Xvfb()
    yield server
    server.close()


@pytest.fixture(scope="module")
def preview(xserver, tmp_path_factory):
    out = tmp_path_factory.mktemp("preview")
    p = Preview(xserver.display, CORNELL, "--width", SIZE, "--height", SIZE, "--spp", SPP,
                "--screenshot-dir", out / "shots", "--record", out / "frames")
    p.out = out
    yield p
    if p.proc.poll() is None:
        p.proc.kill()
        p.proc.wait()


def _headless(meta: dict, seeds) -> np.ndarray:
    """Renders of the screenshot's view and settings with other seeds: (k, H, W, 3)."""
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=meta["width"], height=meta["height"])
    close = meta["world_from_camera_close"]
    scene.camera = replace(scene.camera, world_from_camera=np.array(meta["world_from_camera"]),
                           world_from_camera_close=None if close is None else np.array(close))
    images = []
    for seed in seeds:
        settings = settings_from_scene(scene, integrator=meta["integrator"], strategy=meta["strategy"],
                                       max_depth=meta["max_depth"], sampler=meta["sampler"],
                                       seed=seed, spp=meta["spp"])
        r = Renderer(scene, settings)
        try:
            r.step(meta["spp"])
            images.append(r.film().mean)
        finally:
            r.release()
    return np.stack(images)


def _check_against_headless(shot: dict) -> None:
    """The screenshot's accumulation is a render of the view it names: compared block by
    block with headless renders of other seeds. The screenshot has the noise of one render
    at the same spp, estimated from the spread of the seeds."""
    meta = shot["meta"]
    renders = _headless(meta, SEEDS)
    image = shot["layers"]["RGB"]
    sigma = renders.std(axis=0, ddof=1)
    # Sidak over all comparisons: each tests 3 channels x 36 blocks and 2 image means
    result = compare_images(renders, image, reference_stderr=sigma, block=16,
                            extra_tests=(COMPARISONS - 1) * (2 + 3 * (SIZE // 16) ** 2))
    # smallest bias this sees: ~z x sigma of the image mean, printed on failure
    assert result.passed, result.summary() + "; " + "; ".join(result.messages)
    # sees a bias of the image mean of ~0.3% (printed in the summary), and a few percent per block
    assert result.detectable_bias < 0.01, result.summary()


def test01_screenshot_matches_a_headless_render(preview):
    title = preview.wait_title(f"{SPP}/{SPP} spp - done")
    assert "cornell-box - path, mis-power, depth 8 - color, clamp, +0.0 EV" in title
    shot = preview.screenshot()
    meta, layers, png = shot["meta"], shot["layers"], shot["png"]
    assert meta["spp"] == SPP and (meta["width"], meta["height"]) == (SIZE, SIZE)
    np.testing.assert_array_equal(np.array(meta["world_from_camera"]),
                                  glrender.load(CORNELL).camera.world_from_camera)
    mean = layers["RGB"]
    assert mean.shape == (SIZE, SIZE, 3) and np.isfinite(mean).all()
    # not black: the box fills ~95% of the view (a thin black frame around it)
    assert mean.mean() > 0.1 and (mean.max(axis=2) > 0.01).mean() > 0.9
    assert {"variance", "albedo", "normal", "depth"} <= set(layers)
    # the PNG is the accumulation through the display transform (GLSL float32 vs numpy
    # float64: at most 1 step of 8 bits, rarely)
    diff = np.abs(png.astype(int) - tonemap(mean).astype(int))
    assert diff.max() <= 1 and (diff > 0).mean() < 0.002
    # the window shows it: 5x zoom (window 480x480), nearest
    shown = capture(preview.display, preview.window)
    assert shown.shape == (480, 480, 3)
    np.testing.assert_array_equal(shown, np.repeat(np.repeat(png, 5, axis=0), 5, axis=1))
    _check_against_headless(shot)
    # the same seed headless: on the same driver the progressive frames add up bitwise to it
    same = _headless(meta, [meta["seed"]])[0]
    if meta["gl_version"] == default_context().gl.info["GL_VERSION"]:
        np.testing.assert_array_equal(same, mean)
    preview.first = shot


def test02_drag_orbits(preview):
    first = getattr(preview, "first", None) or preview.screenshot()
    preview.key("space")                     # paused: the restart after the drag is visible
    preview.wait_title("- paused")
    preview.drag((200, 240), 60, 0)
    preview.wait_title(f"0/{SPP} spp - paused")
    preview.key("space")
    preview.wait_title(f"{SPP}/{SPP} spp - done")
    second = preview.screenshot()
    # the camera turned about the up axis by the drag's 60 pixels
    m0, m1 = (np.array(s["meta"]["world_from_camera"]) for s in (first, second))
    up = m0[:3, 1] / np.linalg.norm(m0[:3, 1])
    f0, f1 = (m[:3, 2] / np.linalg.norm(m[:3, 2]) for m in (m0, m1))
    flat0, flat1 = (f - up * np.dot(f, up) for f in (f0, f1))
    angle = math.acos(np.dot(flat0, flat1) / np.linalg.norm(flat0) / np.linalg.norm(flat1))
    assert abs(angle - 60 * ORBIT_RADIANS_PER_PIXEL) < 1e-5
    np.testing.assert_allclose(np.dot(f1, up), np.dot(f0, up), atol=1e-9)   # no pitch
    # the views differ by far more than their noise (both: one render at 64 spp)
    a, b = first["layers"]["RGB"], second["layers"]["RGB"]
    noise = 2 * _headless(first["meta"], SEEDS[:2]).var(axis=0).mean()
    assert ((a - b) ** 2).mean() > 20 * noise
    _check_against_headless(second)


def test03_wheel_zooms_while_rendering(preview):
    """R restarts from the scene's camera; three wheel steps arrive while it renders (each a
    restart in the middle of a pass); the converged image is a render of the zoomed view."""
    home = glrender.load(CORNELL).camera.world_from_camera
    preview.key("r")
    xdotool(preview.display, "click", "--repeat", "3", "--delay", "60", "4")
    for _ in range(3):   # the title may still show the previous view's "done" for a frame
        preview.wait_title(f"{SPP}/{SPP} spp - done")
        shot = preview.screenshot()
        m = np.array(shot["meta"]["world_from_camera"])
        if shot["meta"]["spp"] == SPP and not np.allclose(m[:3, 3], home[:3, 3]):
            break
    assert shot["meta"]["spp"] == SPP
    # toward the target along the unchanged view direction, 0.85^3 of the distance
    np.testing.assert_allclose(m[:3, :3], home[:3, :3], atol=1e-12)
    forward = home[:3, 2] / np.linalg.norm(home[:3, 2])
    center, _ = pack_scene(glrender.load(CORNELL)).sphere_bounds
    distance = np.dot(center - home[:3, 3], forward)
    np.testing.assert_allclose(m[:3, 3], home[:3, 3] + forward * distance * (1 - ZOOM_PER_STEP ** 3),
                               atol=1e-9)
    _check_against_headless(shot)


def test04_w_flies_forward(preview):
    """Holding W moves eye and target along the view at half the scene's radius per second."""
    before = np.array(preview.screenshot()["meta"]["world_from_camera"])
    preview.key("space")
    preview.wait_title("- paused")
    xdotool(preview.display, "keydown", "w")
    time.sleep(0.4)
    xdotool(preview.display, "keyup", "w")
    preview.wait_title(f"0/{SPP} spp - paused")
    preview.key("space")
    preview.wait_title(f"{SPP}/{SPP} spp - done")
    after = np.array(preview.screenshot()["meta"]["world_from_camera"])
    np.testing.assert_allclose(after[:3, :3], before[:3, :3], atol=1e-12)
    forward = before[:3, 2] / np.linalg.norm(before[:3, 2])
    step = after[:3, 3] - before[:3, 3]
    np.testing.assert_allclose(step, forward * np.dot(step, forward), atol=1e-9)
    _, radius = pack_scene(glrender.load(CORNELL)).sphere_bounds
    # 0.4 s held, give or take the frames that saw the key down (and the xdotool calls)
    assert 0.5 * radius * 0.2 < np.dot(step, forward) < 0.5 * radius * 1.0


def test05_keys_change_the_title(preview):
    """Each key's effect, in sequence, as the title shows it (integrator, strategy and
    depth changes compile a new kernel first)."""
    steps = [
        (("m",), "- path, light, depth 8 -"),
        (("m", "m"), "- path, mis-balance, depth 8 -"),
        (("bracketleft",), "- path, mis-balance, depth 7 -"),
        (("bracketright", "bracketright"), "- path, mis-balance, depth 9 -"),
        (("v",), "- albedo, clamp, +0.0 EV -"),
        (("4",), "- variance, clamp, +0.0 EV -"),
        (("1", "t", "equal"), "- color, filmic, +0.5 EV -"),
        (("i",), "- direct, mis-balance - color"),
        (("I",), "- path, mis-balance, depth 9 -"),
    ]
    for keys, expected in steps:
        assert expected not in preview.title()
        preview.key(*keys)
        preview.wait_title(expected)


def test06_recorded_frames(preview):
    frames = sorted((preview.out / "frames").glob("frame-*.png"))
    assert len(frames) > 10
    first = getattr(preview, "first", None)
    if first is not None:   # the frame on screen when the first screenshot was taken
        assert any(np.array_equal(np.asarray(Image.open(f).convert("RGB")), first["png"])
                   for f in frames)


def test07_closing_the_window_exits_0(preview):
    start = len(preview.lines)
    t0 = time.monotonic()
    request_close(preview.display, preview.window)
    code = preview.proc.wait(timeout=10)
    elapsed = time.monotonic() - t0
    assert code == 0, preview.errors
    assert elapsed < 2.0, elapsed
    preview.wait_line("preview closed at", 5, start)
    assert not [e for e in preview.errors if "error" in e.lower() or "Traceback" in e], preview.errors
