"""Light selection by the light BVH (``light_selection = "bvh"``) renders what power
selection renders: a street between two walls lit by 60 one-sided emitters (some turned to
the wall), 12 point lights and 8 spot lights whose intensities span three decades, under a
dim constant environment (a light at infinity, beside the tree), with a glossy floor. The
path tracer (MIS between light samples, whose probabilities now depend on the shading
point, and BSDF samples that hit emitters, weighed by the tree's probability at the vertex
they left; also with emitters large enough that BSDF samples find them often) and direct
lighting, per 8-pixel block at a Šidák-corrected alpha of 0.01 over every block, channel
and case of this file, sigma from the seeds. Also: the tree does what it is for (a lower
median pixel variance than power selection at equal samples), and the wavefront executor
refuses it in one line.
"""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.errors import UsageError
from glrender.render.renderer import settings_from_scene
from glrender.scene import model as m
from glrender.testing.images import compare_images
from glrender.lab.scenes import street, street_lamp

from render_scenes import base

SEEDS_POWER, SEEDS_BVH = tuple(range(31, 39)), tuple(range(41, 49))
BLOCK = 8
# (integrator, spp, emitter size): with emitters 1 across, BSDF samples find them often, and
# the MIS weights of those hits must take the tree's probability at the vertex they left
CASES = [("path", 64, 0.2), ("direct", 64, 0.2), ("path", 32, 1.0)]


def many_lights(size=32, emitter=0.2) -> m.Scene:
    """A street 40 long and 8 wide between two walls, seen along its length from one end:
    60 one-sided emitters (squares of side `emitter`) on the walls facing the street or
    turned away from it, 12
    point lights and 8 spots along it shining down, intensities over three decades, a
    glossy floor and a dim sky. Each point of the street is lit mostly by the few lights
    near it."""
    rng = np.random.default_rng(3)
    scene = base(size, size, max_depth=4)
    black = street(scene)
    for k in range(60):
        side = 1 if k % 2 else -1
        centre = (3.95 * side, rng.uniform(-19, 19), rng.uniform(0.5, 5.5))
        inward = k % 5 != 0   # one in five faces the wall: the tree rules those out
        normal = (-side if inward else side, rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3))
        radiance = 10 ** rng.uniform(0, 3) * rng.uniform(0.5, 1.0, 3) * 0.2
        frame = m.look_at(centre, np.add(centre, normal), (0, 0, 1))
        scene.shapes.append(m.Shape("rectangle", material=black, world_from_object=frame @ m.scale(emitter / 2),
                                    emission=m.Emission(tuple(radiance))))
    for k in range(20):
        scene.lights.append(street_lamp(rng, spot=k >= 12))
    scene.lights.append(m.Light("constant", radiance=(0.01, 0.015, 0.03)))
    return scene


def renders(scene, integrator, spp, seeds, selection):
    return np.stack([glrender.render(scene, spp=spp, integrator=integrator, seed=seed, progress=False,
                                     sampler="independent", light_selection=selection).mean
                     for seed in seeds])


def block_tests(scene):
    f = scene.film
    return 3 * -(-f.width // BLOCK) * -(-f.height // BLOCK) + 2


@pytest.mark.parametrize("integrator, spp, emitter", CASES)
def test01_bvh_matches_power_selection(gl_ctx, integrator, spp, emitter):
    scene = many_lights(emitter=emitter)
    power = renders(scene, integrator, spp, SEEDS_POWER, "power")
    bvh = renders(scene, integrator, spp, SEEDS_BVH, "bvh")
    ref, ref_se = power.mean(axis=0), power.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_POWER))
    extra = (len(CASES) - 1) * block_tests(scene)
    # (no MSE test: power selection's pixels are heavy-tailed here, small bright emitters
    # chosen rarely, and their per-pixel variances misjudge its expected error)
    c = compare_images(bvh, ref, ref_se, block=BLOCK, extra_tests=extra, check_mse=False)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.05, c.summary()
    # what the tree is for: less noise at equal samples, here in most pixels (not on the
    # glossy floor near the camera, which mirrors the far lights that the tree weighs down
    # by their distance: light selection does not see the BSDF)
    variance = lambda images: images.var(axis=0, ddof=1).mean(axis=-1)
    ratio = float(np.median(variance(bvh) / np.maximum(variance(power), 1e-12)))
    assert ratio < 0.75, ratio


@pytest.fixture(scope="module")
def scene():
    return many_lights()


def test02_the_wavefront_executor_refuses_it(scene):
    with pytest.raises(UsageError, match="light BVH"):
        settings_from_scene(scene, integrator="path", light_selection="bvh", executor="wavefront")


def test03_auto_chooses_by_the_light_count(gl_ctx):
    """``auto`` (the default): uniform below AUTO_POWER_LIGHTS light records, power from there
    on; the light BVH only on request."""
    from glrender.render.params import AUTO_POWER_LIGHTS, choose_light_selection
    from glrender.render.renderer import Renderer

    assert m.Integrator().light_selection == "auto"
    assert choose_light_selection("auto", AUTO_POWER_LIGHTS - 1) == "uniform"
    assert choose_light_selection("auto", AUTO_POWER_LIGHTS) == "power"
    assert all(choose_light_selection(s, 10 ** 6) == s for s in ("uniform", "power", "bvh"))
    scene = many_lights(size=8)          # 60 emitters, 20 point and spot lights and the sky
    few = base(8, 8)
    few.camera = scene.camera
    few.shapes, few.lights, few.materials = scene.shapes[:3], scene.lights[-3:], scene.materials
    for s, want in ((scene, "power"), (few, "uniform")):
        with Renderer(s, settings_from_scene(s, spp=1)) as r:
            assert r.settings.integrator.light_selection == want
            assert (len(r.packed.lights) >= AUTO_POWER_LIGHTS) == (want == "power")


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test04_bsdf_samples_that_escape_weigh_the_sky_at_their_vertex(gl_ctx, integrator):
    """A bright sky beside the tree: a BSDF sample that escapes to it is weighed against light
    sampling by the sky's probability at the vertex it left, for the normal the vertex's
    light samples chose with (the root's importance bounds the cosine to the normal, so the
    sky's share depends on it). Lights far off at the floor's horizon make the cosine small:
    weighed without the normal the image came out 4% bright. bvh matches uniform selection
    per block."""
    scene = base(16, 16, max_depth=2)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, -6, 3), (0, 0, 0), (0, 0, 1)), fov=45)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.7, 0.7, 0.7)))
    scene.shapes.append(m.Shape("rectangle", material=grey, world_from_object=m.scale((4.0, 4.0, 1.0))))
    for k in range(6):
        scene.lights.append(m.Light("point", position=(12 + 0.3 * k, 0.2 * k, 0.05), intensity=(50.0, 45.0, 40.0)))
    scene.lights.append(m.Light("constant", radiance=(1.0, 1.1, 1.3)))
    uniform = renders(scene, integrator, 64, SEEDS_POWER, "uniform")
    bvh = renders(scene, integrator, 64, SEEDS_BVH, "bvh")
    ref, ref_se = uniform.mean(axis=0), uniform.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_POWER))
    c = compare_images(bvh, ref, ref_se, block=4, extra_tests=3 * 4 * 4 + 2)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.01, c.summary()
