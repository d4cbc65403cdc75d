"""Vertex connection and merging (glrender.vcm): against the path tracer and the closed form
per block, its bpt mode bitwise bdpt, its consistency on the caustic scene, and the
properties every integrator keeps (one dispatch or many, a seed's determinism, resume, the
loop cap, bounded storage).

Error bars come from independent seeds only (TESTING.md): a merge spreads a light vertex
over the pixels within its radius and a light path's connections over the film, so the
pixels of a render are correlated and each block's sigma is the spread of the seeds' own
block means (compare_images correlated_blocks, Student t with seeds - 1 degrees of freedom).
"""
import math

import numpy as np
import pytest

import glrender
from glrender.drivers import create_driver
from glrender.errors import UsageError
from glrender.render.renderer import settings_from_scene
from glrender.scene import model as m
from glrender.testing.images import compare_images
from glrender.vcm import VcmSettings, vcm as vcm_module

from bidir_scenes import (caustic, closed_enclosure, cornell, cornell_motion, path_reference, renders,
                          thin_lens, use_generic_weights)

SEEDS = tuple(range(100, 116))
SEEDS_PATH = (11, 12, 13, 14)
# name: (scene, block, path spp, vcm iterations, vcm mode, VcmSettings of its own: light
# paths per iteration (default one per pixel, 1024 in these 32x32 images), connections to
# a light vertex cache)
SCENES = {
    "cornell": (cornell, 16, 256, 64, "vcm", {}),
    "enclosure": (closed_enclosure, 8, 0, 16, "vcm", {}),
    "thin-lens": (thin_lens, 16, 256, 64, "vcm", {}),
    "cornell-vm": (cornell, 16, 256, 64, "vm", {}),
    "cornell-paths-300": (cornell, 16, 256, 64, "vcm", {"light_paths": 300}),
    "cornell-paths-3000": (cornell, 16, 256, 64, "vcm", {"light_paths": 3000}),
    "cornell-cache": (cornell, 16, 256, 64, "vcm", {"cache_connections": 2}),
    "cornell-motion": (cornell_motion, 16, 256, 64, "vcm", {}),
    "enclosure-cache": (closed_enclosure, 8, 0, 16, "vcm", {"cache_connections": 1, "light_paths": 700}),
}


def default_radius(scene):
    """The default initial radius of vcm for ``scene`` (one pixel footprint)."""
    r = create_driver(scene, settings_from_scene(scene, integrator="vcm", spp=1), VcmSettings())
    radius = r.radius_1
    r.release()
    return radius


def vcm_renders(scene, iterations, seeds, mode="vcm", **options):
    return np.stack([glrender.render(scene, spp=iterations, integrator="vcm", seed=seed,
                                     sampler="independent", progress=False,
                                     integrator_options=VcmSettings(mode=mode, **options)).mean
                     for seed in seeds])


