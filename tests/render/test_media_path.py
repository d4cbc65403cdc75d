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


COMPARISONS = 13   # the statistical comparisons of this file (Šidák)


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
    """Integrators and settings that do not render media yet, and an albedo grid that is not
    the sigma_t grid's, say so in one line."""
    scene = fog_sphere()
    for options in ({"integrator": "ao"}, {"light_samples": 2}):
        with pytest.raises(UsageError, match=r"participating media are rendered by --integrator path"):
            glrender.render(scene, spp=1, progress=False, **options)
    odd = fog_sphere()
    odd.media[0] = m.Medium(kind="heterogeneous", sigma_t=grid_volume(4),
                            albedo=m.Volume(np.ones((2, 2, 2, 1), np.float32)))
    with pytest.raises(SceneError, match=r"the albedo grid must have the sigma_t grid's voxels"):
        glrender.render(odd, spp=1, progress=False)


def grid_volume(n=20, value=1.0, corner=None) -> m.Volume:
    """An n^3 grid of ``value`` over the cube [-1, 1]^3 around the fog sphere, voxel
    (0, 0, 0) set to ``corner``: with trilinear lookups it reaches only points within
    1.5 voxels of that corner of the cube, all outside the unit sphere, so the sphere's
    fog stays ``value`` while the majorant of the corner's supervoxel (8 voxels a side, with
    a one-voxel apron: the rays through the sphere cross it) is the corner's."""
    data = np.full((n, n, n, 1), value, np.float32)
    if corner is not None:
        data[0, 0, 0, 0] = corner
    return m.Volume(data, world_from_object=m.translate((-1.0, -1.0, -1.0)) @ m.scale(2.0))


def grid_fog(scene, volume, albedo, scale=1.0):
    scene.media[0] = m.Medium(kind="heterogeneous", sigma_t=volume, albedo=(albedo,) * 3,
                              scale=scale, phase=scene.media[0].phase, g=scene.media[0].g)
    return scene


@pytest.mark.parametrize("corner", [None, 4.0], ids=["tight", "majorant-2x"])
def test07_grid_fog_furnace_by_phase_sampling_is_exactly_one(gl_ctx, corner):
    """A heterogeneous white fog (a grid with a smooth bump, 21^3 voxels: 3 x 3 x 3
    supervoxels, the last ones partial; scale 2, and once with a corner voxel that raises
    its supervoxel's majorant): delta tracking's null collisions and scattering events weigh
    exactly 1 in a grey medium, so by phase sampling alone every sample is 1."""
    n = 21
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n),) * 3, indexing="ij")
    data = (1.0 + 0.8 * np.exp(-(x * x + y * y + z * z) * 2.0)).astype(np.float32)[..., None]
    if corner is not None:
        data[0, 0, 0, 0] = corner
    volume = m.Volume(data, world_from_object=m.translate((-1.0, -1.0, -1.0)) @ m.scale(2.0))
    scene = grid_fog(fog_sphere(phase="hg", g=0.4, strategy="bsdf", rr="off", max_depth=-1),
                     volume, 1.0, scale=2.0)
    film = glrender.render(scene, spp=16, seed=5, sampler="independent", progress=False)
    assert np.sum(film.truncated) == 0
    assert np.abs(film.mean - 1.0).max() <= 1e-5, float(np.abs(film.mean - 1.0).max())


