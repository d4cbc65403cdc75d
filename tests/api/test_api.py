"""The public API: round trips through every output format, scenes built and edited in
code, progressive rendering, time budgets and progress reports."""
from __future__ import annotations

import importlib
import importlib.util
import io
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
import glrender.accel.bvh_cache

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"
BUNNY = ROOT / "scenes" / "cornell-bunny" / "scene.toml"


def example(name: str):
    """A module of examples/ (the scripts double as libraries)."""
    spec = importlib.util.spec_from_file_location(f"example_{name}", ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def small(path: Path, size: int = 32) -> glrender.Scene:
    scene = glrender.load(path)
    scene.film = replace(scene.film, width=size, height=size)
    return scene


@pytest.fixture(scope="module")
def film() -> glrender.Film:
    return glrender.render(small(CORNELL), spp=8, seed=3, aovs=True, progress=False)


def test_public_names_have_docstrings():
    for name in glrender.__all__:
        obj = getattr(glrender, name)
        if callable(obj) and not name.endswith("Callback"):
            assert (obj.__doc__ or "").strip(), f"glrender.{name} has no docstring"


def test_film_arrays(film):
    h, w = film.shape
    assert (h, w) == (32, 32) and film.spp == 8
    for arr in (film.mean, film.variance, film.stderr, film.aov("albedo"), film.aov("normal")):
        assert arr.shape == (h, w, 3) and arr.dtype == np.float32
    assert film.aov("depth").shape == (h, w)
    np.testing.assert_array_equal(film.aov("variance"), film.variance)
    # stderr is the per-sample variance over the sample count
    np.testing.assert_allclose(film.stderr ** 2 * 8, film.variance, rtol=1e-5, atol=1e-12)
    assert film.stats["spp"] == 8 and film.stats["stopped"] == "complete"
    assert film.stats["seconds"]["render"] > 0 and film.stats["samples_per_second"] > 0
    assert glrender.Image is glrender.Film


@pytest.mark.parametrize("ext", [".npy", ".pfm", ".exr"])
def test_save_float_round_trip(film, tmp_path, ext):
    from glrender.film import read_image

    path = tmp_path / f"out{ext}"
    film.save(path)
    np.testing.assert_array_equal(read_image(path), film.mean)


def test_save_exr_layers(film, tmp_path):
    from glrender.film.io import read_exr_layers

    path = tmp_path / "out.exr"
    film.save(path)
    layers = read_exr_layers(path)
    np.testing.assert_array_equal(layers["variance"], film.variance)
    np.testing.assert_array_equal(layers["albedo"], film.aov("albedo"))
    np.testing.assert_array_equal(layers["depth"], film.aov("depth"))


def test_save_hdr_round_trip(film, tmp_path):
    """Radiance RGBE keeps 8 mantissa bits against the pixel's largest channel."""
    from glrender.film import read_image

    path = tmp_path / "out.hdr"
    film.save(path)
    back = read_image(path)
    top = film.mean.max(axis=2, keepdims=True)
    assert np.all(np.abs(back - film.mean) <= top * 2.0 ** -7 + 1e-30)


@pytest.mark.parametrize("ext", [".png", ".jpg"])
def test_save_ldr_and_notebook_png(film, tmp_path, ext):
    from PIL import Image

    path = tmp_path / f"out{ext}"
    film.save(path)
    pixels = np.asarray(Image.open(path).convert("RGB"))
    expected = film.to_srgb8()
    if ext == ".png":
        np.testing.assert_array_equal(pixels, expected)
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(film._repr_png_()))), expected)
    else:  # JPEG: the same bytes as Pillow's encoding of the 8-bit image at quality 95
        buf = io.BytesIO()
        Image.fromarray(expected).save(buf, format="JPEG", quality=95)
        assert path.read_bytes() == buf.getvalue()


def test_render_accepts_a_path_and_renderer_matches(tmp_path):
    """render(path) loads the file; a Renderer stepped to the same spp gives the same image,
    bitwise (the accumulation does not depend on how passes are split)."""
    scene = small(CORNELL, 24)
    path = tmp_path / "scene.toml"
    path.write_text(CORNELL.read_text().replace("width = 256", "width = 24")
                    .replace("height = 256", "height = 24"))
    a = glrender.render(path, spp=12, seed=5, progress=False)
    with glrender.Renderer(scene, spp=12, seed=5) as r:
        assert r.step(5) == 5 and r.step(7) == 7
        b = r.image()
    np.testing.assert_array_equal(a.mean, b.mean)
    assert b.spp == 12