def block_tests(scene, block):
    f = scene.film
    return 3 * -(-f.width // block) * -(-f.height // block) + 2


@pytest.fixture(scope="module")
def all_tests():
    return sum(block_tests(SCENES[name][0](32), SCENES[name][1]) for name in SCENES)


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test01_vcm_matches_path_and_closed_form(gl_ctx, all_tests, name):
    """32x32 images, 16 seeds, alpha 0.75 and r_1 a quarter of the default (a quarter
    pixel footprint here: in scene units the default radius of a 128x128 render), whose
    bias after 64 iterations (16 in the enclosure) is below what the tests can see (at the
    default radius of 32x32, four times larger, the Cornell box's corners were 1-2% dark:
    a density estimate's disk reaches past the walls there). Each block and channel and
    the image mean at a Šidák alpha of 0.01 over all of this file's comparisons; the
    image-mean test detects a bias of 2.2% on the Cornell box (1.7% merges alone), 2.0% with
    the thin lens and 0.27% in the enclosure, whose radiance is Le / (1 - albedo) = 2
    everywhere (2 (1 - 2^-16) at the 16-segment cap)."""
    make, block, spp_path, iterations, mode, options = SCENES[name]
    scene = make(32)
    extra = all_tests - block_tests(scene, block)
    v = vcm_renders(scene, iterations, SEEDS, mode, initial_radius=default_radius(scene) / 4,
                    **options)
    if make is closed_enclosure:
        ref, ref_se = np.full(v.shape[1:], 2.0), None
    else:
        ref, ref_se = path_reference(scene, spp_path, SEEDS_PATH)
    c = compare_images(v, ref, ref_se, block=block, extra_tests=extra, correlated_blocks=True)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < (0.005 if make is closed_enclosure else 0.025), c.summary()


@pytest.mark.parametrize("make", [cornell, caustic])
def test02_bpt_mode_is_bdpt_bitwise(gl_ctx, make):
    """--vcm-mode bpt runs bdpt's kernel: the same image, bit for bit."""
    scene = make(16)
    images = []
    for integrator, options in (("bdpt", None), ("vcm", VcmSettings(mode="bpt"))):
        r = create_driver(scene, settings_from_scene(scene, integrator=integrator, spp=4, seed=9),
                          options, ctx=gl_ctx)
        r.step(4)
        images.append(r.film().mean)
        r.release()
    assert np.array_equal(images[0], images[1]) and images[0].max() > 0


def vcm_image(gl_ctx, scene, spp, options=None, **settings):
    r = create_driver(scene, settings_from_scene(scene, integrator="vcm", spp=spp, seed=5,
                                                 **settings), options or VcmSettings(), ctx=gl_ctx)
    r.step(spp)
    film = r.film()
    stats = r.stats()
    r.release()
    return film, stats


@pytest.mark.parametrize("options", [{"mode": "vcm"}, {"mode": "vm"}, {"cache_connections": 2}],
                         ids=["vcm", "vm", "cache"])
def test03_one_dispatch_or_many_and_the_seed_bitwise(gl_ctx, options):
    """The merge grid is sorted by light path and vertex, merges sum in that order, the
    light vertex cache lists the vertices by light path and vertex, and splats sum in
    integers: the image does not depend on how a pass is dispatched, nor on the order in
    which the light pass's atomics stored the vertices."""
    scene = caustic(16)
    a = vcm_image(gl_ctx, scene, 3, VcmSettings(**options), time_target=1e-9)[0].mean
    b = vcm_image(gl_ctx, scene, 3, VcmSettings(**options), time_target=10.0)[0].mean
    c = vcm_image(gl_ctx, scene, 3, VcmSettings(**options), time_target=10.0)[0].mean
    assert np.array_equal(a, b) and np.array_equal(b, c) and a.max() > 0


def test04_storage_grows_and_the_image_stays(gl_ctx, monkeypatch):
    """Buffers first sized for 1 vertex and 1 merge point per light path overflow; the light
    pass is traced again into larger ones (its lens splats not repeated) and the image is
    bitwise the one with room from the start. Stored bytes: 96 per vertex, 88 per merge
    point (its position and key, its data, its key and cell hash for the sorts)."""
    scene = caustic(16)
    roomy, stats = vcm_image(gl_ctx, scene, 2)
    assert stats["vcm"]["counters"]["retraced"] == 0
    assert stats["vcm"]["bytes_per_vertex"] == 96 and stats["vcm"]["bytes_per_merge_point"] == 88
    monkeypatch.setattr(vcm_module, "VERTICES_PER_PATH", 1)
    monkeypatch.setattr(vcm_module, "MERGES_PER_PATH", 1)
    tight, stats = vcm_image(gl_ctx, scene, 2)
    assert stats["vcm"]["counters"]["retraced"] >= 1
    assert np.array_equal(roomy.mean, tight.mean)


def test05_resume_continues_bitwise(gl_ctx):
    """An iteration's light paths and radius depend on its index and the seed alone: 3
    iterations, saved and restored in a new renderer, then 2 more, are the 5 of one run."""
    scene = caustic(16)
    settings = settings_from_scene(scene, integrator="vcm", spp=5, seed=2)
    whole = create_driver(scene, settings, VcmSettings(), ctx=gl_ctx)
    whole.step(5)
    want = whole.film().mean
    whole.release()
    first = create_driver(scene, settings, VcmSettings(), ctx=gl_ctx)
    first.step(3)
    state = first.state()
    first.release()
    second = create_driver(scene, settings, VcmSettings(), ctx=gl_ctx)
    second.restore(state)
    second.step(2)
    assert np.array_equal(second.film().mean, want)
    second.release()


@pytest.mark.parametrize("make", [caustic, closed_enclosure])
def test06_loop_counts_far_below_the_cap(gl_ctx, make):
    """The worst invocation of the camera pass (connections and up to 1,024 merge
    candidates per vertex): the caustic scene and the enclosure at bdpt's 16-segment cap."""
    film, _ = vcm_image(gl_ctx, make(16), 2, count_loops=True)
    worst = int(film.loop_counts.max())
    assert 0 < worst < 30_000, worst


def test07_refusals(gl_ctx):
    with pytest.raises(UsageError, match=r"vcm mode: expected one of vcm, vm, bpt"):
        VcmSettings(mode="both")
    with pytest.raises(UsageError, match=r"alpha: expected a number in \(0, 1\)"):
        VcmSettings(alpha=1.0)
    with pytest.raises(UsageError, match=r"initial radius: expected a positive number"):
        VcmSettings(initial_radius=0.0)
    with pytest.raises(UsageError, match=r"light vertex cache: expected an integer in \[0, 16\]"):
        VcmSettings(cache_connections=17)
    with pytest.raises(UsageError, match=r"light vertex cache: only in vcm mode 'vcm'"):
        VcmSettings(mode="vm", cache_connections=1)


@pytest.mark.slow
def test08_caustic_error_falls_with_iterations(gl_ctx):
    """Consistency: on the caustic scene (24x24), the MSE against a bdpt reference (8 seeds
    of 1024 spp), less the reference's own variance, over 2, 4, 8, 16 and 32 iterations of
    8 seeds each: the slope of log(MSE) against log(iterations), fitted over the 40
    renders, is below 0 by more than 3 standard errors of the fit."""
    scene = caustic(24)
    ref_renders = renders(scene, "bdpt", 1024, range(200, 208))
    ref = ref_renders.mean(axis=0)
    ref_var = float((ref_renders.var(axis=0, ddof=1) / len(ref_renders)).mean())
    xs, ys = [], []
    for n in (2, 4, 8, 16, 32):
        for img in vcm_renders(scene, n, range(300, 308)):
            mse = float(((img - ref) ** 2).mean()) - ref_var
            assert mse > 0, (n, mse)
            xs.append(math.log(n))
            ys.append(math.log(mse))
    x, y = np.array(xs), np.array(ys)
    slope, intercept = np.polyfit(x, y, 1)
    resid = y - (slope * x + intercept)
    se = math.sqrt(resid.var(ddof=2) / ((x - x.mean()) ** 2).sum())
    assert slope + 3 * se < 0, (slope, se)


@pytest.mark.parametrize("mode,cache", [("vcm", 0), ("vm", 0), ("vcm", 2)], ids=["vcm", "vm", "cache"])
def test09_strategy_images_with_merges_partition_the_render(gl_ctx, mode, cache):
    """At strategy depth = max depth (3) the weighted images of the connections (splats
    included; with a light vertex cache, on the Cornell box, each connection under its own
    s) and of the merges add up to the film: the camera side to float32 summation order (a
    bound from the sample and strategy counts), the splats exactly (the same fixed-point
    integers). The merges' unweighted images are at least their weighted part, and the
    merges carry light (the caustic's: the glass's L S D E paths)."""
    from glrender.render import strategies

    scene = (cornell if cache else caustic)(16)   # the Cornell box's (2, 2) connections carry light
    spp, depth = 4, 3
    r = create_driver(scene, settings_from_scene(scene, integrator="vcm", spp=spp, seed=4,
                                                 max_depth=depth, strategy_depth=depth),
                      VcmSettings(mode=mode, cache_connections=cache), ctx=gl_ctx)
    r.step(spp)
    film, splat = r.film(), r.splat_image()
    images, merges = r.strategy_images(), r.merge_strategy_images()
    r.release()
    assert set(merges) == set(strategies.merges(depth)) == {(1, 2), (1, 3), (2, 2)}
    camera = sum(w for (s, t), (w, u) in images.items() if t >= 2) + sum(w for w, u in merges.values())
    magnitude = sum(np.abs(w) for (s, t), (w, u) in images.items() if t >= 2) + \
        sum(np.abs(w) for w, u in merges.values())
    bound = 4 * (spp + len(images) + len(merges)) * 2.0 ** -24 * (magnitude + np.abs(film.mean))
    err = np.abs(camera - (film.mean - splat))
    assert np.all(err <= bound + 1e-7), float((err - bound).max())
    assert all(np.all(u >= w - 1e-6) for w, u in merges.values())
    assert sum(w.sum() for w, u in merges.values()) > 0
    if cache:   # the cache's connections, under their own strategy
        assert images[(2, 2)][0].sum() > 0
    if mode == "vm":   # merges alone: no connection but s = 0 carries light
        assert all(w.max() == 0 for (s, t), (w, u) in images.items() if s > 0)


@pytest.mark.parametrize("make", [caustic, cornell])
def test10_connection_densities_are_the_fresh_ones(gl_ctx, monkeypatch, make):
    """As bdpt's (tests/render/test_bdpt.py test06): the connections, next-event estimation
    and lens splats of vcm weigh with the densities of their own BSDF evaluations, merges
    and the lens connections' light-path factor included: the image is bitwise the one
    whose connection weights evaluate every density afresh (GLRENDER_BDPT_GENERIC_WEIGHTS),
    at 0.7 light paths a pixel."""
    scene = make(16)
    images = []
    for generic in (False, True):
        if generic:
            use_generic_weights(monkeypatch)
        film, _ = vcm_image(gl_ctx, scene, 3, VcmSettings(light_paths=180))
        images.append(film.mean)
    assert np.array_equal(images[0], images[1]) and images[0].max() > 0


def test11_params_block_is_the_host_layout(gl_ctx):
    """glrender/vcm/layout.py VCM_PARAMS is integrators/vcm_layout.glsl's std140 block: a
    kernel copies every member of a block the host wrote back, word for word."""
    from glrender.gl import shaders
    from glrender.gpu.bindings import UBO_VCM_PARAMS
    from glrender.vcm import layout as vl

    source = """#version 450
layout(local_size_x = 1) in;
#include "integrators/vcm_layout.glsl"
layout(std430, binding = 8) buffer Out { uvec4 words[]; };
void main() {
    words[0] = u_vcm.paths;
    words[1] = u_vcm.grid_size;
    words[2] = floatBitsToUint(u_vcm.grid_lo);
    words[3] = floatBitsToUint(u_vcm.merge);
    words[4] = floatBitsToUint(u_vcm.lens);
    words[5] = u_vcm.cache;
}
"""
    kernel = shaders.compile_compute(gl_ctx, source=source, name="<vcm params test>")
    block = np.zeros(1, vl.VCM_PARAMS)[0]
    block["paths"] = (1, 2, 3, 4)
    block["grid_size"] = (5, 6, 7, 8)
    block["grid_lo"] = (0.5, 1.5, 2.5, 3.5)
    block["merge"] = (4.5, 5.5, 6.5, 7.5)
    block["lens"] = (8.5, 9.5, 10.5, 11.5)
    block["cache"] = (12, 13, 14, 15)
    gl = gl_ctx.gl
    params, out = gl.buffer(block.tobytes()), gl.buffer(reserve=16 * 6)
    params.bind_to_uniform_block(UBO_VCM_PARAMS)
    out.bind_to_storage_buffer(8)
    kernel.run(group_x=1)
    assert out.read() == block.tobytes()
    params.release()
    out.release()


def test12_motion_takes_one_time_per_iteration(gl_ctx):
    """In a scene with motion every path of an iteration takes the iteration's shutter time
    (merges join light vertices of one time): the radical inverse of the iteration index,
    rotated by the seed. A render with motion is deterministic and compiles the shared time
    only where something moves."""
    times = [vcm_module.iteration_time(i, 7) for i in range(8)]
    assert all(0.0 <= t < 1.0 for t in times)
    # the first 2^k iterations hold one time in each of 2^k equal parts of [0, 1)
    assert sorted(int(t * 8) for t in times) == list(range(8))
    assert vcm_module.iteration_time(3, 7) != vcm_module.iteration_time(3, 8)
    scene = cornell_motion(16)
    r = create_driver(scene, settings_from_scene(scene, integrator="vcm", spp=2, seed=5),
                      VcmSettings(), ctx=gl_ctx)
    assert r.shared_time and r.defines.get("GLRENDER_SHARED_TIME") == 1
    r.step(2)
    a = r.film().mean
    r.release()
    b = vcm_image(gl_ctx, scene, 2)[0].mean
    still = create_driver(cornell(16), settings_from_scene(cornell(16), integrator="vcm", spp=1),
                          VcmSettings(), ctx=gl_ctx)
    assert not still.shared_time
    still.release()
    assert np.array_equal(a, b) and a.max() > 0 and np.isfinite(a).all()
