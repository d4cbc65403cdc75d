"""The display pass (preview.frag.glsl) against the Python display transforms, headless.

The shader computes in float32 and the framebuffer rounds to 8 bits; tonemap.py
computes in float64. A float32 result differs from the float64 one by a few ulps, so
the two 8-bit values can differ only where the exact value lies within ~1e-5 of a
rounding boundary: by at most 1, in a fraction of the values of order 1e-4 (0.2% allowed).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from glrender.film.tonemap import TONE_CURVES, tonemap
from glrender.gpu import bindings
from glrender.preview.display import VIEWS, Display, DisplaySettings, fit_viewport
from glrender.render import accum

W, H = 61, 37     # odd sizes: rows and columns cannot be swapped unnoticed


class _Film(SimpleNamespace):
    """A stand-in for a renderer's accumulation: what the display reads of a renderer."""

    def bind_film(self) -> None:
        self.sums.bind_to_storage_buffer(bindings.SSBO_ACCUM_SUM)
        self.squares.bind_to_storage_buffer(bindings.SSBO_ACCUM_SQ)
        self.aov.bind_to_storage_buffer(bindings.SSBO_ACCUM_AOV)

    def release(self) -> None:
        for buf in (self.sums, self.squares, self.aov):
            buf.release()


def _words(values: np.ndarray) -> np.ndarray:
    """float64 values as the accumulation's 128-bit fixed-point words (nearest)."""
    out = []
    for v in np.asarray(values, np.float64).ravel():
        q = int(round(float(v) * 2.0 ** accum.FRACTION)) % (1 << 128)
        out.append([(q >> (32 * k)) & 0xFFFFFFFF for k in range(4)])
    return np.array(out, np.uint32).reshape(*np.shape(values), 4)


def _accumulation(gl_ctx, seed=0):
    """A stand-in for a renderer's accumulation (exact sums, glrender.render.accum):
    random means over 8 decades, counts 0..9 (0: a pixel without samples yet),
    variances from 1e-6 to 10 times the squared mean, albedo and normals."""
    rng = np.random.default_rng(seed)
    n = W * H
    mean = np.zeros((n, 4), np.float32)
    mean[:, :3] = 10.0 ** rng.uniform(-4, 4, (n, 3))
    mean[::97, 0] = 0.0
    mean[:, 3] = rng.integers(0, 10, n)
    count = mean[:, 3:].astype(np.float64)
    mean[:, :3] *= count[:, 0:1] > 0
    m2 = np.zeros((n, 4), np.float32)
    m2[:, :3] = mean[:, :3].astype(np.float64) ** 2 * np.maximum(count - 1, 0) \
        * 10.0 ** rng.uniform(-6, 1, (n, 3))
    aov = np.zeros((n, 3, 4), np.float32)   # albedo (rgb, -), normal (xyz, depth), emission (rgb, -)
    aov[:, 0, :3] = rng.uniform(0, 1, (n, 3))
    normal = rng.normal(size=(n, 3))
    aov[:, 1, :3] = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    sums = np.zeros((n, 4, 4), np.uint32)
    m64 = mean[:, :3].astype(np.float64)
    sums[:, :3] = _words(m64 * count)
    sums[:, 3, 0] = mean[:, 3]
    squares = _words(m2[:, :3].astype(np.float64) + m64 ** 2 * count)
    aov[:, 2, :3] = 10.0 ** rng.uniform(-2, 2, (n, 3))
    # accum.AOV_CHANNELS sums: albedo rgb, normal xyz, depth, emission rgb
    aov_sums = _words(np.concatenate([aov[:, 0, :3], aov[:, 1, :3], aov[:, 1, 3:], aov[:, 2, :3]],
                                     axis=1).astype(np.float64) * count)
    gl = gl_ctx.gl
    source = _Film(width=W, height=H, settings=SimpleNamespace(aovs=True),
                   sums=gl.buffer(sums.tobytes()), squares=gl.buffer(squares.tobytes()),
                   aov=gl.buffer(aov_sums.tobytes()))
    arrays = SimpleNamespace(mean=mean.reshape(H, W, 4), m2=m2.reshape(H, W, 4),
                             aov=aov.reshape(H, W, 3, 4))
    return source, arrays


def _expected(arrays, settings: DisplaySettings) -> np.ndarray:
    count = arrays.mean[..., 3:]
    if settings.view == "color":
        out = tonemap(arrays.mean[..., :3], settings.exposure, settings.curve, settings.srgb)
    elif settings.view == "variance":
        var = np.where(count > 1, arrays.m2[..., :3] / np.maximum(count - 1, 1), 0.0)
        out = tonemap(var, settings.exposure, settings.curve, settings.srgb)
    elif settings.view == "albedo":
        out = tonemap(arrays.aov[:, :, 0, :3], 0.0, "clamp", settings.srgb)
    else:
        out = np.round(np.clip(0.5 * arrays.aov[:, :, 1, :3].astype(np.float64) + 0.5, 0, 1) * 255)
    return np.where(count > 0, out, 0).astype(np.uint8)


