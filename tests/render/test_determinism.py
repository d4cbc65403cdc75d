"""The same (scene, seed, spp) gives the same image, bitwise, however the work is split."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.render.renderer import Renderer, settings_from_scene

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def small_cornell():
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film.width, scene.film.height = 72, 56   # not a multiple of the 8x8 tiles
    return scene


def film_of(scene, *, passes, time_target, sampler="sobol", seed=7, spp=8, steps=None):
    settings = settings_from_scene(scene, spp=spp, seed=seed, sampler=sampler,
                                   samples_per_pass=passes, time_target=time_target)
    r = Renderer(scene, settings)
    for k in steps or [spp]:
        r.step(k)
    f = r.film()
    r.release()
    return f


@pytest.mark.parametrize("sampler", ["independent", "stratified", "sobol"])
def test01_bitwise_the_same_however_split(gl_ctx, small_cornell, sampler):
    a = film_of(small_cornell, passes=4, time_target=100.0, sampler=sampler)    # 1 dispatch per pass
    b = film_of(small_cornell, passes=1, time_target=1e-9, sampler=sampler)     # 1 tile per dispatch
    c = film_of(small_cornell, passes=3, time_target=0.05, sampler=sampler, steps=[1, 5, 2])
    for other in (b, c):
        np.testing.assert_array_equal(a.mean, other.mean)
        np.testing.assert_array_equal(a.m2, other.m2)
        np.testing.assert_array_equal(a.count, other.count)
    assert a.spp == 8 and (a.count == 8).all()


def test02_seeds_differ_and_repeat(gl_ctx, small_cornell):
    a = film_of(small_cornell, passes=4, time_target=0.1, seed=1)
    b = film_of(small_cornell, passes=4, time_target=0.1, seed=1)
    c = film_of(small_cornell, passes=4, time_target=0.1, seed=2)
    np.testing.assert_array_equal(a.mean, b.mean)
    lit = a.mean > 0  # the background outside the box is black for every seed
    assert np.mean(a.mean[lit] != c.mean[lit]) > 0.9


@pytest.mark.parametrize("which", ["furnace", "bunny", "caustic"])
def test03_loop_counts_stay_far_below_the_cap(gl_ctx, which):
    """llvmpipe stops an invocation silently after ~65,535 loop iterations: the debug
    counter's worst invocation (one pass of the default samples per pass) must stay below
    30,000 on the worst scenes: a long-path furnace (albedo 0.99, unbounded depth), the
    bunny (69k triangles) and the glass sphere, both with unbounded depth."""
    from render_scenes import enclosure

    if which == "furnace":
        scene = enclosure(albedo=0.99, max_depth=-1, width=16, height=16)
    else:
        scene = glrender.load(ROOT / "scenes" / ("cornell-bunny" if which == "bunny" else "caustic") /
                              "scene.toml")
        scene.film.width, scene.film.height = 48, 48
    settings = settings_from_scene(scene, spp=16, seed=3, count_loops=True, max_depth=-1)
    r = Renderer(scene, settings)
    r.step(16)
    counts = r.film().loop_counts
    r.release()
    assert counts.max() > 8           # the counter works: paths bounce, rays traverse
    assert counts.max() < 30_000


def test04_state_and_restore_continue_bitwise(gl_ctx, small_cornell):
    """Stopping, saving the accumulation and continuing in a new renderer gives the image of
    an uninterrupted render, bitwise; another seed's state is refused."""
    whole = film_of(small_cornell, passes=4, time_target=0.1, seed=5, spp=12)
    settings = settings_from_scene(small_cornell, spp=12, seed=5, sampler="sobol", samples_per_pass=4)
    first = Renderer(small_cornell, settings)
    first.step(5)
    state = first.state()
    first.release()
    second = Renderer(small_cornell, settings)
    second.restore(state)
    second.step(7)
    f = second.film()
    np.testing.assert_array_equal(f.mean, whole.mean)
    np.testing.assert_array_equal(f.m2, whole.m2)
    assert f.spp == 12
    other = Renderer(small_cornell, settings_from_scene(small_cornell, spp=12, seed=6, sampler="sobol"))
    with pytest.raises(glrender.UsageError, match="different scene or different render settings"):
        other.restore(state)


def test05_a_state_continues_to_more_samples(gl_ctx, small_cornell):
    """Independent and Sobol' samples do not depend on the total spp: a render of 6 spp
    continued to 10 equals a render of 10 (the stratified sampler's strata do depend on it)."""
    whole = film_of(small_cornell, passes=4, time_target=0.1, seed=5, spp=10)
    first = Renderer(small_cornell, settings_from_scene(small_cornell, spp=6, seed=5, sampler="sobol",
                                                        samples_per_pass=4))
    first.step(6)
    state = first.state()
    second = Renderer(small_cornell, settings_from_scene(small_cornell, spp=10, seed=5, sampler="sobol",
                                                         samples_per_pass=4))
    second.restore(state)
    second.step(4)
    np.testing.assert_array_equal(second.film().mean, whole.mean)
    strat = Renderer(small_cornell, settings_from_scene(small_cornell, spp=6, seed=5, sampler="stratified"))
    other = Renderer(small_cornell, settings_from_scene(small_cornell, spp=10, seed=5, sampler="stratified"))
    assert strat.fingerprint() != other.fingerprint()
