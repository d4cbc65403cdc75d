"""The path tracer's albedo and normal AOVs follow mirrors and glass to the first non-delta
surface (the auxiliary images a denoiser wants); depth stays the first hit's.

Under the independent sampler each sample's albedo is the seen surface's albedo times the
delta surfaces' sampled weights (or 0 where the path leaves to the environment), so the
mean over a block of pixels is tested against its expectation with a 5-sigma band from
the binomial spread of the lobe choice (exact values where no choice is made).
"""
import numpy as np
import pytest

import glrender
from glrender.scene import model as m

SEEN = (0.6, 0.3, 0.1)        # the diffuse surface seen through the mirror or the glass


def _scene() -> m.Scene:
    scene = m.Scene(film=m.Film(width=16, height=16, filter="box"),
                    integrator=m.Integrator(kind="path", max_depth=8), source="<aov test>")
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 4), (0, 0, 0), (0, 1, 0)), fov=10)
    scene.lights.append(m.Light("constant", radiance=(1.0, 1.0, 1.0)))
    return scene


def mirror_scene() -> m.Scene:
    """A perfect mirror at the origin, normal (0, 1, 1)/sqrt(2): camera rays along -z leave
    along +y and meet a diffuse wall at y = 3 that faces -y."""
    scene = _scene()
    mirror = scene.add_material(m.Material("conductor"))          # eta 0, k 1: reflects all
    wall = scene.add_material(m.Material("diffuse", reflectance=SEEN))
    scene.shapes.append(m.Shape("rectangle", material=mirror, world_from_object=m.rotate((1, 0, 0), -45)))
    scene.shapes.append(m.Shape("rectangle", material=wall,
                                world_from_object=m.translate((0, 3, 0)) @ m.rotate((1, 0, 0), 90)
                                @ m.scale(3.0)))
    return scene


def glass_scene() -> m.Scene:
    """A thin glass pane facing the camera at z = 0, a diffuse wall behind it at z = -2."""
    scene = _scene()
    glass = scene.add_material(m.Material("thindielectric", int_ior=1.5, ext_ior=1.0))
    wall = scene.add_material(m.Material("diffuse", reflectance=SEEN))
    scene.shapes.append(m.Shape("rectangle", material=glass, world_from_object=m.scale(2.0)))
    scene.shapes.append(m.Shape("rectangle", material=wall,
                                world_from_object=m.translate((0, 0, -2)) @ m.scale(3.0)))
    return scene


def test01_albedo_and_normal_seen_in_a_mirror(gl_ctx):
    film = glrender.render(mirror_scene(), spp=4, seed=1, sampler="independent", aovs=True)
    albedo, normal, depth = film.aov("albedo"), film.aov("normal"), film.aov("depth")
    # every sample of every pixel sees the wall through the mirror (weight 1): float32 exact
    np.testing.assert_allclose(albedo, np.broadcast_to(SEEN, albedo.shape), rtol=1e-5)
    np.testing.assert_allclose(normal, np.broadcast_to((0, -1, 0), normal.shape), atol=1e-5)
    # depth is the mirror's (the tilted plane lies 3.7 to 4.4 away across the 10-degree
    # field; the wall, reached through it, more than 6.5)
    assert np.all((depth > 3.6) & (depth < 4.5))


def test02_albedo_and_normal_seen_through_glass(gl_ctx):
    spp = 16
    film = glrender.render(glass_scene(), spp=spp, seed=2, sampler="independent", aovs=True)
    albedo, normal, depth = film.aov("albedo"), film.aov("normal"), film.aov("depth")
    # a thin pane reflects R = 2r / (1 + r), r = ((eta - 1) / (eta + 1))^2 at normal incidence
    # (the camera's 10-degree field keeps incidence within 5 degrees: R changes < 1e-4); the
    # reflected samples see the environment (albedo 0), the transmitted ones the wall
    r = (0.5 / 2.5) ** 2
    t = 1.0 - 2 * r / (1 + r)
    n = albedo.shape[0] * albedo.shape[1] * spp
    band = 5.0 * np.sqrt(t * (1 - t) / n)          # binomial spread of the transmitted fraction
    frac = albedo.reshape(-1, 3).mean(0) / np.array(SEEN)
    np.testing.assert_allclose(frac, t, atol=band)
    np.testing.assert_allclose(normal.reshape(-1, 3).mean(0), (0, 0, t), atol=band)
    assert np.all(np.abs(depth - 4.0) < 0.05)


@pytest.mark.parametrize("integrator", ["direct"])
def test03_other_integrators_keep_the_first_hit(gl_ctx, integrator):
    """Only the path tracer follows delta surfaces; the direct integrator records the mirror."""
    film = glrender.render(mirror_scene(), spp=1, seed=1, integrator=integrator, aovs=True)
    np.testing.assert_allclose(film.aov("albedo"), 1.0, rtol=1e-5)