@pytest.fixture(scope="module")
def accumulation(gl_ctx):
    source, arrays = _accumulation(gl_ctx)
    yield source, arrays
    source.release()


@pytest.fixture(scope="module")
def display(gl_ctx):
    d = Display(gl_ctx)
    yield d
    d.release()


CASES = [DisplaySettings("color", e, c, s) for c in TONE_CURVES for e in (0.0, -3.5, 2.0)
         for s in (True, False)] + [DisplaySettings(v, 1.5, "filmic") for v in VIEWS[1:]]


@pytest.mark.parametrize("settings", CASES, ids=lambda s: f"{s.view}-{s.curve}-{s.exposure:+g}-"
                                                         f"{'srgb' if s.srgb else 'linear'}")
def test01_display_matches_tonemap(display, accumulation, settings):
    source, arrays = accumulation
    got = display.image(source, settings).astype(int)
    want = _expected(arrays, settings).astype(int)
    diff = np.abs(got - want)
    assert diff.max() <= 1, np.argwhere(diff > 1)[:5]
    assert (diff > 0).mean() < 0.002, (diff > 0).mean()


def test02_unsampled_pixels_are_black(display, accumulation):
    source, arrays = accumulation
    img = display.image(source, DisplaySettings())
    empty = arrays.mean[..., 3] == 0
    assert empty.any() and (img[empty] == 0).all()


def test03_fit_viewport():
    assert fit_viewport((256, 256), (512, 512)) == (0, 0, 512, 512)
    assert fit_viewport((200, 100), (400, 400)) == (0, 100, 400, 200)    # letterbox
    assert fit_viewport((100, 200), (400, 400)) == (100, 0, 200, 400)    # pillarbox
    assert fit_viewport((640, 480), (1, 1)) == (0, 0, 1, 1)


@pytest.mark.parametrize("border", [(5, 0), (0, 2)], ids=["pillarbox", "letterbox"])
def test04_window_pixels_map_to_image_pixels(gl_ctx, display, accumulation, border):
    """Drawn at 3x into a framebuffer with a border, every block of 3x3 framebuffer
    pixels shows its image pixel (rows top to bottom, nearest), and the border keeps the
    clear colour."""
    source, arrays = accumulation
    gl = gl_ctx.gl
    bx, by = border
    fw, fh = 3 * W + 2 * bx, 3 * H + 2 * by
    fbo = gl.simple_framebuffer((fw, fh), components=4, dtype="f1")
    try:
        fbo.use()
        fbo.clear(0.0, 0.0, 1.0, 1.0)
        view = fit_viewport((W, H), (fw, fh))
        assert view == (bx, by, 3 * W, 3 * H)
        display.draw(source, fbo, view, DisplaySettings())
        frame = np.frombuffer(fbo.read(components=3, alignment=1), np.uint8).reshape(fh, fw, 3)[::-1]
    finally:
        fbo.release()
    one = display.image(source, DisplaySettings())
    inner = frame[by:by + 3 * H, bx:bx + 3 * W]
    np.testing.assert_array_equal(inner, np.repeat(np.repeat(one, 3, axis=0), 3, axis=1))
    outside = np.ones((fh, fw), bool)
    outside[by:by + 3 * H, bx:bx + 3 * W] = False
    assert outside.any() and (frame[outside] == (0, 0, 255)).all()


def test05_held_image_fills_pixels_without_samples(gl_ctx, accumulation):
    """After hold(), a restarted accumulation shows the held image where it has no samples
    yet and its own pixels elsewhere."""
    source, arrays = accumulation
    d = Display(gl_ctx)
    gl = gl_ctx.gl
    restarted = np.zeros((H * W, 4, 4), np.uint32)
    rows = (np.arange(H * W) // W) % 2 == 0     # every other row has samples: one grey value
    restarted[rows, :3] = _words(np.full(3, 0.25))
    restarted[rows, 3, 0] = 1
    empty = _Film(width=W, height=H, settings=SimpleNamespace(aovs=False),
                  sums=gl.buffer(restarted.tobytes()),
                  squares=gl.buffer(reserve=W * H * 48), aov=gl.buffer(reserve=16))
    try:
        shown = d.image(source, DisplaySettings())
        d.hold(source, DisplaySettings())
        img = d.image(empty, DisplaySettings())
        np.testing.assert_array_equal(img[1::2], shown[1::2])
        assert (img[::2] == tonemap(np.full((1, 1, 3), 0.25))[0, 0]).all()
        d.hold(empty, DisplaySettings())     # a second restart holds the mixed image
        np.testing.assert_array_equal(d.image(empty, DisplaySettings()), img)
    finally:
        d.release()
        empty.release()
