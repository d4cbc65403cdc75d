"""The emission AOV (the part of the beauty emitted by what the camera sees) and the
seen-emission pass that renders the same quantity on its own (emission_only).

Where every sample sees an emitter the AOV is exact (float32 rounding); the path tracer
follows mirrors and glass as for the albedo, the other integrators take the first hit;
the emission_only render equals the AOV of a full render bitwise at the same seed and
spp (the same camera samples, the same sums), so the denoiser subtracts and adds back
one quantity.
"""
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.render.emission_pass import EMISSION_SPP_MIN, emission_settings, emission_spp
from glrender.render.renderer import settings_from_scene
from glrender.scene import model as m

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_aov_through import glass_scene, mirror_scene  # noqa: E402
from denoise_scenes import cornell  # noqa: E402

LE = np.array([18.387, 13.9873, 6.75357], np.float32)    # the Cornell box light's radiance


def _without_wall(scene: m.Scene) -> m.Scene:
    """The mirror or glass scene with only the delta surface: every path leaves to the
    constant environment (radiance 1) through it."""
    scene.shapes = scene.shapes[:1]
    return scene


def _small_cornell() -> m.Scene:
    scene = cornell()
    scene.film = replace(scene.film, width=64, height=64)
    return scene


def _light_inside(film) -> np.ndarray:
    """(H, W) bool: the pixels whose every sample sees the light (emission AOV at Le to
    float32 rounding in all three channels)."""
    return np.all(np.abs(film.aov("emission") - LE) <= 1e-5 * LE, axis=-1)


def test01_environment_in_a_mirror_and_through_glass(gl_ctx):
    film = glrender.render(_without_wall(mirror_scene()), spp=4, seed=1, aovs=True)
    np.testing.assert_allclose(film.aov("emission"), 1.0, rtol=1e-6)
    np.testing.assert_array_equal(film.aov("albedo"), 0.0)
    np.testing.assert_array_equal(film.aov("emission"), film.mean)   # nothing else is lit
    # a thin pane: each sample reflects or transmits with its Fresnel probability,
    # weight 1 either way, and reaches the environment
    film = glrender.render(_without_wall(glass_scene()), spp=8, seed=2, aovs=True)
    np.testing.assert_allclose(film.aov("emission"), 1.0, rtol=1e-5)
    # the direct integrator records the first hit: the mirror emits nothing
    film = glrender.render(_without_wall(mirror_scene()), spp=2, seed=1, aovs=True,
                           integrator="direct")
    np.testing.assert_array_equal(film.aov("emission"), 0.0)
    assert film.mean.min() > 0.99                       # it sees the environment in it


def test02_a_wall_in_a_mirror_emits_nothing(gl_ctx):
    film = glrender.render(mirror_scene(), spp=4, seed=1, aovs=True)
    np.testing.assert_array_equal(film.aov("emission"), 0.0)
    assert film.mean.min() > 0                          # the wall is lit


@pytest.mark.parametrize("integrator", ["path", "direct", "bdpt"])
def test03_the_cornell_light_seen_directly(gl_ctx, integrator):
    film = glrender.render(_small_cornell(), spp=4, seed=3, aovs=True, integrator=integrator)
    emission = film.aov("emission")
    inside = _light_inside(film)
    assert inside.sum() >= 16                           # the light's face, 64x64 film
    # elsewhere 0, but on the light's edge: the pixels next to its face, partly covered
    near = np.pad(inside, 1)
    near = np.any([near[dy:dy + 64, dx:dx + 64] for dy in range(3) for dx in range(3)], axis=0)
    seen = emission.max(-1) > 0
    assert np.all(near[seen]) and seen.sum() > inside.sum()
    assert np.all(emission <= LE * (1 + 1e-5))
    # what is left on the light's face is the light it reflects: small against Le
    rest = film.mean - emission
    assert np.all(np.abs(rest[inside]) < 0.05 * LE)


def test04_hidden_emitters_and_light_tracing_record_none(gl_ctx):
    film = glrender.render(_small_cornell(), spp=2, seed=3, aovs=True, hide_emitters=True)
    np.testing.assert_array_equal(film.aov("emission"), 0.0)
    film = glrender.render(_small_cornell(), spp=2, seed=3, aovs=True, integrator="lighttrace")
    np.testing.assert_array_equal(film.aov("emission"), 0.0)


@pytest.mark.parametrize("scene, integrator", [
    (_small_cornell, "path"), (mirror_scene, "path"), (glass_scene, "path"),
    (lambda: _without_wall(mirror_scene()), "path"), (lambda: _without_wall(glass_scene()), "path"),
    (_small_cornell, "direct"), (lambda: _without_wall(mirror_scene()), "direct")])
def test05_emission_only_render_is_the_aov(gl_ctx, scene, integrator):
    """The seen-emission pass of emission_settings, at the render's own spp, is its
    emission AOV bitwise (the direct integrator's: the pass stops at the first hit)."""
    s = scene()
    full = glrender.render(s, spp=8, seed=4, aovs=True, integrator=integrator)
    pass_settings = emission_settings(settings_from_scene(s, spp=8, seed=4, integrator=integrator))
    alone = glrender.render(s, spp=8, seed=4, emission_only=True,
                            max_depth=pass_settings.integrator.max_depth)
    np.testing.assert_array_equal(alone.mean, full.aov("emission"))


def test06_pass_settings():
    scene = _small_cornell()
    s = emission_settings(settings_from_scene(scene, spp=16, seed=9, max_depth=5))
    assert s.emission_only and not s.aovs and s.integrator.kind == "path"
    assert s.sampler.spp == emission_spp(16) == 64 and s.sampler.seed == 9
    assert s.integrator.max_depth == 5
    assert emission_spp(1) == EMISSION_SPP_MIN and emission_spp(64) == 256
    # the direct, photon and BDPT integrators record the first hit: the pass stops there too
    for kind in ("direct", "bdpt", "photon"):
        s = emission_settings(settings_from_scene(scene, spp=4, integrator=kind))
        assert s.integrator.kind == "path" and s.integrator.max_depth == 1
    # nothing to render again: no emission AOV, or a clamp that scales it per sample
    assert emission_settings(settings_from_scene(scene, spp=4, integrator="ao")) is None
    assert emission_settings(settings_from_scene(scene, spp=4, integrator="lighttrace")) is None
    assert emission_settings(settings_from_scene(scene, spp=4, clamp=10.0)) is None
    with pytest.raises(glrender.UsageError, match="emission_only: only with the path"):
        settings_from_scene(scene, integrator="direct", emission_only=True)


def test07_photon_integrator_records_the_first_hit(gl_ctx):
    """The photon integrator's emission AOV is the first hit's emitted radiance: the
    seen-emission pass of emission_settings (the path tracer stopped at the first hit, at
    the render's own spp and seed) gives it bitwise."""
    from glrender.photon import PhotonRenderer
    from glrender.photon.photon import PhotonSettings

    s = _small_cornell()
    r = PhotonRenderer(s, photon=PhotonSettings(photons=1 << 12), ctx=gl_ctx, seed=4, spp=4,
                       aovs=True)
    try:
        r.step(4)
        emission = r.film().aov("emission")
    finally:
        r.release()
    assert emission.max() > 0
    pass_settings = emission_settings(settings_from_scene(s, spp=4, seed=4, integrator="photon"))
    assert pass_settings.integrator.max_depth == 1
    alone = glrender.render(s, spp=4, seed=4, emission_only=True, max_depth=1)
    np.testing.assert_array_equal(alone.mean, emission)
