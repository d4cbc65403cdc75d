"""Rendered furnaces: ideal interfaces inside a uniform environment of radiance 1.

A sphere that only reflects and refracts without loss, seen against a constant
environment of radiance 1 with unbounded path depth, has radiance exactly 1 in every
pixel: a smooth dielectric (the 1 / eta^2 of entering and the eta^2 of leaving cancel;
the Fresnel choice keeps every weight at 1), a thin dielectric sheet, and a conductor
with F = 1 (eta = 0, k = 1).
- test01: without Russian roulette every path weight is exactly 1 (up to float32
  rounding of eta^2 products): zero variance, so every pixel must be within 1e-5 of 1.
- test02: with the default roulette (from depth 5) the weights become 0 or 1 / q:
  sigma of the image mean from 4 independent seeds (independent sampler; per-pixel
  spread between seeds, pooled over all pixels: dof = pixels x 3), Šidák z over scenes
  x channels. At 4 x 32 spp on 24 x 24 pixels that detects a bias of ~0.03%.
"""
import numpy as np
import pytest

import glrender
from glrender.scene import model as m
from glrender.testing.stats import sidak_z

SIZE = 24
SCENES = {
    "dielectric-bk7": m.Material(kind="dielectric"),
    "dielectric-diamond-inverted": m.Material(kind="dielectric", int_ior=1.0, ext_ior=2.419),
    "thindielectric": m.Material(kind="thindielectric", int_ior=1.7),
    "conductor-ideal-mirror": m.Material(kind="conductor"),
}


def furnace_scene(material: m.Material, rr_depth: int) -> m.Scene:
    scene = m.Scene(source="<furnace>")
    scene.film = m.Film(width=SIZE, height=SIZE, filter="box")
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 3.2), (0, 0, 0), (0, 1, 0)), fov=45)
    scene.integrator = m.Integrator(max_depth=-1, rr_depth=rr_depth)
    scene.add_material(material)
    scene.shapes.append(m.Shape(kind="sphere", material=0, radius=1.0))
    scene.lights.append(m.Light(kind="constant", radiance=(1.0, 1.0, 1.0)))
    return scene


@pytest.mark.parametrize("name", list(SCENES))
def test01_furnace_without_roulette_is_exactly_one(gl_ctx, name):
    film = glrender.render(furnace_scene(SCENES[name], rr_depth=1 << 20), spp=16, seed=3,
                           sampler="independent", aovs=True)
    assert np.all(np.abs(film.mean - 1.0) <= 1e-5), np.abs(film.mean - 1.0).max()
    assert film.nonfinite.sum() == 0
    # the camera sees the sphere (first-hit depth 3.2 - 1 at the centre) in over a third
    # of the pixels
    depth = film.aovs["depth"]
    assert abs(depth[SIZE // 2, SIZE // 2] - 2.2) < 0.05
    assert np.count_nonzero((depth > 0) & (depth < 3.2)) > SIZE * SIZE // 3


SEEDS = (11, 22, 33, 44)
ROULETTE = [name for name in SCENES if SCENES[name].kind != "conductor"]  # mirror paths end first
Z = sidak_z(0.01, len(ROULETTE) * 3)


@pytest.mark.parametrize("name", ROULETTE)
def test02_furnace_with_roulette(gl_ctx, name):
    scene = furnace_scene(SCENES[name], rr_depth=5)
    images = np.stack([glrender.render(scene, spp=32, seed=s, sampler="independent").mean
                       for s in SEEDS]).astype(np.float64)
    var = images.var(axis=0, ddof=1).mean(axis=(0, 1))          # mean per-pixel variance
    se = np.sqrt(var / (SIZE * SIZE * len(SEEDS)))
    err = np.abs(images.mean(axis=(0, 1, 2)) - 1.0)
    assert np.all(var > 0)                                       # roulette did act
    assert np.all(err <= Z * se + 1e-5), (err, Z * se)
