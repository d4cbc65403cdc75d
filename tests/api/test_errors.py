"""Every error path of the public API: the exception class and a message that names the
file, field or argument at fault."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"


def small(size: int = 16) -> glrender.Scene:
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=size, height=size)
    return scene


def test_hierarchy():
    for cls in (glrender.SceneError, glrender.ShaderError, glrender.DeviceError, glrender.UsageError):
        assert issubclass(cls, glrender.GlrenderError) and cls.exit_code == 2
    assert issubclass(glrender.UsageError, ValueError)


# -- load ----------------------------------------------------------------------------------
def test_load_unknown_format(tmp_path):
    path = tmp_path / "scene.blend"
    path.write_text("")
    with pytest.raises(glrender.SceneError, match=r"scene\.blend: unsupported scene format \.blend"):
        glrender.load(path)


def test_load_missing_file(tmp_path):
    with pytest.raises(glrender.SceneError, match=r"nothere\.toml: no such file"):
        glrender.load(tmp_path / "nothere.toml")


def test_load_bad_field_names_file_and_key(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(CORNELL.read_text().replace("max_depth = 8", "max_depth = \"deep\""))
    with pytest.raises(glrender.SceneError, match=r"bad\.toml: integrator\.max_depth"):
        glrender.load(path)


def test_load_unfilled_parameter(tmp_path):
    path = tmp_path / "params.toml"
    path.write_text(CORNELL.read_text().replace("spp = 64", "spp = \"$samples\""))
    with pytest.raises(glrender.SceneError, match=r"params\.toml.*samples"):
        glrender.load(path)
    assert glrender.load(path, samples=4).sampler.spp == 4


# -- scenes built in code ------------------------------------------------------------------
@pytest.mark.parametrize("make, pattern", [
    (lambda: glrender.Material("velvet"), r"material \?: unknown kind 'velvet'"),
    (lambda: glrender.Light("laser"), r"light \?: unknown kind 'laser'"),
    (lambda: glrender.Camera(fov=180.0), r"camera\.fov: expected degrees in \(0, 180\)"),
    (lambda: glrender.FilmSettings(width=0), r"film\.width: expected an integer"),
    (lambda: glrender.Integrator(kind="photon-map"), r"integrator: expected one of path"),
    (lambda: glrender.Sampler(kind="halton"), r"sampler: expected one of independent"),
    (lambda: glrender.look_at((0, 0, 0), (0, 0, 0), (0, 1, 0)), r"look_at: origin and target"),
])
def test_invalid_scene_parts(make, pattern):
    with pytest.raises(glrender.SceneError, match=pattern):
        make()


def test_render_checks_the_scene():
    scene = small()
    scene.shapes[0].material = 99
    with pytest.raises(glrender.SceneError, match=r"shape light: material index 99 out of range"):
        glrender.render(scene, spp=1, progress=False)
    with pytest.raises(glrender.SceneError, match="no shapes and no lights"):
        glrender.render(glrender.Scene(), spp=1, progress=False)


# -- render arguments ----------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, cls, pattern", [
    (dict(spp=0), glrender.UsageError, r"spp: expected a positive integer, got 0"),
    (dict(spp=2.5), glrender.UsageError, r"spp: expected a positive integer, got 2\.5"),
    (dict(time=-1.0), glrender.UsageError, r"time: expected a positive number of seconds"),
    (dict(time=float("nan")), glrender.UsageError, r"time: expected a positive number"),
    (dict(integrator="photon-map"), glrender.SceneError, r"integrator: expected one of path"),
    (dict(sampler="halton"), glrender.SceneError, r"sampler: expected one of"),
    (dict(strategy="best"), glrender.SceneError, r"integrator\.strategy"),
    (dict(max_depth=0), glrender.SceneError, r"integrator\.max_depth"),
    (dict(device="tpu"), glrender.DeviceError, r"expected auto, cpu, gpu or a device index, got 'tpu'"),
    (dict(denoise=True), glrender.UsageError, r"render: unknown option denoise \(expected "),
])
def test_render_bad_arguments(kwargs, cls, pattern):
    with pytest.raises(cls, match=pattern):
        glrender.render(small(), progress=False, **kwargs)


def test_render_bad_scene_argument(tmp_path):
    with pytest.raises(glrender.UsageError, match="expected a Scene or a scene file path, got int"):
        glrender.render(42)  # type: ignore[arg-type]
    with pytest.raises(glrender.SceneError, match="no such file"):
        glrender.render(tmp_path / "missing.toml")


# -- Film ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def film() -> glrender.Film:
    return glrender.render(small(8), spp=2, progress=False)


def test_film_missing_aov(film):
    with pytest.raises(glrender.UsageError, match=r"AOV 'albedo' was not rendered \(available: "
                                                  r"variance; render with aovs=True"):
        film.aov("albedo")


def test_film_save_errors(film, tmp_path):
    with pytest.raises(glrender.UsageError, match=r"out\.gif: unknown output format \.gif"):
        film.save(tmp_path / "out.gif")
    with pytest.raises(glrender.UsageError, match=r"the folder .*nowhere for the image does not exist"):
        film.save(tmp_path / "nowhere" / "out.png")
    with pytest.raises(glrender.UsageError, match=r"tone curve 'sepia'"):
        film.save(tmp_path / "out.png", curve="sepia")
    assert not (tmp_path / "out.png").exists()   # nothing half-written


# -- Renderer ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def renderer():
    with glrender.Renderer(small(8), spp=4) as r:
        yield r


def test_renderer_settings_or_overrides():
    scene = small(8)
    settings = glrender.settings_from_scene(scene)
    with pytest.raises(glrender.UsageError, match=r"either settings or overrides \(spp\)"):
        glrender.Renderer(scene, settings, spp=4)


def test_renderer_step_negative(renderer):
    with pytest.raises(glrender.UsageError, match="spp: expected a non-negative integer, got -1"):
        renderer.step(-1)


def test_renderer_set_camera_type(renderer):
    with pytest.raises(glrender.UsageError, match="set_camera: expected a glrender Camera, got ndarray"):
        renderer.set_camera(np.eye(4))  # type: ignore[arg-type]


def test_renderer_restore_mismatch(renderer):
    state = renderer.state()
    with glrender.Renderer(small(8), spp=4, seed=9) as other:
        with pytest.raises(glrender.UsageError, match="fingerprints differ"):
            other.restore(state)


def test_renderer_reset_rows(renderer):
    with pytest.raises(glrender.UsageError, match=r"rows \(5, 1\): expected \(first, count\) tile rows"):
        renderer.reset(rows=(5, 1))


def test_shader_error_names_file_and_line(gl_ctx):
    """A kernel that does not compile reports the shader file and line (the renderer's
    kernels are fixed, so this is reached through the preprocessor's public entry)."""
    from glrender.gl.shaders import compile_compute

    source = "#version 430\nlayout(local_size_x = 1) in;\nvoid main() { undefined_call(); }\n"
    with pytest.raises(glrender.ShaderError) as info:
        compile_compute(gl_ctx, None, source=source)
    assert ":3:" in str(info.value) and info.value.line == 3
