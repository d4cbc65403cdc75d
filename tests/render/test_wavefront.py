"""The wavefront executor (glrender/render/wavefront.py) renders the render kernel's images
bit for bit: the same paths, the same random numbers, the same exact sums.

Its extend stage traces each ray's BVH hit up to the ray's own t_max instead of the
nearest compiled primitive's distance; the nearest triangle is the same, so the images
agree exactly unless two triangles tie at the hit (a ray through a shared edge), which
these scenes' rays do not meet: each comparison is of whole accumulations, word for word.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh

import glrender
from glrender.accel import MotionInstance
from glrender.errors import UsageError
from glrender.render import wavefront
from glrender.render.renderer import Renderer, RenderSettings, settings_from_scene
from glrender.scene import model as m

from render_scenes import enclosure

ROOT = Path(__file__).resolve().parents[2]


def shipped(name: str, size: int = 40) -> m.Scene:
    scene = glrender.load(ROOT / "scenes" / name / "scene.toml")
    scene.film = replace(scene.film, width=size, height=size - 8)
    return scene


def moving_mesh_in_enclosure() -> m.Scene:
    """A mesh that turns and moves over the shutter (its own BVH, traced at a time) inside a
    closed emissive cube of albedo 0.9: with max depth unbounded and no roulette, paths run
    to the 256-segment cap and are counted."""
    ico = trimesh.creation.icosphere(subdivisions=2, radius=0.25)
    sc = enclosure(albedo=0.9, width=16, height=12, max_depth=-1, rr="off")
    sc.film = replace(sc.film, filter="gaussian")
    mat = sc.add_material(m.Material("roughplastic", reflectance=(0.6, 0.3, 0.2), alpha=0.2))
    obj = m.Shape("mesh", material=mat, vertices=ico.vertices, triangles=ico.faces,
                  world_from_object=m.translate((0.5, 0.3, -0.5)))
    obj.world_from_object_close = m.translate((0.7, 0.4, -0.6)) @ m.rotate((0, 0, 1), 60)
    sc.shapes.append(obj)
    sc.lights.append(m.Light("point", position=(0.1, 0.1, 0.1), intensity=(0.5,) * 3))
    sc.shutter = m.Shutter(0, 1)
    return sc


def accumulations(scene: m.Scene, spp: int, steps: int = 2, **options) -> dict[str, dict]:
    out = {}
    for executor in ("megakernel", "wavefront"):
        r = Renderer(scene, settings_from_scene(scene, spp=spp * steps, executor=executor, **options))
        try:
            for _ in range(steps):
                r.step(spp)
            out[executor] = r.state()
        finally:
            r.release()
    return out


def assert_same(states: dict[str, dict]) -> None:
    a, b = states["megakernel"], states["wavefront"]
    keys = [k for k, v in a.items() if isinstance(v, np.ndarray)]
    assert keys
    for k in keys:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


@pytest.mark.parametrize("name", ["cornell-bunny", "caustic"])
def test01_bitwise_the_render_kernels_image(gl_ctx, name):
    states = accumulations(shipped(name), spp=3)
    assert_same(states)
    assert states["wavefront"]["sums"].any()


def test02_many_waves_and_passes(gl_ctx, monkeypatch):
    """Waves of 512 paths: a pass takes dozens of them (and a wave ends mid-pixel)."""
    monkeypatch.setattr(wavefront, "MAX_CAPACITY", 512)
    assert_same(accumulations(shipped("cornell-bunny", 24), spp=5, steps=3))


def test03_aovs_depth_cap_and_motion(gl_ctx):
    """The AOVs, the depth cap's count of cut paths, and a mesh that moves over the shutter,
    in one scene (one set of programs)."""
    states = accumulations(moving_mesh_in_enclosure(), spp=1, aovs=True)
    assert_same(states)
    cut = states["wavefront"]["sums"].reshape(-1, 4, 4)[:, 3, 2]   # counts.z: paths cut
    assert cut.sum() > 0
    assert states["wavefront"]["aov"].any()


def test04_refused_settings_name_the_executor(gl_ctx):
    scene = shipped("cornell-box", 16)
    for options, words in (({"integrator": "bdpt"}, "runs the path integrator, not bdpt"),
                           ({"split": 2}, "one light sample and no splitting"),
                           ({"light_samples": 2}, "one light sample and no splitting")):
        with pytest.raises(UsageError, match=words):
            settings_from_scene(scene, executor="wavefront", **options)
    with pytest.raises(UsageError, match="executor: expected one of megakernel, wavefront"):
        settings_from_scene(scene, executor="streams")
    # settings made directly are checked the same way
    with pytest.raises(UsageError, match="runs the path integrator, not bdpt"):
        RenderSettings(m.Integrator(kind="bdpt"), m.Sampler(), executor="wavefront")


def test05_local_size_is_the_hosts():
    from glrender.gl.shaders import packaged_root

    src = (packaged_root() / "kernels" / "wavefront.comp.glsl").read_text()
    assert f"layout(local_size_x = {wavefront.LOCAL_SIZE}) in;" in src
