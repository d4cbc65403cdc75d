"""Light tracing against the path tracer (and closed forms), per 16x16 block (4x4 on the
small analytic scenes) at a Šidák-corrected alpha of 0.01 over every block, channel
and scene of this file (glrender.testing.images.compare_images, sigma from four
independent seeds of each integrator). Light tracing cannot render what the camera
sees through glass: the caustic scene is compared where the first hit is non-specular.
Each comparison states the image-mean bias it can detect (asserted below 2%; 4% on the
caustic, where the path tracer's own noise dominates).
"""
import numpy as np
import pytest

import glrender
from glrender.testing.images import compare_images

from bidir_scenes import (caustic, closed_enclosure, cornell, glossy, non_specular_first_hit,
                          path_reference, point_light, renders, thin_lens)

SEEDS_PATH, SEEDS_LT = (11, 12, 13, 14), (21, 22, 23, 24)
# name: (scene, block, path spp, lighttrace spp)
SCENES = {
    "cornell": (cornell, 16, 64, 64),
    "glossy": (glossy, 16, 64, 64),
    "thin-lens": (thin_lens, 16, 64, 64),
    "point-light": (point_light, 4, 16, 128),
    "enclosure": (closed_enclosure, 4, 16, 16),
    "caustic": (caustic, 8, 256, 256),
}


def block_tests(scene, block):
    f = scene.film
    return 3 * -(-f.width // block) * -(-f.height // block) + 2


@pytest.fixture(scope="module")
def all_tests():
    return sum(block_tests(make(), block) for make, block, _, _ in SCENES.values())


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SCENES))
def test01_lighttrace_matches_path(gl_ctx, all_tests, name):
    make, block, spp_path, spp_lt = SCENES[name]
    scene = make()
    extra = all_tests - block_tests(scene, block)
    lt = renders(scene, "lighttrace", spp_lt, SEEDS_LT)
    mask = non_specular_first_hit(scene) if name == "caustic" else None
    if name == "enclosure":
        # closed form: L = Le / (1 - albedo) = 2 everywhere (zero reference error)
        ref, ref_se = np.full(lt.shape[1:], 2.0), None
    else:
        ref, ref_se = path_reference(scene, spp_path, SEEDS_PATH)
    c = compare_images(lt, ref, ref_se, block=block, mask=mask, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < (0.04 if name == "caustic" else 0.02), c.summary()


def test02_one_dispatch_or_many_bitwise(gl_ctx):
    """Integer fixed-point splats: the image does not depend on how a pass is split."""
    scene = cornell(32)
    images = []
    for time_target in (1e-9, 10.0):   # one tile per dispatch vs the whole image in one
        from glrender.render.renderer import Renderer, settings_from_scene
        r = Renderer(scene, settings_from_scene(scene, integrator="lighttrace", spp=8, seed=5,
                                                time_target=time_target), ctx=gl_ctx)
        r.step(8)
        images.append(r.film().mean)
        r.release()
    assert np.array_equal(images[0], images[1])


def test03_checkpoint_resume_bitwise(gl_ctx):
    from glrender.render.renderer import Renderer, settings_from_scene
    scene = cornell(32)
    settings = settings_from_scene(scene, integrator="lighttrace", spp=16, seed=7, samples_per_pass=4)
    whole = Renderer(scene, settings, ctx=gl_ctx)
    whole.step(16)
    first = Renderer(scene, settings, ctx=gl_ctx)
    first.step(8)
    state = first.state()
    second = Renderer(scene, settings, ctx=gl_ctx)
    second.restore(state)
    second.step(8)
    assert np.array_equal(whole.film().mean, second.film().mean)
    assert whole.film().mean.sum() > 0
    for r in (whole, first, second):
        r.release()