def test_cornell_in_code_equals_file():
    """The scene built in code and the file give the same image and settings, bitwise."""
    built = example("scene_in_code").cornell_box(size=32, spp=64)
    loaded = small(CORNELL)
    assert built.sampler == loaded.sampler and built.film == loaded.film
    a = glrender.render(built, spp=8, seed=2, progress=False)
    b = glrender.render(loaded, spp=8, seed=2, progress=False)
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.variance, b.variance)


def test_edit_material_and_light_in_code():
    scene = small(CORNELL, 16)
    before = glrender.render(scene, spp=8, progress=False)
    light = next(s for s in scene.shapes if s.emission is not None)
    light.emission = glrender.Emission(radiance=(0.0, 0.0, 0.0))
    dark = glrender.render(scene, spp=8, progress=False)
    assert before.mean.max() > 0 and dark.mean.max() == 0.0
    light.emission = glrender.Emission(radiance=(18.387, 13.9873, 6.75357))
    again = glrender.render(scene, spp=8, progress=False)
    np.testing.assert_array_equal(again.mean, before.mean)


def test_camera_edit_does_not_rebuild(monkeypatch):
    """Moving the camera of a Renderer keeps the packed scene, BVH and kernel: counted
    calls to the packer, the BVH builder and the compiler stay at one. The image after the
    move is bitwise that of a new renderer built with the moved camera."""
    monkeypatch.setenv("GLRENDER_CACHE", "off")   # every renderer builds its tree: the counter counts
    import glrender.accel
    import glrender.gl.shaders
    # glrender.render is the function: reach the module by its name
    renderer_module = importlib.import_module("glrender.gpu.device_scene")

    counts = {"pack": 0, "bvh": 0, "compile": 0}

    def counted(key, fn):
        def wrapper(*args, **kwargs):
            counts[key] += 1
            return fn(*args, **kwargs)
        return wrapper

    monkeypatch.setattr(renderer_module, "pack_scene", counted("pack", renderer_module.pack_scene))
    monkeypatch.setattr(glrender.accel.bvh_cache, "build_bvh", counted("bvh", glrender.accel.bvh_cache.build_bvh))
    monkeypatch.setattr(glrender.gl.shaders, "compile_compute",
                        counted("compile", glrender.gl.shaders.compile_compute))
    scene = small(BUNNY, 24)
    moved = replace(scene.camera, world_from_camera=glrender.translate((0.1, 0.05, 0.2))
                    @ scene.camera.world_from_camera, fov=scene.camera.fov * 0.8)
    with glrender.Renderer(scene, spp=8, seed=4) as r:
        assert r.packed.has_bvh
        r.step(8)
        first = r.image()
        r.set_camera(moved)
        assert r.spp_done == 0
        r.step(8)
        second = r.image()
        assert counts == {"pack": 1, "bvh": 1, "compile": 1}
    assert not np.array_equal(first.mean, second.mean)
    fresh_scene = small(BUNNY, 24)
    fresh_scene.camera = moved
    with glrender.Renderer(fresh_scene, spp=8, seed=4) as fresh:
        fresh.step(8)
        np.testing.assert_array_equal(fresh.image().mean, second.mean)
    assert counts["bvh"] == 2   # the fresh renderer did build (the counter counts)


def test_time_budget_and_progress():
    scene = small(CORNELL, 16)
    seen: list[tuple[int, float]] = []
    film = glrender.render(scene, time=0.3, progress=lambda spp, s: seen.append((spp, s)))
    assert film.stats["stopped"] == "time" and film.stats["spp_target"] is None
    assert film.spp > 0 and seen and seen[-1][0] == film.spp
    assert [s for s, _ in seen] == sorted(s for s, _ in seen)
    targets = []
    glrender.render(scene, spp=24, progress=False, callback=lambda d, t: targets.append((d, t)))
    assert targets[-1] == (24, 24)


def test_progress_bar_only_on_a_terminal(capsys):
    glrender.render(small(CORNELL, 16), spp=8, progress=True)
    assert capsys.readouterr().err == ""   # pytest's stderr is not a terminal


def test_single_way_to_set_up_a_render():
    """Only the device scene packs scenes and only the Renderer compiles the render kernel:
    the CLI, preview, lab and distributed paths go through them."""
    package = ROOT / "glrender"
    offenders = []
    for path in package.rglob("*.py"):
        text = path.read_text()
        rel = path.relative_to(package).as_posix()
        if "pack_scene(" in text and rel not in ("gpu/device_scene.py", "gpu/pack.py"):
            offenders.append(rel)
        if "kernels/render.comp.glsl" in text and rel != "render/renderer.py":
            offenders.append(rel)
    assert offenders == []
