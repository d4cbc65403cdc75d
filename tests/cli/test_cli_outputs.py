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


def test09_stats_and_info_give_bytes_per_triangle_and_device_limits(tmp_path, gl_ctx):
    """``--stats`` records the device limits that bound a scene and, for a mesh, what its
    BVH triangles take on the device per triangle and how many would fit (as many as the
    upload takes in parts); ``glrender info`` gives the same limits and the figures of a
    reference mesh."""
    from glrender.gpu import bvh_upload

    n = 30                                            # a 30 x 30 height field: 1,800 triangles
    y, x = np.mgrid[0:n + 1, 0:n + 1] / n
    v = np.stack([x, y, 0.1 * np.sin(6 * x)], axis=-1).reshape(-1, 3).astype("<f4")
    k = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).reshape(-1)
    f = np.concatenate([np.stack([k, k + 1, k + n + 2], 1), np.stack([k, k + n + 2, k + n + 1], 1)])
    faces = np.zeros(len(f), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    faces["n"], faces["i"] = 3, f
    mesh = tmp_path / "field.ply"
    mesh.write_bytes((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
                      "property float x\nproperty float y\nproperty float z\n"
                      f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
                     + v.tobytes() + faces.tobytes())
    info = json.loads(glrender("info", "--json").stdout)
    limits = {name: info["limits"][name] for name in
              ("GL_MAX_TEXTURE_BUFFER_SIZE", "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "GL_MAX_TEXTURE_SIZE")}

    def stats_of(scene):
        path = tmp_path / "s.json"
        r = glrender("render", scene, "--spp", "1", "--width", "8", "-o", tmp_path / "o.png",
                     "--stats", path, "--quiet")
        assert r.returncode == 0, r.stderr
        return json.loads(path.read_text())

    stats = stats_of(mesh)
    assert stats["device_limits"] == limits
    m = stats["mesh"]
    assert m["triangles"] == len(f)
    assert m["bytes_per_triangle"] == pytest.approx(m["device_bytes"] / len(f), abs=0.01)
    # corners (3 texels), normals (3), uvs (2) and info (1) of 16 bytes, and the nodes
    assert 9 * 16 < m["bytes_per_triangle"] < 9 * 16 + 64
    assert max(m["texels_per_triangle"].values()) == 3
    most, kind = bvh_upload.triangle_ceiling(gl_ctx.gl)
    assert m["max_triangles"] == most > limits["GL_MAX_TEXTURE_BUFFER_SIZE"] // 3
    assert m["limited_by"] == bvh_upload.KINDS[kind].label
    assert m["textures"] == bvh_upload.max_parts(gl_ctx.gl, kind) > 1
    cornell = stats_of(CORNELL)
    assert cornell["mesh"] is None and cornell["device_limits"] == limits
    reference = info["mesh"]
    assert 9 * 16 < reference["bytes_per_triangle"] < 9 * 16 + 64
    assert {k: reference[k] for k in ("max_triangles", "limited_by", "textures")} == \
        {k: m[k] for k in ("max_triangles", "limited_by", "textures")}
    text = glrender("info").stdout
    assert f"at most {m['max_triangles']:,} triangles" in text
