"""The preview window: progressive rendering you can steer.

One thread owns the window's OpenGL context and runs the frame loop: poll input,
move the camera, add samples for about one frame budget (:mod:`.progressive`),
draw the accumulation through the display pass (:mod:`.display`), swap. Any camera
change restarts the accumulation; a change of integrator, strategy or max depth
builds a new renderer (a new kernel; the title says so while it compiles). The
title shows the settings, the samples per pixel and the samples per second.
"""
from __future__ import annotations

import json
import sys
import time
from collections import deque
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..film.io import WriteError
from ..film.tonemap import TONE_CURVES
from ..render.params import STRATEGIES
from .. import integrators
from ..drivers import create_driver
from ..photon import PhotonSettings
from ..render.driver import RenderDriver
from ..render.job import JobOptions, job_settings, make_driver
from ..render.renderer import camera_screen
from ..scene import model as m
from .camera import CameraController
from .display import VIEWS, Display, DisplaySettings, fit_viewport
from .keys import bindings, help_text
from .progressive import Progressive, SppmProgressive

INTEGRATOR_ORDER = m.INTEGRATORS
PREVIEW_PHOTONS = 1 << 17       # the photon integrator's global and caustic maps in the preview
# per driver (glrender.integrators): how the preview accumulates (SPPM iteration by iteration,
# one camera sample each, without AOVs) and the integrator's own options in the preview
PREVIEW_DRIVERS = {
    "kernel": (Progressive, True, lambda: None),
    "photon": (Progressive, True, lambda: PhotonSettings(photons=PREVIEW_PHOTONS)),
    "sppm": (SppmProgressive, False, lambda: None),
    "vcm": (Progressive, True, lambda: None),
}
STRATEGY_ORDER = tuple(STRATEGIES)
DEPTH_STEPS_MAX = 16            # ] past this goes to unbounded (-1)
EXPOSURE_STEP = 0.5             # stops per key press
FAST_FLY = 4.0                  # speed factor with Shift
IDLE_WAIT = 0.25                # seconds to wait for events when nothing renders
RATE_WINDOW = 1.0               # seconds of history for samples/s
TITLE_INTERVAL = 0.2            # seconds between title updates while rendering


@dataclass
class PreviewOptions:
    """Everything the preview command decides besides the scene."""

    scene_name: str = "scene"
    integrator: str | None = None
    strategy: str | None = None
    light_selection: str | None = None
    max_depth: int | None = None
    sampler: str | None = None
    seed: int | None = None
    spp: int | None = None                  # stop at this many samples per pixel
    display: DisplaySettings = field(default_factory=DisplaySettings)
    frame_budget: float = 0.03              # seconds per frame
    screenshot_dir: Path = Path(".")
    record_dir: Path | None = None


