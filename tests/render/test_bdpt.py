"""Bidirectional path tracing against the path tracer (and the enclosure's closed form),
per 16x16 block (4x4 on the small analytic scenes) at a Šidák-corrected alpha of 0.01
over every block, channel and scene of this file (glrender.testing.images, sigma from
four independent seeds of each integrator), under both MIS heuristics; and the same
seed gives the same image bitwise however a pass is split into dispatches (integer
fixed-point splats for the t = 1 strategies). Lights at infinity: an image environment
(importance sampled, seen directly and through the scene) and a directional light.
"""
import numpy as np
import pytest

from glrender.render.renderer import Renderer, settings_from_scene
from glrender.testing.images import compare_images

from bidir_scenes import (camera_haze, caustic, closed_enclosure, cornell, directional, environment,
                          fog_glossy, glossy, smoke_grid,
                          path_reference, point_light, renders, slab_enclosure, thin_lens,
                          use_generic_weights)

SEEDS_PATH, SEEDS_BDPT = (11, 12, 13, 14), (31, 32, 33, 34)
# name: (scene, block, path spp, bdpt spp)
SCENES = {
    "cornell": (cornell, 16, 64, 16),
    "glossy": (glossy, 16, 64, 16),
    "thin-lens": (thin_lens, 16, 64, 16),
    "point-light": (point_light, 4, 16, 16),
    "enclosure": (closed_enclosure, 4, 16, 8),
    # facing walls 0.1 apart, 2 from the origin: connections between them (their shadow rays
    # once met the far wall: 1.0% dark)
    "slab": (slab_enclosure, 4, 16, 8),
    "caustic": (caustic, 8, 256, 64),
    "environment": (environment, 8, 64, 16),
    "directional": (directional, 8, 64, 16),
}
CASES = [(name, "mis-power") for name in SCENES] + [("cornell", "mis-balance")]


def block_tests(scene, block):
    f = scene.film
    return 3 * -(-f.width // block) * -(-f.height // block) + 2


@pytest.fixture(scope="module")
def all_tests():
    return sum(block_tests(SCENES[name][0](), SCENES[name][1]) for name, _ in CASES)


@pytest.mark.slow
@pytest.mark.parametrize("name, heuristic", CASES)
def test01_bdpt_matches_path(gl_ctx, all_tests, name, heuristic):
    make, block, spp_path, spp_bdpt = SCENES[name]
    scene = make()
    extra = all_tests - block_tests(scene, block)
    bd = renders(scene, "bdpt", spp_bdpt, SEEDS_BDPT, strategy=heuristic)
    if name in ("enclosure", "slab"):
        # closed form: L = Le / (1 - albedo) = 2 (bdpt stops at 16 segments: 2 (1 - 2^-16);
        # tests/render/test_depth_cap.py counts the subpaths its cap cuts)
        ref, ref_se = np.full(bd.shape[1:], 2.0), None
    else:
        ref, ref_se = path_reference(scene, spp_path, SEEDS_PATH)
    c = compare_images(bd, ref, ref_se, block=block, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < (0.04 if name == "caustic" else 0.02), c.summary()


@pytest.mark.slow
def test05_cornell_box_matches_mitsuba(gl_ctx):
    """The full-size Cornell box against Mitsuba 3's reference (tests/data/refs, 49,152 spp),
    as tests/render/test_cornell.py holds the path tracer to it: every block and channel,
    the image mean and the MSE at Šidák alpha 0.01, the reference's own error included."""
    import glrender
    from bidir_scenes import ROOT
    refs = ROOT / "tests" / "data" / "refs"
    ref, ref_se = np.load(refs / "cornell-box-ref.npy"), np.load(refs / "cornell-box-ref-stderr.npy")
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    imgs = np.stack([glrender.render(scene, spp=8, seed=seed, integrator="bdpt", progress=False).mean
                     for seed in (41, 42, 43, 44)])
    c = compare_images(imgs, ref, ref_se, block=16)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.005, c.summary()


def test02_one_dispatch_or_many_bitwise(gl_ctx):
    scene = cornell(16)
    images = []
    for time_target in (1e-9, 10.0):   # one tile per dispatch vs the whole image in one
        r = Renderer(scene, settings_from_scene(scene, integrator="bdpt", spp=4, seed=5,
                                                time_target=time_target), ctx=gl_ctx)
        r.step(4)
        images.append(r.film().mean)
        r.release()
    assert np.array_equal(images[0], images[1]) and images[0].sum() > 0


@pytest.mark.parametrize("make", [caustic, closed_enclosure])
def test03_loop_counts_far_below_the_cap(gl_ctx, make):
    """The worst invocation of a pass: the caustic scene (BVH, glass) at max depth 8, and
    the enclosure at unbounded depth (bdpt's cap of 16 segments)."""
    scene = make(16)
    r = Renderer(scene, settings_from_scene(scene, integrator="bdpt", spp=8, seed=3, count_loops=True),
                 ctx=gl_ctx)
    r.step(8)
    worst = int(r.film().loop_counts.max())
    r.release()
    assert 0 < worst < 30_000, worst



@pytest.mark.parametrize("make", [glossy, caustic, environment, fog_glossy, smoke_grid, camera_haze])
def test06_connection_densities_are_the_fresh_ones(gl_ctx, monkeypatch, make):
    """The strategies take the MIS densities of the connection from their own BSDF (and
    phase function) evaluations (no second material lookup): the image is bitwise the one
    whose weights evaluate every density afresh (GLRENDER_BDPT_GENERIC_WEIGHTS); with media,
    the media's MIS transmittance is the connection's walk's in both."""
    scene = make(16)
    images = []
    for generic in (False, True):
        if generic:
            use_generic_weights(monkeypatch)
        r = Renderer(scene, settings_from_scene(scene, integrator="bdpt", spp=4, seed=8), ctx=gl_ctx)
        r.step(4)
        images.append(r.film().mean)
        assert ("GLRENDER_BDPT_GENERIC_WEIGHTS" in r.defines) == generic
        r.release()
    assert np.array_equal(images[0], images[1]) and images[0].max() > 0
