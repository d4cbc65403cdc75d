"""Participating media in the path tracer (homogeneous): furnaces whose answer is known
exactly or in closed form, the enclosure filled with fog, and what media refuse.

Statistical comparisons use compare_images (glrender/testing/images.py): every block and
channel and the image mean at a Šidák alpha of 0.01 over all of this file's comparisons,
the standard errors from the spread of independent seeds."""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError, UsageError
from glrender.render.renderer import camera_tangents
from glrender.scene import model as m
from glrender.testing.images import compare_images

from render_scenes import base, enclosure

SEEDS = tuple(range(40, 48))
BLOCK = 8
SIZE = 32


def block_tests(size=SIZE, block=BLOCK):
    return 3 * (size // block) ** 2 + 2


COMPARISONS = 4    # the statistical comparisons of this file (Šidák)


def fog_sphere(sigma_t=2.0, albedo=1.0, phase="isotropic", g=0.0, size=SIZE, **integrator) -> m.Scene:
    """A unit sphere of fog bounded by a null surface (index-matched: no refraction) under
    a uniform environment of radiance 1, seen from 4 units away."""
    scene = base(size, size, **integrator)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 4), (0, 0, 0), (0, 1, 0)), fov=40)
    null = scene.add_material(m.Material("null"))
    fog = scene.add_medium(m.Medium(sigma_t=(sigma_t,) * 3 if np.isscalar(sigma_t) else tuple(sigma_t),
                                    albedo=(albedo,) * 3, phase=phase, g=g))
    scene.shapes.append(m.Shape("sphere", material=null, interior=fog))
    scene.lights.append(m.Light("constant", radiance=(1.0, 1.0, 1.0)))
    return scene


def renders(scene, spp, seeds=SEEDS):
    return np.stack([glrender.render(scene, spp=spp, seed=seed, sampler="independent",
                                     progress=False).mean for seed in seeds])


def chord_transmittance(scene, sigma_t, supersample=16):
    """Per pixel, the mean over its area (box filter) of exp(-sigma_t l), l the length of
    the camera ray's chord through the unit sphere at the origin."""
    w, h = scene.film.width, scene.film.height
    tx, ty = camera_tangents(scene.camera, w, h)
    s = supersample
    off = (np.arange(s) + 0.5) / s
    X, Y = np.meshgrid((np.arange(w)[:, None] + off).reshape(-1) / w,
                       (np.arange(h)[:, None] + off).reshape(-1) / h)
    d = np.stack([(1 - 2 * X) * tx, (1 - 2 * Y) * ty, np.ones_like(X)], axis=-1)
    M = scene.camera.world_from_camera
    d = d @ M[:3, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = M[:3, 3]
    b = d @ o
    disc = np.maximum(b * b - (o @ o - 1.0), 0.0)
    t = np.exp(-np.asarray(sigma_t)[None, None, :] * (2.0 * np.sqrt(disc))[..., None])
    return t.reshape(h, s, w, s, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("g", [0.0, 0.7, -0.7])
def test01_white_fog_furnace_by_phase_sampling_is_exactly_one(gl_ctx, g):
    """Albedo 1 (sigma_t 2 and 5 per unit), no next-event estimation, no Russian roulette,
    unbounded depth: every sample carries exactly 1 (the free-flight and phase weights are
    1, the environment 1), for isotropic and forward or backward Henyey-Greenstein
    scattering. (A chromatic extinction weighs each channel by sigma_t,c T_c over the
    channels' mean: 1 in expectation only, test02.)"""
    for sigma in (2.0, 5.0):
        scene = fog_sphere(sigma_t=sigma, phase="hg" if g else "isotropic", g=g, strategy="bsdf",
                           rr="off", max_depth=-1)
        film = glrender.render(scene, spp=16, seed=3, sampler="independent", progress=False)
        assert np.sum(film.truncated) == 0
        assert np.abs(film.mean - 1.0).max() <= 1e-5, (sigma, float(np.abs(film.mean - 1.0).max()))


def test02_white_fog_furnace_with_light_samples_is_one(gl_ctx):
    """The same furnace with next-event estimation through the fog (transmittance to the
    environment across the null boundary) and MIS against phase sampling: 1 within noise."""
    scene = fog_sphere(sigma_t=(0.5, 2.0, 5.0), phase="hg", g=0.6, max_depth=-1)
    v = renders(scene, 256)
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(v, np.ones(v.shape[1:]), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()


def test03_black_fog_is_the_chords_transmittance(gl_ctx):
    """Albedo 0: each pixel is the mean over its area of exp(-sigma_t l), l the chord of its
    ray through the sphere (supersampled 16 x 16 per pixel), per channel of a chromatic
    extinction (0.5, 1.5, 3)."""
    sigma = (0.5, 1.5, 3.0)
    scene = fog_sphere(sigma_t=sigma, albedo=0.0, max_depth=-1)
    v = renders(scene, 64)
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(v, chord_transmittance(scene, sigma), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()


def test04_white_fog_keeps_the_enclosure_at_le_over_one_minus_albedo(gl_ctx):
    """The closed enclosure (walls of albedo 0.5 emitting 1: L = 2 everywhere) filled with
    white fog around the camera (sigma_t 1.5, g 0.5): the radiance stays 2."""
    scene = enclosure(albedo=0.5, radiance=1.0, width=SIZE, height=SIZE, max_depth=-1)
    fog = scene.add_medium(m.Medium(sigma_t=(1.5,) * 3, albedo=(1.0,) * 3, phase="hg", g=0.5))
    scene.camera.medium = fog
    scene.shapes[0].interior = fog
    v = renders(scene, 16)
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(v, np.full(v.shape[1:], 2.0), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()


def test05_a_scene_without_media_compiles_none(gl_ctx):
    """Media cost nothing where no shape or camera names one: the kernel is compiled without
    them (golden hashes keep those images bitwise), even with media defined but unused."""
    from glrender.render.renderer import Renderer, settings_from_scene

    scene = fog_sphere()
    scene.shapes[0].interior = None
    r = Renderer(scene, settings_from_scene(scene, spp=1), ctx=gl_ctx)
    assert "GLRENDER_MEDIA" not in r.defines and not r.packed.has_media
    r.release()
    scene = fog_sphere()
    r = Renderer(scene, settings_from_scene(scene, spp=1), ctx=gl_ctx)
    assert r.defines.get("GLRENDER_MEDIA") == 1
    r.release()


def test06_what_media_refuse(gl_ctx):
    """Integrators and settings that do not render media yet, and grids, say so in one line."""
    scene = fog_sphere()
    for options in ({"integrator": "bdpt"}, {"integrator": "direct"}, {"light_samples": 2}):
        with pytest.raises(UsageError, match=r"participating media are rendered by --integrator path"):
            glrender.render(scene, spp=1, progress=False, **options)
    grid = fog_sphere()
    grid.media[0] = m.Medium(kind="heterogeneous",
                             sigma_t=m.Volume(np.ones((2, 2, 2, 1), np.float32)))
    with pytest.raises(SceneError, match=r"media with grids .* are not rendered yet"):
        glrender.render(grid, spp=1, progress=False)