def window_size_for(image: tuple[int, int], screen: tuple[int, int] | None) -> tuple[int, int]:
    """The window's first size: the image at an integer zoom that makes its longer side
    at least 512 pixels, shrunk to fit 90% of the screen."""
    w, h = image
    zoom = max(1, 512 // max(w, h))
    w, h = w * zoom, h * zoom
    if screen:
        fit = min(1.0, 0.9 * screen[0] / w, 0.9 * screen[1] / h)
        w, h = max(1, int(w * fit)), max(1, int(h * fit))
    return w, h


def depth_label(depth: int) -> str:
    return "unbounded" if depth < 0 else str(depth)


class PreviewApp:
    """A scene in a window. ``ctx`` is a window context (``create_window_context``)."""

    def __init__(self, scene: m.Scene, ctx, options: PreviewOptions, out=sys.stdout):
        import glfw

        self.glfw = glfw
        self.scene = scene
        self.ctx = ctx
        self.window = ctx.window
        self.options = options
        self.out = out
        integ = scene.integrator
        self.integrator = options.integrator or integ.kind
        if self.integrator not in self._integrator_order():
            self.integrator = "path"
        self.strategy = options.strategy or integ.strategy
        self.max_depth = options.max_depth if options.max_depth is not None else integ.max_depth
        self.view = options.display
        self.paused = False
        self._rebuild_wanted = False
        self._screenshot_wanted = False
        self._dirty = True
        self._keys = bindings(glfw)
        self._drag = None            # (button, shift) while a mouse button is held
        self._cursor = None
        self._motion = [0.0, 0.0, 0.0, 0.0]   # orbit dx, dy; pan dx, dy this frame
        self._scroll = 0.0
        self._samples_total = 0.0
        self._rate_history = deque()
        self._title = None
        self._title_time = 0.0
        self._compile_note = ""
        self._compile_note_until = 0.0
        self._display_seconds = 0.0
        self._frames = 0
        self._totals = {"render": 0.0, "display": 0.0}   # seconds, for the summary
        self._recorded = 0
        self.renderer: RenderDriver | None = None
        self.progressive: Progressive | None = None
        self.denoise = False         # the N key: show the denoised color view
        self._denoised = None        # its DenoisedView (glrender/preview/denoised.py)
        self._generation = 0         # which accumulation: +1 at every restart or new kernel
        self._shown = None           # (Denoised, view settings, 8-bit pixels) last tonemapped
        self._drawn_denoised = None  # the Denoised image the window shows now (None: the accumulation)
        self.display = Display(ctx)
        self._build()
        center, radius = self.renderer.device_scene.packed.sphere_bounds
        self.controller = CameraController(scene.camera, center, radius)
        self._install_callbacks()

    # -- renderer --------------------------------------------------------------------------
    def settings_label(self) -> str:
        spec = integrators.get(self.integrator)
        parts = [self.integrator]
        if spec.uses_strategy:
            parts.append(self.strategy)
        if spec.uses_depth:
            parts.append(f"depth {depth_label(self.max_depth)}")
        return ", ".join(parts)

    def _build(self) -> None:
        """A renderer (new kernel) for the current integrator, strategy and depth."""
        self._set_title(f"glrender - {self.options.scene_name} - compiling {self.settings_label()} ...",
                        force=True)
        self.glfw.poll_events()
        t0 = time.perf_counter()
        progressive, aovs, options = PREVIEW_DRIVERS[integrators.get(self.integrator).driver]
        settings = job_settings(self.scene, JobOptions(
            integrator=self.integrator, seed=self.options.seed,
            settings=dict(strategy=self.strategy, max_depth=self.max_depth,
                          light_selection=self.options.light_selection,
                          sampler=self.options.sampler, aovs=aovs,
                          time_target=self.options.frame_budget)))
        old = self.renderer
        if old is not None:
            self.display.hold(old, self.view)   # on screen until the new kernel's samples land
            old.release()
        self.renderer = make_driver(self.scene, settings, create_driver, options(), ctx=self.ctx)
        self.progressive = progressive(self.renderer, self.options.spp)
        self._generation += 1
        seconds = time.perf_counter() - t0
        self._compile_note = f" - built in {seconds:.2f} s"
        self._compile_note_until = time.perf_counter() + 3.0
        self._dirty = True

    def _restart(self) -> None:
        """The camera moved: forget the samples (the image on screen is held until the new
        ones arrive)."""
        self.display.hold(self.renderer, self.view)
        self.scene.camera = self.controller.camera()
        self.progressive.reset()
        self._generation += 1
        self._dirty = True

    # -- input -----------------------------------------------------------------------------
    def _install_callbacks(self) -> None:
        glfw, win = self.glfw, self.window
        glfw.set_key_callback(win, self._on_key)
        glfw.set_mouse_button_callback(win, self._on_button)
        glfw.set_cursor_pos_callback(win, self._on_cursor)
        glfw.set_scroll_callback(win, self._on_scroll)
        glfw.set_window_refresh_callback(win, lambda w: self._mark_dirty())
        glfw.set_framebuffer_size_callback(win, lambda w, width, height: self._mark_dirty())

    def _mark_dirty(self) -> None:
        self._dirty = True

    def _on_key(self, window, key, scancode, action, mods) -> None:
        if action not in (self.glfw.PRESS, self.glfw.REPEAT):
            return
        bound = self._keys.get(key)
        if bound is None:
            return
        name, index = bound
        if action == self.glfw.REPEAT and name not in ("exposure_down", "exposure_up",
                                                       "depth_down", "depth_up"):
            return
        getattr(self, f"action_{name}")(bool(mods & self.glfw.MOD_SHIFT), index)
        self._dirty = True

    def _on_button(self, window, button, action, mods) -> None:
        glfw = self.glfw
        if action == glfw.PRESS and self._drag is None:
            self._drag = (button, bool(mods & glfw.MOD_SHIFT))
            self._cursor = glfw.get_cursor_pos(window)
        elif action == glfw.RELEASE and self._drag is not None and self._drag[0] == button:
            self._drag = None

    def _on_cursor(self, window, x, y) -> None:
        if self._drag is None:
            return
        if self._cursor is None:
            self._cursor = (x, y)
        dx, dy = x - self._cursor[0], y - self._cursor[1]
        self._cursor = (x, y)
        button, shift = self._drag
        if button == self.glfw.MOUSE_BUTTON_LEFT and not shift:
            self._motion[0] += dx
            self._motion[1] += dy
        else:
            self._motion[2] += dx
            self._motion[3] += dy

    def _on_scroll(self, window, dx, dy) -> None:
        self._scroll += dy

    def _cycle(self, values, current, shift: bool):
        i = values.index(current) if current in values else -1
        return values[(i + (-1 if shift else 1)) % len(values)]

    # Actions: (shift held, index of the key in its group); see keys.py
    def action_reset_camera(self, shift, index):
        self.controller.reset()
        self._restart()

    def _integrator_order(self) -> tuple[str, ...]:
        """The integrators key I cycles through: those that render the scene (with media,
        the ones that render media)."""
        if self.scene.has_media:
            return tuple(n for n in INTEGRATOR_ORDER if integrators.get(n).media)
        return tuple(INTEGRATOR_ORDER)

    def action_next_integrator(self, shift, index):
        self.integrator = self._cycle(self._integrator_order(), self.integrator, shift)
        self._rebuild_wanted = True

    def action_next_strategy(self, shift, index):
        self.strategy = self._cycle(STRATEGY_ORDER, self.strategy, shift)
        self._rebuild_wanted = True

    def action_depth_down(self, shift, index):
        if self.max_depth < 0:
            self.max_depth = DEPTH_STEPS_MAX
        elif self.max_depth > 1:
            self.max_depth -= 1
        else:
            return
        self._rebuild_wanted = True

    def action_depth_up(self, shift, index):
        if self.max_depth < 0:
            return
        self.max_depth = -1 if self.max_depth >= DEPTH_STEPS_MAX else self.max_depth + 1
        self._rebuild_wanted = True

    def _set_view(self, **changes):
        self.view = replace(self.view, **changes)

    def action_next_view(self, shift, index):
        self._set_view(view=self._cycle(VIEWS, self.view.view, shift))

    def action_view(self, shift, index):
        self._set_view(view=VIEWS[index])

    def action_next_curve(self, shift, index):
        self._set_view(curve=self._cycle(TONE_CURVES, self.view.curve, shift))

    def action_exposure_down(self, shift, index):
        self._set_view(exposure=self.view.exposure - EXPOSURE_STEP)

    def action_exposure_up(self, shift, index):
        self._set_view(exposure=self.view.exposure + EXPOSURE_STEP)

    def action_exposure_reset(self, shift, index):
        self._set_view(exposure=0.0)

    def action_denoise(self, shift, index):
        if self.denoise:
            self.denoise = False
            return
        if self._denoised is None:
            from ..denoise import aovs_are_clean
            from ..errors import UsageError
            from .denoised import DenoisedView

            try:
                self._denoised = DenoisedView(clean_aux=aovs_are_clean(self.scene),
                                              on_done=self.glfw.post_empty_event)
            except UsageError as exc:   # without the denoise extra: say so, stay noisy
                self.say(str(exc))
                return
            self.say(f"denoising with Open Image Denoise ({self._denoised.denoiser.device_name}, "
                     f"{self._denoised.denoiser.threads} threads) in the background")
        self.denoise = True

    def _denoise_step(self) -> None:
        """Hand the accumulation to the denoiser when a new denoised image is due."""
        d = self._denoised
        if not self.denoise or d is None or self.view.view != "color":
            return
        if d.wants(self._generation, self.progressive.spp, final=self.progressive.done):
            d.submit(self.renderer.film(), self._generation)
        result = d.current(self._generation)
        if result is not None and (self._shown is None or self._shown[0] is not result):
            self._dirty = True

    def _denoised_pixels(self):
        """The denoised view's 8-bit pixels when it is on and has an image of this
        accumulation, else None (the accumulation is shown)."""
        if not self.denoise or self._denoised is None or self.view.view != "color":
            return None
        result = self._denoised.current(self._generation)
        if result is None:
            return None
        if self._shown is None or self._shown[0] is not result or self._shown[1] != self.view:
            from ..film.tonemap import tonemap

            v = self.view
            self._shown = (result, v, tonemap(result.image, v.exposure, v.curve, v.srgb))
        return self._shown[2]

    def _view_image(self) -> np.ndarray:
        """What the window shows at 1:1, 8-bit RGB, rows top to bottom."""
        pixels = self._denoised_pixels()
        return pixels if pixels is not None else self.display.image(self.renderer, self.view)

    def action_pause(self, shift, index):
        self.paused = not self.paused

    def action_screenshot(self, shift, index):
        self._screenshot_wanted = True

    def action_help(self, shift, index):
        self.say("keys:\n" + help_text())

    def action_quit(self, shift, index):
        self.glfw.set_window_should_close(self.window, True)

    def _apply_camera_input(self, seconds: float) -> None:
        glfw, win, c = self.glfw, self.window, self.controller
        moved = False
        odx, ody, pdx, pdy = self._motion
        self._motion = [0.0, 0.0, 0.0, 0.0]
        if odx or ody:
            c.orbit(odx, ody)
            moved = True
        if pdx or pdy:
            width, height = glfw.get_window_size(win)
            view = fit_viewport((self.renderer.width, self.renderer.height), (width, height))
            cam = c.camera()
            _, screen_y = camera_screen(cam, self.renderer.width, self.renderer.height)
            # an orthographic view is 2 screen_y units high at every distance
            c.pan(pdx, pdy, view[3] / screen_y * (c.distance if cam.orthographic else 1.0))
            moved = True
        if self._scroll:
            c.zoom(self._scroll)
            self._scroll = 0.0
            moved = True
        down = lambda key: glfw.get_key(win, key) == glfw.PRESS  # noqa: E731
        fwd = down(glfw.KEY_W) - down(glfw.KEY_S)
        right = down(glfw.KEY_D) - down(glfw.KEY_A)
        up = down(glfw.KEY_E) - down(glfw.KEY_Q)
        if fwd or right or up:
            fast = down(glfw.KEY_LEFT_SHIFT) or down(glfw.KEY_RIGHT_SHIFT)
            c.fly(fwd, right, up, min(seconds, 0.1) * (FAST_FLY if fast else 1.0))
            moved = True
        if moved:
            self._restart()

    def _flying(self) -> bool:
        glfw, win = self.glfw, self.window
        return any(glfw.get_key(win, k) == glfw.PRESS
                   for k in (glfw.KEY_W, glfw.KEY_A, glfw.KEY_S, glfw.KEY_D, glfw.KEY_Q, glfw.KEY_E))

    # -- output ----------------------------------------------------------------------------
    def say(self, text: str) -> None:
        print(f"glrender: {text}", file=self.out, flush=True)

    def _rate(self, now: float) -> float:
        history = self._rate_history
        history.append((now, self._samples_total))
        while len(history) > 2 and now - history[1][0] >= RATE_WINDOW:
            history.popleft()
        t0, s0 = history[0]
        return (self._samples_total - s0) / (now - t0) if now > t0 else 0.0

    def title(self, now: float) -> str:
        p = self.progressive
        spp = f"{p.spp}/{p.target_spp} spp" if p.target_spp is not None else f"{p.spp} spp"
        if self.paused:
            state = "paused"
        elif p.done:
            state = "done"
        else:
            state = f"{self._rate(now) / 1e6:.2f} M samples/s"
        v = self.view
        note = self._compile_note if now < self._compile_note_until else ""
        if self.denoise and self._denoised is not None:
            # what the window shows, not the newest result: the worker may finish one
            # after the draw, and the title names it only once it is drawn
            shown = self._drawn_denoised
            note += f" - denoised at {shown.spp} spp" if shown is not None else " - denoising"
        return (f"glrender - {self.options.scene_name} - {self.settings_label()} - {v.view}, "
                f"{v.curve}, {v.exposure:+.1f} EV - {spp} - {state}{note}")

    def _set_title(self, text: str, force: bool = False) -> None:
        now = time.perf_counter()
        if text != self._title and (force or now - self._title_time >= TITLE_INTERVAL):
            self.glfw.set_window_title(self.window, text)
            self._title, self._title_time = text, now

    def _unique_stem(self, folder: Path) -> Path:
        for n in range(1, 100000):
            stem = folder / f"{self.options.scene_name}-{n:03d}"
            if not any(stem.with_suffix(ext).exists() for ext in (".png", ".exr", ".pfm", ".json")):
                return stem
        raise RuntimeError(f"{folder}: no free screenshot name")  # pragma: no cover

    def screenshot(self) -> list[Path]:
        """Save the view (PNG, as shown at 1:1), the accumulation (EXR with variance and
        AOV layers; PFM without the OpenEXR package) and the settings and camera (JSON),
        after completing the pass in progress so every pixel has the same count."""
        from PIL import Image

        from ..film.io import atomic_write, write_image

        self.progressive.finish_pass()
        film = self.renderer.film()
        stem = self._unique_stem(self.options.screenshot_dir)
        png = stem.with_suffix(".png")
        pixels = self._view_image()
        atomic_write(png, lambda tmp: Image.fromarray(pixels).save(tmp, format="PNG"))
        try:
            import OpenEXR  # noqa: F401
        except ImportError:  # the exr extra is optional: keep the floats in a PFM
            hdr = stem.with_suffix(".pfm")
            write_image(hdr, film.mean)
        else:
            hdr = stem.with_suffix(".exr")
            film.save(hdr)
        cam = self.scene.camera
        meta = {
            "scene": self.options.scene_name, "spp": film.spp,
            "width": self.renderer.width, "height": self.renderer.height,
            "integrator": self.integrator, "strategy": self.strategy, "max_depth": self.max_depth,
            "sampler": self.renderer.settings.sampler.kind, "seed": self.renderer.settings.sampler.seed,
            "view": self.view.view, "tonemap": self.view.curve, "exposure": self.view.exposure,
            "srgb": self.view.srgb,
            "world_from_camera": np.asarray(cam.world_from_camera).tolist(),
            "world_from_camera_close": None if cam.world_from_camera_close is None
            else np.asarray(cam.world_from_camera_close).tolist(),
            "fov": cam.fov, "fov_axis": cam.fov_axis,
            "device": self.ctx.gl.info["GL_RENDERER"], "gl_version": self.ctx.gl.info["GL_VERSION"],
            "png": png.name, "hdr": hdr.name,
            "denoised_spp": self._shown[0].spp if self._denoised_pixels() is not None else None,
        }
        meta_path = stem.with_suffix(".json")
        atomic_write(meta_path, lambda tmp: tmp.write_text(json.dumps(meta, indent=2) + "\n"))
        paths = [png, hdr, meta_path]
        self.say(f"screenshot at {film.spp} spp -> {', '.join(str(p) for p in paths)}")
        return paths

    def _record(self) -> None:
        """The frame shown to --record's folder; a frame that cannot be written ends the
        recording (said in one line), never the preview."""
        from PIL import Image

        self._recorded += 1
        path = self.options.record_dir / f"frame-{self._recorded:06d}.png"
        try:
            Image.fromarray(self._view_image()).save(path, compress_level=1)
        except OSError as exc:
            self.say(f"recording stopped: {path}: cannot write ({exc.strerror or exc})")
            self.options = replace(self.options, record_dir=None)

    # -- frame loop ------------------------------------------------------------------------
    def _draw(self) -> None:
        glfw, gl = self.glfw, self.ctx.gl
        t0 = time.perf_counter()
        size = glfw.get_framebuffer_size(self.window)
        if size[0] > 0 and size[1] > 0:
            gl.screen.use()
            gl.viewport = (0, 0, *size)
            gl.clear(0.12, 0.12, 0.12, 1.0)
            view = fit_viewport((self.renderer.width, self.renderer.height), size)
            pixels = self._denoised_pixels()
            if pixels is not None:
                self.display.draw_pixels(pixels, gl.screen, view)
            else:
                self.display.draw(self.renderer, gl.screen, view, self.view)
            glfw.swap_buffers(self.window)
            self._drawn_denoised = self._shown[0] if pixels is not None else None
        seconds = time.perf_counter() - t0
        self._display_seconds = seconds if self._frames == 0 else 0.8 * self._display_seconds + 0.2 * seconds
        self._totals["display"] += seconds
        self._frames += 1

    def run(self) -> int:
        glfw, win = self.glfw, self.window
        self.say(f"preview of {self.options.scene_name} ({self.renderer.width}x{self.renderer.height}) "
                 f"on {self.ctx.gl.info['GL_RENDERER']}; window {self.window_id()}; "
                 f"press H for the keys")
        budget = self.options.frame_budget
        last = time.perf_counter()
        while not glfw.window_should_close(win):
            busy = (not self.paused and not self.progressive.done) or self._drag is not None \
                or self._dirty or self._flying()
            if busy:
                glfw.poll_events()
            else:
                glfw.wait_events_timeout(IDLE_WAIT)
            now = time.perf_counter()
            seconds, last = now - last, now
            self._apply_camera_input(seconds)
            if self._rebuild_wanted:
                self._rebuild_wanted = False
                self._build()
            if self._screenshot_wanted:
                self._screenshot_wanted = False
                try:
                    self.screenshot()
                except WriteError as exc:     # a full disk ends no preview
                    self.say(f"screenshot not saved: {exc}")
            rendered = False
            if not self.paused and not self.progressive.done:
                before = self.progressive.samples_added
                t0 = time.perf_counter()
                rendered = self.progressive.advance(max(0.3 * budget, budget - self._display_seconds))
                self._totals["render"] += time.perf_counter() - t0
                self._samples_total += self.progressive.samples_added - before
            self._denoise_step()
            if rendered or self._dirty:
                self._draw()
                if self.options.record_dir is not None:
                    self._record()
                self._dirty = False
            self._set_title(self.title(time.perf_counter()), force=not busy)
        self.say(self.summary())
        return 0

    def summary(self) -> str:
        """One line at exit: spp, frames and where their time went, samples/s."""
        t, frames = self._totals, max(self._frames, 1)
        rate = self._samples_total / t["render"] if t["render"] > 0 else 0.0
        d = self._denoised
        denoised = "" if d is None else (f"; {d.runs} denoised images, {d.seconds:.2f} s of "
                                         f"Open Image Denoise in the background")
        return (f"preview closed at {self.progressive.spp} spp after {self._frames} frames "
                f"(per frame: {1000 * t['render'] / frames:.1f} ms rendering, "
                f"{1000 * t['display'] / frames:.1f} ms display and swap; "
                f"{rate / 1e6:.2f} M samples/s while rendering{denoised})")

    def window_id(self) -> str:
        try:
            return hex(self.glfw.get_x11_window(self.window))
        except Exception:  # not X11 (Wayland): no window id to show
            return "(not X11)"

    def release(self) -> None:
        if self._denoised is not None:
            self._denoised.close()
            self._denoised = None
        if self.renderer is not None:
            self.renderer.release()
            self.renderer = None
        self.display.release()
