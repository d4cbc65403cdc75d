"""The display pass: the renderer's accumulation, tonemapped on the device.

A fragment shader (``shaders/kernels/preview.frag.glsl``) reads the accumulation
buffers directly as storage buffers, so showing a frame costs no read-back. It runs
once per image pixel into an image-sized texture (the frame), and a second, cheap
pass of the same program scales the frame to the window (nearest). Screenshots read
the frame back, so a saved PNG is exactly what the window shows, at 1:1.

When the camera moves, the accumulation restarts and its first pass can take many
frames on llvmpipe; :meth:`Display.hold` keeps the frame on screen, and pixels
without samples show it until their first samples arrive (during a drag the view
updates tile by tile instead of flashing black).
"""
from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..errors import UsageError
from ..film.tonemap import TONE_CURVES
from ..gl import shaders

VIEWS = ("color", "albedo", "normal", "variance")   # kView* in preview.frag.glsl, in order
SOURCE_ACCUMULATION, SOURCE_TEXTURE = 0, 1         # kSource* in preview.frag.glsl
TEXTURE_UNIT = 0   # the frame's or held image's unit while drawing (the render kernel uses 4 and up)


@dataclass
class DisplaySettings:
    """What the display pass shows: a view of the accumulation, its exposure (stops),
    tone curve and encoding."""

    view: str = "color"
    exposure: float = 0.0
    curve: str = "clamp"
    srgb: bool = True

    def __post_init__(self):
        if self.view not in VIEWS:
            raise UsageError(f"view {self.view!r}: expected one of {', '.join(VIEWS)}")
        if self.curve not in TONE_CURVES:
            raise UsageError(f"tone curve {self.curve!r}: expected one of {', '.join(TONE_CURVES)}")


def fit_viewport(image: tuple[int, int], framebuffer: tuple[int, int]) -> tuple[int, int, int, int]:
    """The largest rectangle of the image's aspect ratio centred in the framebuffer:
    (x, y, width, height) in framebuffer pixels, at least 1x1."""
    iw, ih = image
    fw, fh = framebuffer
    scale = min(fw / iw, fh / ih)
    w, h = max(1, round(iw * scale)), max(1, round(ih * scale))
    return (fw - w) // 2, (fh - h) // 2, w, h


class _Target:
    """An image-sized RGBA8 texture and its framebuffer."""

    def __init__(self, gl: moderngl.Context, size: tuple[int, int]):
        self.texture = gl.texture(size, 4, dtype="f1")
        self.texture.filter = (gl.NEAREST, gl.NEAREST)
        self.fbo = gl.framebuffer(color_attachments=[self.texture])

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()


class Display:
    """The display program, its empty vertex array (the triangle comes from gl_VertexID),
    the frame and the held image."""

    def __init__(self, ctx):
        self.gl: moderngl.Context = getattr(ctx, "gl", ctx)
        self.program = shaders.compile_program(ctx, "kernels/preview.vert.glsl",
                                               "kernels/preview.frag.glsl")
        self.vao = self.gl.vertex_array(self.program, [])
        self._frame: _Target | None = None   # the latest frame at 1:1
        self._held: _Target | None = None    # shown where the accumulation is empty
        self._pixels = None                  # an 8-bit image from the host (the denoised view)

    def _set(self, name: str, value) -> None:
        if name in self.program:   # the compiler drops unused uniforms
            self.program[name].value = value

    def _pass(self, size, viewport, source: int, texture) -> None:
        self._set("u_image", size)
        self._set("u_viewport", tuple(float(v) for v in viewport))
        self._set("u_source", source)
        self._set("u_has_texture", texture is not None)
        if texture is not None:
            texture.use(location=TEXTURE_UNIT)
            self._set("u_texture", TEXTURE_UNIT)
        self.gl.viewport = viewport
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def render_frame(self, renderer, settings: DisplaySettings) -> None:
        """The accumulation at 1:1 into the frame texture (over the held image where a pixel
        has no samples). Leaves the frame's framebuffer bound."""
        gl = self.gl
        size = (renderer.width, renderer.height)
        if self._frame is None or self._frame.texture.size != size:
            if self._frame is not None:
                self._frame.release()
            self._frame = _Target(gl, size)
        gl.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)  # the kernel's writes, visible here
        renderer.bind_film()
        self._set("u_view", VIEWS.index(settings.view))
        self._set("u_curve", TONE_CURVES.index(settings.curve))
        self._set("u_scale", float(2.0 ** settings.exposure))
        self._set("u_srgb", bool(settings.srgb))
        self._set("u_has_aovs", bool(renderer.settings.aovs))
        held = self._held.texture if self._held is not None and self._held.texture.size == size else None
        self._frame.fbo.use()
        self._pass(size, (0, 0, *size), SOURCE_ACCUMULATION, held)

    def draw(self, renderer, target: moderngl.Framebuffer, viewport: tuple[int, int, int, int],
             settings: DisplaySettings) -> None:
        """Draw ``renderer``'s accumulation into ``viewport`` of ``target`` (the window's
        ``gl.screen``), which is left bound."""
        self.render_frame(renderer, settings)
        target.use()
        self._pass((renderer.width, renderer.height), viewport, SOURCE_TEXTURE, self._frame.texture)

    def draw_pixels(self, pixels: np.ndarray, target: moderngl.Framebuffer,
                    viewport: tuple[int, int, int, int]) -> None:
        """Draw an 8-bit RGB image (H, W, 3), rows top to bottom, made on the host (the
        denoised view, tonemapped by film/tonemap.py), into ``viewport`` of ``target``,
        which is left bound."""
        h, w = pixels.shape[:2]
        if self._pixels is None or self._pixels.size != (w, h):
            if self._pixels is not None:
                self._pixels.release()
            self._pixels = self.gl.texture((w, h), 4, dtype="f1")
            self._pixels.filter = (self.gl.NEAREST, self.gl.NEAREST)
        rgba = np.full((h, w, 4), 255, np.uint8)
        rgba[..., :3] = pixels[::-1]            # textures hold rows bottom to top
        self._pixels.write(rgba.tobytes())
        target.use()
        self._pass((w, h), viewport, SOURCE_TEXTURE, self._pixels)

    def image(self, renderer, settings: DisplaySettings) -> np.ndarray:
        """What the window shows at 1:1, as 8-bit RGB (H, W, 3), rows top to bottom.
        Leaves the frame's framebuffer bound."""
        self.render_frame(renderer, settings)
        data = self._frame.fbo.read(components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(renderer.height, renderer.width, 3)[::-1].copy()

    def hold(self, renderer, settings: DisplaySettings) -> None:
        """Keep the image shown now (at 1:1, itself partly held) for the pixels of the next
        accumulation that have no samples yet; call before the accumulation restarts.
        Leaves the frame's framebuffer bound."""
        self.render_frame(renderer, settings)
        self._held, self._frame = self._frame, self._held   # the next frame reuses the old held

    def release(self) -> None:
        for t in (self._frame, self._held):
            if t is not None:
                t.release()
        self._frame = self._held = None
        if self._pixels is not None:
            self._pixels.release()
            self._pixels = None
        self.vao.release()
