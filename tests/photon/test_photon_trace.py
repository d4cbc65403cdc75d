"""Photon emission and tracing (shaders/photon/photon_trace.comp.glsl).

The photon kernel's emitted powers, averaged over the photons of a pass, equal the
lights' total power: per light kind and for a scene with one light of every kind
chosen by power (the alias table). Point, area, directional and constant lights
(and a spot whose beam width equals its cutoff) emit every photon with the same power
under power selection, so the mean matches to float32 precision (1e-5 relative);
a spot with a falloff ramp is a Monte Carlo estimate, judged against its standard
error from the photons' spread: it could see a 1% error.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from glrender.photon import SppmRenderer, SppmSettings
from glrender.photon import layout as pl
from glrender.scene import model as m
from glrender.testing.stats import sidak_z

from photon_scenes import plane_scene, spot_power

PHOTONS = 1 << 16
RADIANCE = 3.0
SPOT = dict(cutoff_angle=40.0, beam_width=25.0)


def lights():
    spot_axis = m.look_at((0.3, 0.2, 3.0), (0.0, 0.0, 0.0), (0, 1, 0))
    return {
        "point": (m.Light("point", position=(0.1, 0.2, 2.0), intensity=(2.0, 2.0, 2.0)), None),
        "spot": (m.Light("spot", world_from_light=spot_axis, intensity=(5.0, 5.0, 5.0), **SPOT), None),
        "area": (None, ((0.0, 0.0, 1.5), 0.25, RADIANCE)),
        "directional": (m.Light("directional", direction=(0.2, -0.1, -1.0), irradiance=(1.5,) * 3), None),
        "constant": (m.Light("constant", radiance=(0.7,) * 3), None),
    }


def expected_power(kind: str, light, renderer) -> float:
    """The light's emitted power (W) by closed form; lights at infinity: the power
    crossing the scene's bounding disk."""
    _, radius = renderer.base.packed.sphere_bounds
    if kind == "point":
        return 4 * math.pi * light.intensity[0]
    if kind == "spot":
        return spot_power(light.intensity[0], light.cutoff_angle, light.beam_width)
    if kind == "area":
        return math.pi * RADIANCE * (2 * 0.25) ** 2
    if kind == "directional":
        return light.irradiance[0] * math.pi * radius ** 2
    return light.radiance[0] * 4 * math.pi * math.pi * radius ** 2


def emitted(scene, gl_ctx):
    r = SppmRenderer(scene, sppm=SppmSettings(photons_per_iteration=PHOTONS), ctx=gl_ctx,
                     record_emission=True, light_selection="power")
    try:
        r.step(1)
        return r.emission_records(), r
    finally:
        r.release()


def test01_photon_params_layout():
    assert pl.PHOTON_PARAMS.itemsize == 80
    assert [pl.PHOTON_PARAMS.fields[k][1] for k in ("photons", "grid_size", "grid_lo", "options", "estimate")] == \
        [0, 16, 32, 48, 64]


@pytest.mark.parametrize("kind", list(lights()))
def test02_emitted_power_per_light_kind(gl_ctx, kind):
    light, area = lights()[kind]
    scene = plane_scene(light, area_light=area)
    (power, index), r = emitted(scene, gl_ctx)
    assert np.all(index == 0), "every photon starts on the scene's only light"
    expected = expected_power(kind, light, r)
    mean = power.mean(axis=0)
    if kind == "spot":
        stderr = power[:, 0].std(ddof=1) / math.sqrt(len(power))
        # Sobol' photons: the independent-sample error bar is an upper bound
        assert abs(mean[0] - expected) <= sidak_z(0.01, 1) * stderr, (mean, expected, stderr)
        assert stderr < 2.5e-3 * expected   # so a 1% error would show
    else:
        np.testing.assert_allclose(power, expected, rtol=1e-5)
    np.testing.assert_allclose(mean, mean[0], rtol=1e-6)


def test03_emitted_power_of_all_lights_chosen_by_power(gl_ctx):
    """Five lights of every kind; the spot's beam width equals its cutoff, so that every
    photon carries the total power exactly under power selection."""
    specs = lights()
    scene = plane_scene(None, area_light=specs["area"][1])
    spot = m.Light("spot", world_from_light=specs["spot"][0].world_from_light, intensity=(5.0,) * 3,
                   cutoff_angle=40.0, beam_width=40.0)
    for kind in ("point", "directional", "constant"):
        scene.lights.append(specs[kind][0])
    scene.lights.append(spot)
    (power, index), r = emitted(scene, gl_ctx)
    total = sum(expected_power(k, specs[k][0], r) for k in ("point", "directional", "constant", "area"))
    total += spot_power(5.0, 40.0, 40.0)
    np.testing.assert_allclose(power, total, rtol=1e-5)
    # every light is chosen, in proportion to its power (binomial, 5 sigma)
    counts = np.bincount(index.astype(np.int64), minlength=5)
    assert counts.sum() == PHOTONS and np.all(counts > 0)


def test04_visible_point_unit_vector_round_trip(gl_ctx):
    """The visible point keeps the BSDF's unperturbed normal (a normal map's shadowing term)
    in one float: octahedral, 11 bits a coordinate, exact as a float, back within 2e-3."""
    from glrender.testing.harness import run_glsl

    rng = np.random.default_rng(9)
    n = rng.normal(size=(4096, 3))
    n = np.concatenate([n, np.eye(3), -np.eye(3), [[0.0, 0.0, 1.0], [1e-3, 0.0, -1.0]]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    out = run_glsl("float code = vp_pack_unit(n); vec3 back = vp_unpack_unit(code);",
                   {"n": n.astype(np.float32)}, {"code": "float", "back": "vec3"},
                   includes=["photon/layout.glsl"])
    code = out["code"].astype(np.float64)
    assert np.all(code == np.round(code)) and code.min() >= 0 and code.max() < 2 ** 22
    np.testing.assert_allclose(out["back"], n, atol=2e-3)


def test05_sppm_deposits_carry_the_normal_map_shadowing_term(gl_ctx):
    """SPPM's photon deposits weight a normal-mapped plane under a directional light by the
    shadowing term of the light's direction: with the same seed (the same photons) the image
    with the term is the one without times the closed form, pixel by pixel."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))
    from test_surface_detail import flat_map, quad_scene, shadowing_term

    tilt, light = np.radians(60), np.radians(50)
    images = []
    for shadowing in (True, False):
        mat = m.Material("diffuse", reflectance=(0.5,) * 3, normal_shadowing=shadowing,
                         normal_map=flat_map((np.sin(tilt), 0, np.cos(tilt))))
        scene = quad_scene(mat, "mesh")
        scene.lights = [m.Light("directional", direction=(-np.sin(light), 0, -np.cos(light)),
                                irradiance=(2.0,) * 3)]
        scene.film = m.Film(16, 16, filter="box")
        r = SppmRenderer(scene, sppm=SppmSettings(direct="photons", photons_per_iteration=16384),
                         ctx=gl_ctx, seed=3)
        try:
            r.step(4)
            images.append(r.radiance()[4:12, 4:12])
        finally:
            r.release()
    assert images[1].min() > 0
    g = shadowing_term(np.cos(tilt), np.cos(light))
    # the visible point keeps the unperturbed normal to about 1e-3 rad (vp_pack_unit)
    np.testing.assert_allclose(images[0] / images[1], g, rtol=3e-3)
