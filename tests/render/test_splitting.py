"""The path tracer's Russian roulette rules and splitting: exact ray counts, unbiased on a
scene with an exact answer, bounded work per invocation."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError, UsageError
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.testing.stats import sidak_t

from render_scenes import enclosure

ROOT = Path(__file__).resolve().parents[2]


def render(scene, spp=4, seed=3, **options):
    r = Renderer(scene, settings_from_scene(scene, spp=spp, seed=seed, sampler="independent",
                                            **options))
    r.step(spp)
    film = r.film()
    rays = r.rays() if r.settings.count_rays else None
    r.release()
    return film, rays


@pytest.mark.parametrize("split", [1, 3])
def test01_ray_counts_are_exact(gl_ctx, split):
    """In a closed diffuse enclosure, BSDF sampling alone (no shadow rays) without roulette
    traces exactly max_depth rays per sample; n branches at the first vertex trace
    1 + n (max_depth - 1)."""
    depth, spp = 6, 4
    scene = enclosure(width=16, height=16)
    _, rays = render(scene, spp=spp, count_rays=True, strategy="bsdf", rr="off", max_depth=depth,
                     split=split)
    assert rays == 16 * 16 * spp * (1 + split * (depth - 1))


def test02_counting_rays_leaves_the_image_alone_and_roulette_saves_rays(gl_ctx):
    scene = enclosure(width=16, height=16)
    plain, _ = render(scene, max_depth=16)
    counted, rays = render(scene, max_depth=16, count_rays=True)
    np.testing.assert_array_equal(plain.mean, counted.mean)
    again, rays_again = render(scene, max_depth=16, count_rays=True)
    assert rays_again == rays                       # deterministic: a pure function of the seed
    _, rays_off = render(scene, max_depth=16, count_rays=True, rr="off")
    assert rays < 0.5 * rays_off


SETTINGS = [dict(rr="off"), dict(rr_depth=1), dict(rr="fixed:0.5", rr_depth=1),
            dict(rr="fixed:0.8"), dict(light_samples=3), dict(split=3),
            dict(split=2, light_samples=2, rr="fixed:0.7", rr_depth=2),
            dict(split=2, strategy="light"), dict(light_samples=2, strategy="mis-balance")]


def test03_every_rule_and_split_is_unbiased(gl_ctx):
    """The enclosure's radiance with max_depth D segments is sum_{k<D} 0.5^k = 2 (1 - 0.5^D)
    in every pixel: each setting's image mean from independent seeds agrees with it
    (Student t, Šidák over the settings)."""
    depth, seeds = 12, 8
    exact = 2.0 * (1.0 - 0.5 ** depth)
    scene = enclosure(width=16, height=16)
    t_max = sidak_t(0.01, len(SETTINGS), seeds - 1)
    for options in SETTINGS:
        means = np.array([render(scene, spp=8, seed=s, max_depth=depth, **options)[0].mean.mean()
                          for s in range(seeds)])
        se = means.std(ddof=1) / np.sqrt(seeds)
        assert se > 0
        assert abs(means.mean() - exact) <= t_max * se, (options, means.mean(), se)


@pytest.mark.parametrize("which, split, light_samples", [("bunny", 4, 16), ("furnace", 16, 4)])
def test04_largest_splitting_stays_far_below_the_loop_cap(gl_ctx, which, split, light_samples):
    """The largest work per sample (split x light samples = 64) without roulette at
    unbounded depth: the renderer renders one sample per invocation, and its worst SIMD
    vector stays below 30,000 loop iterations (llvmpipe's cap: 65,535; the count is the
    vector's, common/loop_counter.glsl) on the bunny (69k triangles) and on a furnace of
    albedo 0.99 (every path runs to the 256-segment cap)."""
    if which == "bunny":
        scene = glrender.load(ROOT / "scenes" / "cornell-bunny" / "scene.toml")
        scene.film.width, scene.film.height = 32, 32
    else:
        scene = enclosure(albedo=0.99, width=8, height=8)
    r = Renderer(scene, settings_from_scene(scene, spp=2, seed=3, count_loops=True, max_depth=-1,
                                            rr="off", split=split, light_samples=light_samples))
    assert r.samples_per_pass == 1
    r.step(2)
    counts = r.film().loop_counts
    r.release()
    assert counts.max() > 256
    assert counts.max() < 30_000


def test05_bad_settings_name_the_field(gl_ctx):
    scene = enclosure(width=8, height=8)
    for options, field in ((dict(rr="fixed:0"), "integrator.rr"), (dict(rr="always"), "integrator.rr"),
                           (dict(split=0), "integrator.split"),
                           (dict(light_samples=17), "integrator.light_samples"),
                           (dict(split=16, light_samples=8),
                            r"integrator.split x integrator.light_samples: at most 64 .*got 16 x 8")):
        with pytest.raises(SceneError, match=field):
            settings_from_scene(scene, **options)
    with pytest.raises(UsageError, match="count_rays"):
        r = Renderer(scene, settings_from_scene(scene, spp=1))
        try:
            r.rays()
        finally:
            r.release()


@pytest.mark.parametrize("args, message", [
    (["--rr", "fixed:1.5"], "--rr fixed:1.5: expected throughput, off or fixed:<q> with q in (0, 1]"),
    (["--split", "0"], "--split 0: expected an integer in 1..16"),
    (["--light-samples", "99"], "--light-samples 99: expected an integer in 1..16"),
    (["--rr-depth", "0"], "--rr-depth 0: expected a number of path segments >= 1")])
def test06_bad_options_are_one_line_errors(tmp_path, capsys, args, message):
    from glrender.commands.cli import main

    scene = ROOT / "scenes" / "cornell-box" / "scene.toml"
    assert main(["render", str(scene), "-o", str(tmp_path / "x.png"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"glrender: error: {message}"
