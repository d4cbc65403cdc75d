"""Every integrator through one door: glrender.render and the cluster worker make their drivers
with glrender.drivers.create_driver, so the photon integrators render through the API as the
command line renders them; Renderer, the render kernel's driver, refuses them with a pointer."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender import integrators
from glrender.drivers import create_driver, options_class
from glrender.errors import UsageError
from glrender.photon import PhotonSettings, SppmSettings
from glrender.render.driver import RenderDriver
from glrender.vcm import VcmSettings

CORNELL = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"
OPTIONS = {"photon": PhotonSettings(photons=20000), "sppm": SppmSettings(photons_per_iteration=5000)}


def small_cornell():
    scene = glrender.load(CORNELL)
    scene.film = scene.film.resized(24, 24)
    return scene


@pytest.mark.parametrize("kind", ["photon", "sppm"])
def test01_photon_integrators_render_through_the_api(gl_ctx, kind):
    scene = small_cornell()
    film = glrender.render(scene, spp=2, seed=3, integrator=kind, progress=False,
                           integrator_options=OPTIONS[kind])
    assert film.spp == 2 and film.stats["integrator"] == kind
    assert film.stats["biased"] is True and "photon" in film.stats
    settings = glrender.settings_from_scene(scene, spp=2, seed=3, integrator=kind)
    driver = create_driver(scene, settings, OPTIONS[kind], ctx=gl_ctx)
    try:
        assert isinstance(driver, RenderDriver)
        driver.step(2)
        direct = driver.film().mean
    finally:
        driver.release()
    assert np.isfinite(film.mean).all() and film.mean.mean() > 0
    if kind == "photon":
        np.testing.assert_array_equal(film.mean, direct)
    else:     # SPPM deposits with float atomics: equal up to the order of its sums
        np.testing.assert_allclose(film.mean, direct, rtol=1e-6, atol=1e-7 * direct.max())


@pytest.mark.parametrize("kind", ["sppm", "photon"])
def test02_renderer_refuses_an_integrator_with_its_own_driver(gl_ctx, kind):
    with pytest.raises(UsageError, match=rf"integrator '{kind}' has its own driver.*create_driver"):
        glrender.Renderer(small_cornell(), integrator=kind, ctx=gl_ctx)


def test03_options_of_another_integrator_are_refused(gl_ctx):
    scene = small_cornell()
    with pytest.raises(UsageError, match=r"'sppm': its options are a SppmSettings, got "
                                         r"PhotonSettings"):
        glrender.render(scene, spp=1, integrator="sppm", progress=False,
                        integrator_options=PhotonSettings())
    with pytest.raises(UsageError, match=r"'path' takes no options of its own"):
        glrender.render(scene, spp=1, integrator="path", progress=False,
                        integrator_options=SppmSettings())


def test04_the_table_names_every_integrator_and_its_driver():
    assert integrators.names() == ("path", "direct", "ao", "lighttrace", "bdpt", "sppm",
                                   "photon", "vcm")
    assert glrender.scene.model.INTEGRATORS == integrators.names()
    for name in integrators.names():
        spec = integrators.get(name)
        assert (spec.glsl is None) == (spec.driver == "sppm")
        assert options_class(name) is {"kernel": None, "photon": PhotonSettings,
                                       "sppm": SppmSettings, "vcm": VcmSettings}[spec.driver]
    assert integrators.running_on("kernel") == ("path", "direct", "ao", "lighttrace", "bdpt")
    with pytest.raises(UsageError, match=r"integrator 'mlt': expected one of path, direct"):
        integrators.get("mlt")
