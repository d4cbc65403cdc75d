"""Every output format, written by `glrender render` and read back, against the in-memory render."""
from __future__ import annotations

import json

import numpy as np
import pytest

from cli_run import CORNELL, glrender, reference_film
from glrender.film.io import read_exr_layers, read_image, read_pfm
from glrender.film.tonemap import tonemap

W, H, SPP, SEED = 40, 24, 8, 3
ALL_AOVS = "albedo,normal,depth,variance"


@pytest.fixture(scope="module")
def film(gl_ctx):
    return reference_film(width=W, height=H, spp=SPP, seed=SEED, aovs=True)


def render(tmp_path, name, *extra):
    out = tmp_path / name
    r = glrender("render", CORNELL, "-o", out, "--width", W, "--height", H, "--spp", SPP,
                 "--seed", SEED, "--aov", ALL_AOVS, "--quiet", *extra)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "" and r.stderr == ""   # --quiet: nothing but errors
    return out


def test01_float_formats_hold_the_render_bitwise(tmp_path, film):
    assert film.mean.max() > 0.1                 # a real image, not an empty one
    np.testing.assert_array_equal(np.load(render(tmp_path, "a.npy")), film.mean)
    np.testing.assert_array_equal(read_pfm(render(tmp_path, "a.pfm")), film.mean)


def test02_exr_layers(tmp_path, film):
    layers = read_exr_layers(render(tmp_path, "a.exr"))
    assert set(layers) == {"RGB", "albedo", "normal", "depth", "variance"}
    for layer in layers.values():
        assert layer.dtype == np.float32
    np.testing.assert_array_equal(layers["RGB"], film.mean)
    np.testing.assert_array_equal(layers["variance"], film.variance)
    for name in ("albedo", "normal", "depth"):
        np.testing.assert_array_equal(layers[name], film.aov(name))
    assert film.variance.max() > 0 and np.abs(film.aov("normal")).max() > 0.5


def test03_exr_half(tmp_path, film):
    layers = read_exr_layers(render(tmp_path, "h.exr", "--half"))
    assert layers["RGB"].dtype == np.float16
    np.testing.assert_array_equal(layers["RGB"], film.mean.astype(np.float16))
    np.testing.assert_array_equal(layers["depth"], film.aov("depth").astype(np.float16))


def test04_radiance_hdr(tmp_path, film):
    """RGBE keeps 8 mantissa bits of the largest channel and truncates: every channel is
    below its value by less than 2^-7 of the pixel's largest channel (eq. in radiance_hdr)."""
    got = read_image(render(tmp_path, "a.hdr"))
    ref = film.mean.astype(np.float64)
    bound = ref.max(axis=-1, keepdims=True) * 2.0 ** -7
    err = ref - got
    assert (err >= -1e-7 * ref).all() and (err < bound + 1e-12).all()


@pytest.mark.parametrize("curve, exposure, srgb", [("clamp", 0, True), ("filmic", 1.5, True),
                                                   ("aces", -0.5, False)])
def test05_png_is_the_tonemapped_render(tmp_path, film, curve, exposure, srgb):
    from PIL import Image

    out = render(tmp_path, "a.png", "--tonemap", curve, "--exposure", exposure,
                 "--srgb" if srgb else "--no-srgb")
    with Image.open(out) as im:
        got = np.asarray(im.convert("RGB"))
    np.testing.assert_array_equal(got, tonemap(film.mean, exposure, curve, srgb))


def test06_jpeg(tmp_path, film):
    """JPEG is lossy: the file decodes to the same pixels as the tonemapped render encoded
    here at the same quality (libjpeg is deterministic)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(tonemap(film.mean)).save(buf, format="JPEG", quality=95)
    with Image.open(buf) as im:
        expected = np.asarray(im.convert("RGB"))
    with Image.open(render(tmp_path, "a.jpg")) as im:
        got = np.asarray(im.convert("RGB"))
    np.testing.assert_array_equal(got, expected)


def test07_aovs_beside_single_layer_formats(tmp_path, film):
    out = render(tmp_path, "b.png")
    for name in ("albedo", "normal", "depth", "variance"):
        np.testing.assert_array_equal(read_pfm(tmp_path / f"b.{name}.pfm"), film.aov(name))
    render(tmp_path, "c.npy")
    np.testing.assert_array_equal(np.load(tmp_path / "c.depth.npy"), film.aov("depth"))
    assert out.exists()


def test08_stats(tmp_path, film):
    stats_path = tmp_path / "s.json"
    out = render(tmp_path, "s.exr", "--stats", stats_path)
    stats = json.loads(stats_path.read_text())
    for key in ("device", "scene_hash", "seed", "spp", "seconds", "samples_per_second",
                "nonfinite_samples", "mean_relative_stderr"):
        assert key in stats, key
    assert stats["device"]["GL_RENDERER"]
    assert set(stats["seconds"]) >= {"load", "pack", "build", "compile", "render", "write"}
    assert stats["seconds"]["pack"] <= stats["seconds"]["build"]
    assert all(v >= 0 for v in stats["seconds"].values())
    assert stats["seed"] == SEED and stats["spp"] == SPP and stats["stopped"] == "complete"
    assert stats["nonfinite_samples"] == film.nonfinite_total == 0
    lit = film.mean > 0
    expected = np.mean(film.stderr[lit] / film.mean[lit])
    assert stats["mean_relative_stderr"] == pytest.approx(expected, rel=1e-6)
    assert stats["samples_per_second"] > 0
    assert stats["outputs"] == [str(out)]
    assert len(stats["scene_hash"]) == 64