@pytest.mark.parametrize("corner", [None, 2.0], ids=["tight", "majorant-2x"])
def test08_constant_grid_fog_matches_the_closed_forms(gl_ctx, corner):
    """A grid of constant density 1.5 (once with a majorant twice too large): black, each
    pixel is its chords' transmittance exp(-1.5 l) (delta tracking's free flights); white
    with light samples (ratio tracking's transmittance toward the environment), 1."""
    black = grid_fog(fog_sphere(max_depth=-1), grid_volume(value=1.0, corner=corner and corner / 1.5),
                     0.0, scale=1.5)
    v = renders(black, 64)
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(v, chord_transmittance(black, (1.5,) * 3), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()
    white = grid_fog(fog_sphere(phase="hg", g=0.6, max_depth=-1),
                     grid_volume(value=1.0, corner=corner and corner / 1.5), 1.0, scale=1.5)
    v = renders(white, 64)
    c = compare_images(v, np.ones(v.shape[1:]), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()


def test09_light_through_an_absorbing_slab_is_its_closed_form(gl_ctx):
    """A diffuse plane (albedo 0.5) seen from straight above, lit by a directional light at
    60 degrees from the vertical through a slab of absorbing fog (sigma_t (0.3, 0.8, 1.6),
    0.5 thick, bounded by a null box) that the camera rays do not cross: direct lighting
    alone (max depth 2) gives every sample rho / pi E cos(60) exp(-sigma_t 0.5 / cos(60))
    where the light's path crosses the whole slab, and the same without the exponential
    where it misses it, to 1e-5 (the transmittance of a homogeneous medium is closed form)."""
    from render_scenes import plane_points, plane_under_light

    theta = np.radians(60.0)
    light = m.Light("directional", direction=(np.sin(theta), 0.0, -np.cos(theta)), irradiance=(3.0,) * 3)
    scene = plane_under_light(light, albedo=0.5, width=SIZE, height=SIZE, max_depth=2)
    null = scene.add_material(m.Material("null"))
    sigma = np.array([0.3, 0.8, 1.6])
    slab = scene.add_medium(m.Medium(sigma_t=tuple(sigma), albedo=(0.0,) * 3))
    # x in [-5, -1.5], |y| <= 2, z in [1, 1.5]: the light's rays to the plane at x <= 0.2
    # cross it whole, those to x >= 1.1 miss it; the camera sees |x|, |y| <= 1.4
    box = m.translate((-3.25, 0.0, 1.25)) @ m.scale((1.75, 2.0, 0.25))
    scene.shapes.append(m.Shape("cube", material=null, interior=slab, world_from_object=box))
    film = glrender.render(scene, spp=4, seed=1, sampler="independent", progress=False)
    x = plane_points(scene, supersample=4)[..., 0]
    lit = 0.5 / np.pi * 3.0 * np.cos(theta)
    through = np.all(x <= 0.2, axis=-1)
    clear = np.all(x >= 1.1, axis=-1)
    assert through.sum() > 50 and clear.sum() > 50
    want = lit * np.exp(-sigma * 0.5 / np.cos(theta))
    np.testing.assert_allclose(film.mean[through], np.broadcast_to(want, film.mean[through].shape), rtol=1e-5)
    np.testing.assert_allclose(film.mean[clear], lit, rtol=1e-5)


def test10_supervoxel_majorants_bound_every_lookup():
    """The local majorants of a heterogeneous medium (glrender/gpu/pack.py
    supervoxel_majorants): at 20,000 random points of a random grid of 3 channels (odd
    sizes: partial supervoxels), the trilinear lookup's largest channel never exceeds the
    bound of the supervoxel holding the point (the one-voxel apron covers the half voxel a
    lookup reads beyond it), and each bound is attained within its supervoxel and apron."""
    from glrender.gpu import layout
    from glrender.gpu.pack import supervoxel_majorants

    rng = np.random.default_rng(4)
    res = np.array([19, 11, 26])   # x, y, z
    data = rng.random((res[2], res[1], res[0], 3)) ** 4 * 5.0
    bounds = supervoxel_majorants(data.max(axis=3), 2.0)
    u = rng.random((20000, 3))
    c = np.clip(u * res - 0.5, 0, res - 1)
    a = np.floor(c).astype(int)
    b = np.minimum(a + 1, res - 1)
    f = c - a
    value = 0.0
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                ix, iy, iz = (b if dx else a)[:, 0], (b if dy else a)[:, 1], (b if dz else a)[:, 2]
                w = (f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1]) * \
                    (f[:, 2] if dz else 1 - f[:, 2])
                value = value + w[:, None] * data[iz, iy, ix]
    cell = np.minimum((u * res / layout.SUPERVOXEL).astype(int), np.array(bounds.shape[::-1]) - 1)
    bound = bounds[cell[:, 2], cell[:, 1], cell[:, 0]]
    assert np.all(2.0 * value.max(axis=1) <= bound * (1 + 1e-12))
    assert bounds.shape == (4, 2, 3) and bounds.max() == 2.0 * data.max()


def fog_over_floor(chromatic_grid: bool) -> m.Scene:
    """The parity suite's fog ball over a floor under an area light (32x32), its medium
    grey and homogeneous, or a chromatic grid with a bump (21^3 voxels, 3 channels)."""
    from pathlib import Path

    scene = glrender.load(Path(__file__).resolve().parents[1] / "parity" / "scenes" / "medium-homogeneous.xml")
    scene.film = m.Film(width=SIZE, height=SIZE, filter="box")
    if chromatic_grid:
        n = 21
        z, y, x = np.meshgrid(*(np.linspace(-1, 1, n),) * 3, indexing="ij")
        bump = np.exp(-(x * x + y * y + z * z) * 2.0)[..., None]
        data = (bump * np.array([0.5, 1.5, 3.0]) + 0.2).astype(np.float32)
        volume = m.Volume(data, world_from_object=m.translate((-0.8, 0.0, -0.8)) @ m.scale(1.6))
        scene.media[0] = m.Medium(kind="heterogeneous", sigma_t=volume, albedo=(0.9, 0.7, 0.5),
                                  scale=2.0, phase="hg", g=0.5)
    return scene


@pytest.mark.parametrize("chromatic_grid, strategy", [(False, None), (True, None), (False, "bsdf"), (True, "bsdf")],
                         ids=["homogeneous", "chromatic-grid", "homogeneous-bsdf", "chromatic-grid-bsdf"])
def test11_direct_is_single_scattering(gl_ctx, chromatic_grid, strategy):
    """`direct` with media estimates single scattering: on a fog ball over a floor (grey and
    homogeneous; a chromatic grid), per block and in the image mean the path tracer at max
    depth 2 (its reference: 8 seeds of 256 samples, their spread its error); with MIS, and
    with BSDF and phase samples alone (the emitters they find through the fog; 1,024
    samples)."""
    scene = fog_over_floor(chromatic_grid)
    if strategy is not None:
        scene.integrator.strategy = strategy
    seeds = range(60, 68)
    path = np.stack([glrender.render(scene, spp=256, seed=k, sampler="independent", max_depth=2,
                                     progress=False).mean for k in seeds])
    direct = np.stack([glrender.render(scene, spp=256 if strategy is None else 1024, seed=k + 100,
                                       sampler="independent",
                                       integrator="direct", progress=False).mean for k in seeds])
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(direct, path.mean(axis=0), path.std(axis=0, ddof=1) / np.sqrt(len(seeds)),
                       block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.02, c.summary()


def test12_direct_single_scattering_from_a_point_light_in_a_slab(gl_ctx):
    """A point light (intensity 5) inside a slab of fog (|z| <= 0.5, sigma_t 0.8, albedo 0.7,
    Henyey-Greenstein g = 0.4) seen from z = 5 through it against a black background:
    `direct`'s image is single scattering, per pixel the integral along each camera ray of
    exp(-sigma_t s) sigma_s p(cos) I / r^2 exp(-sigma_t r) over the slab (s: the depth
    reached inside it, r: the distance to the light, cos between the ray and the light's
    direction), by 1D quadrature (4,000 points, 4 x 4 rays a pixel)."""
    sigma_t, albedo, g, intensity = 0.8, 0.7, 0.4, 5.0
    light = np.array([1.6, 0.3, 0.1])
    scene = base(SIZE, SIZE, max_depth=2)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 5), (0, 0, 0), (0, 1, 0)), fov=20)
    null = scene.add_material(m.Material("null"))
    fog = scene.add_medium(m.Medium(sigma_t=(sigma_t,) * 3, albedo=(albedo,) * 3, phase="hg", g=g))
    scene.shapes.append(m.Shape("cube", material=null, interior=fog,
                                world_from_object=m.scale((10.0, 10.0, 0.5))))
    scene.lights.append(m.Light("point", position=tuple(light), intensity=(intensity,) * 3))
    v = np.stack([glrender.render(scene, spp=256, seed=k, sampler="independent", integrator="direct",
                                  progress=False).mean for k in range(8)])

    w = h = SIZE
    tx, ty = camera_tangents(scene.camera, w, h)
    s = 4
    off = (np.arange(s) + 0.5) / s
    X, Y = np.meshgrid((np.arange(w)[:, None] + off).reshape(-1) / w, (np.arange(h)[:, None] + off).reshape(-1) / h)
    M = scene.camera.world_from_camera
    d = np.stack([(1 - 2 * X) * tx, (1 - 2 * Y) * ty, np.ones_like(X)], axis=-1) @ M[:3, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = M[:3, 3]
    t_in, t_out = (o[2] - 0.5) / -d[..., 2], (o[2] + 0.5) / -d[..., 2]
    n = 4000
    u = (np.arange(n) + 0.5) / n
    t = t_in[..., None] + (t_out - t_in)[..., None] * u                  # (H s, W s, n)
    p = o + t[..., None] * d[..., None, :]
    to_light = light - p
    r = np.linalg.norm(to_light, axis=-1)
    cos = np.einsum("...k,...nk->...n", d, to_light) / r
    phase = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * cos) ** 1.5)
    integrand = np.exp(-sigma_t * (t - t_in[..., None])) * albedo * sigma_t * phase * intensity / r ** 2 \
        * np.exp(-sigma_t * r)
    radiance = integrand.mean(axis=-1) * (t_out - t_in)
    ref = radiance.reshape(h, s, w, s).mean(axis=(1, 3))
    extra = (COMPARISONS - 1) * block_tests()
    c = compare_images(v, np.repeat(ref[..., None], 3, axis=-1), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()


def test13_chromatic_fog_is_each_channels_grey_fog(gl_ctx):
    """Spectral MIS over hero channels is unbiased: in a chromatic scene each channel equals
    the grey scene made of that channel's coefficients. The camera sits in chromatic haze
    (inside a null sphere of radius 8) and looks at a null sphere of denser chromatic fog
    under a uniform environment, so a
    path's first segment crosses a null surface after medium events (where a hero channel
    drawn again mid-path once biased the image 1-2%); per block and in the image mean, with
    the grey renders' spread as the reference's error."""
    def scene_of(sigma_haze, sigma_ball, albedo):
        scene = fog_sphere(sigma_t=sigma_ball, albedo=1.0, phase="hg", g=0.5)
        scene.media[0] = m.Medium(sigma_t=tuple(sigma_ball), albedo=tuple(albedo), phase="hg", g=0.5)
        haze = scene.add_medium(m.Medium(sigma_t=tuple(sigma_haze), albedo=tuple(albedo)))
        scene.shapes[0].exterior = haze
        null = scene.shapes[0].material
        scene.shapes.append(m.Shape("sphere", material=null, radius=8.0, interior=haze))
        scene.camera = m.Camera(world_from_camera=scene.camera.world_from_camera, fov=40, medium=haze)
        return scene

    haze, ball, albedo = np.array([0.05, 0.15, 0.3]), np.array([0.5, 1.5, 3.0]), np.array([0.95, 0.8, 0.6])
    seeds = range(80, 88)
    chromatic = renders(scene_of(haze, ball, albedo), 64, seeds)
    grey = [renders(scene_of((haze[c],) * 3, (ball[c],) * 3, (albedo[c],) * 3), 64, range(90, 98))
            for c in range(3)]
    ref = np.stack([g.mean(axis=0)[..., c] for c, g in enumerate(grey)], axis=-1)
    ref_se = np.stack([g.std(axis=0, ddof=1)[..., c] for c, g in enumerate(grey)], axis=-1) / np.sqrt(8)
    c = compare_images(chromatic, ref, ref_se, block=BLOCK, extra_tests=(COMPARISONS - 1) * block_tests())
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()
