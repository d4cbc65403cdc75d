"""Drivers of one scene with different settings share its device scene (Renderer(share=...),
glrender.drivers.create_driver(share=...); glrender/gpu/device_scene.py): the packed arrays,
the BVH and triangle data, textures and the environment image are made once, the images are
the bits a driver of its own makes, and the data lives until the last driver using it is
released. The command line's noise pilot and seen-emission pass use it, and photon mapping
and SPPM share it like the render kernel's integrators."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import glrender.accel.bvh_cache
from glrender.errors import UsageError
from glrender.render.renderer import Renderer, settings_from_scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "denoise"))
from denoise_scenes import CORNELL, cornell, textured_cornell  # noqa: E402


@pytest.fixture
def builds(monkeypatch):
    """The number of BVH builds so far (the builder calls of glrender.accel.bvh_cache, through
    which a device scene builds its tree)."""
    count = [0]
    build = glrender.accel.bvh_cache.build_bvh

    def counted(*args, **kwargs):
        count[0] += 1
        return build(*args, **kwargs)

    monkeypatch.setattr(glrender.accel.bvh_cache, "build_bvh", counted)
    return count


def small_textured():
    """The textured Cornell box at 48x40 with a triangle mesh (an icosphere of 1,280
    triangles, too many to compile into the kernel) in the middle: textures and a BVH to
    share."""
    from dataclasses import replace

    import trimesh

    from glrender.scene import model as m

    scene = textured_cornell()
    scene.film = replace(scene.film, width=48, height=40)
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.25)
    scene.shapes.append(m.Shape("mesh", material=scene.shapes[1].material,
                                vertices=np.asarray(ball.vertices) + [0.0, 0.3, 0.0],
                                triangles=np.asarray(ball.faces)))
    return scene


def test01_shared_data_renders_the_same_bits(gl_ctx, builds):
    scene = small_textured()
    a = settings_from_scene(scene, spp=4, seed=1, integrator="path")
    b = settings_from_scene(scene, spp=6, seed=9, integrator="direct")
    with Renderer(scene, b, ctx=gl_ctx) as own:
        own.step(6)
        expected = own.film()
    assert own.packed.has_bvh and len(own.packed.textures), "the scene must exercise the BVH and textures"
    first = builds[0]
    with Renderer(scene, a, ctx=gl_ctx) as base:
        shared = Renderer(scene, b, ctx=gl_ctx, share=base)
        assert builds[0] == first + 1, "the sharing renderer built its own BVH"
        assert shared.packed is base.packed
    # the first renderer is released; the shared data lives on with the second
    shared.step(6)
    got = shared.film()
    shared.release()
    np.testing.assert_array_equal(got.mean, expected.mean)
    np.testing.assert_array_equal(got.variance, expected.variance)


def test02_sharing_needs_the_same_scene_and_a_live_renderer(gl_ctx):
    scene = small_textured()
    with Renderer(scene, settings_from_scene(scene, spp=1), ctx=gl_ctx) as base:
        with pytest.raises(UsageError, match="same scene object"):
            Renderer(cornell(), ctx=gl_ctx, share=base)
    with pytest.raises(UsageError, match="was released"):
        Renderer(scene, ctx=gl_ctx, share=base)


COUNT_PACKS = """
import importlib
import sys

from glrender.commands.cli import main

renderer_module = importlib.import_module("glrender.gpu.device_scene")

count = [0]
pack = renderer_module.pack_scene


def counted(*args, **kwargs):
    count[0] += 1
    return pack(*args, **kwargs)


renderer_module.pack_scene = counted
rc = main(sys.argv[1:])
print("packed", count[0], "rc", rc)
"""


def test03_cli_pilot_and_seen_emission_share_one_packing(tmp_path):
    """In its own process: the command line makes its own context, which stays current."""
    import os
    import subprocess

    from glrender.denoise import available

    args = ["render", str(CORNELL), "--width", "48", "--height", "32", "--quiet",
            "--noise-threshold", "0.2", "--spp", "8", "-o", str(tmp_path / "out.exr")]
    if available():
        args.append("--denoise")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-c", COUNT_PACKS, *args], capture_output=True, text=True,
                       env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out.exr").is_file()
    # the pilot, the render and (with --denoise) the seen-emission pass: one packed scene
    assert r.stdout.split()[-3:] == ["1", "rc", "0"], r.stdout


@pytest.mark.parametrize("integrator", ["photon", "sppm"])
def test04_photon_drivers_share_the_device_scene(gl_ctx, builds, integrator):
    from glrender.drivers import create_driver

    scene = small_textured()
    settings = settings_from_scene(scene, spp=2, seed=3, integrator=integrator)
    with create_driver(scene, settings, ctx=gl_ctx) as own:
        own.step(2)
        expected = own.film()
    first = builds[0]
    with Renderer(scene, settings_from_scene(scene, spp=1), ctx=gl_ctx) as base:
        shared = create_driver(scene, settings, ctx=gl_ctx, share=base)
        assert builds[0] == first + 1, f"{integrator} built its own BVH"
        assert shared.device_scene is base.device_scene
    shared.step(2)
    got = shared.film()
    shared.release()
    assert base.device_scene is None and shared.device_scene is None
    if integrator == "photon":
        np.testing.assert_array_equal(got.mean, expected.mean)
    else:   # SPPM deposits with float atomics: the same photons, sums in any order
        np.testing.assert_allclose(got.mean, expected.mean, rtol=1e-5, atol=1e-7)
