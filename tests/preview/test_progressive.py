"""Frame-budgeted progressive rendering (glrender/preview/progressive.py), headless."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import glrender
from glrender.preview.progressive import Progressive
from glrender.render import accum
from glrender.render.renderer import Renderer, settings_from_scene

SCENE = "scenes/cornell-box/scene.toml"


def _scene(width, height):
    from pathlib import Path

    scene = glrender.load(Path(__file__).parents[2] / SCENE)
    scene.film = replace(scene.film, width=width, height=height)
    return scene


@pytest.fixture(scope="module")
def small(gl_ctx):
    """A 44x28 image (partial tiles at the right and bottom edges)."""
    scene = _scene(44, 28)
    return scene, settings_from_scene(scene, aovs=True)


def test01_same_image_as_whole_passes(gl_ctx, small):
    """Passes cut into single-tile dispatches over many frames give bitwise the image
    Renderer.step gives: each pixel sums its samples in index order either way."""
    scene, settings = small
    whole = Renderer(scene, settings, ctx=gl_ctx)
    cut = Renderer(scene, settings, ctx=gl_ctx)
    try:
        whole.step(21)
        p = Progressive(cut, target_spp=21)
        frames = 0
        while not p.done:
            p.advance(0.0)   # a zero budget: one dispatch per call
            frames += 1
        assert frames > 21 * p.tiles / 8   # passes of up to 8 spp, mostly one tile per call
        a, b = whole.film(), cut.film()
        assert b.spp == 21 and (b.count == 21).all()
        for x, y in ((a.mean, b.mean), (a.m2, b.m2), (a.aovs["albedo"], b.aovs["albedo"]),
                     (a.aovs["normal"], b.aovs["normal"])):
            np.testing.assert_array_equal(x, y)
        np.testing.assert_allclose(p.samples_added, 21 * 44 * 28)
    finally:
        whole.release()
        cut.release()


def test02_passes_ramp_up(gl_ctx, small):
    """1 spp first, then as many as the image has, up to samples_per_pass; between
    passes every pixel has the same count."""
    scene, settings = small
    r = Renderer(scene, settings, ctx=gl_ctx)
    try:
        p = Progressive(r, target_spp=30)
        seen = []
        while not p.done:
            p.advance(0.0)   # one dispatch per call
            if p.pass_samples == 0:
                seen.append(p.spp)
                assert (r.film().count == p.spp).all()
        assert seen[:6] == [1, 2, 4, 8, 16, 24] and seen[-1] == 30
        assert r.samples_per_pass == 8
        assert not p.advance(1.0)   # done: nothing more
        p.reset()
        assert p.spp == 0 and not p.done and (r.film().count == 0).all()
    finally:
        r.release()


def test03_budget_cuts_a_pass_and_finish_pass_completes_it(gl_ctx):
    """A pass much longer than the budget spreads over calls; finish_pass completes it
    (screenshots save whole passes)."""
    scene = _scene(256, 256)   # one 1-spp pass: tens of milliseconds on llvmpipe
    r = Renderer(scene, settings_from_scene(scene), ctx=gl_ctx)
    try:
        p = Progressive(r)
        p.advance(0.0)            # measures the rate on a few tiles
        p.advance(0.001)
        assert 0 < p.next_tile < p.tiles and p.pass_samples == 1 and p.spp == 0
        counts = r.film().count
        assert 0 < (counts == 1).mean() < 1 and counts.max() == 1
        p.finish_pass()
        assert p.spp == 1 and p.pass_samples == 0 and (r.film().count == 1).all()
    finally:
        r.release()


def test04_reset_mid_pass_starts_clean(gl_ctx, small):
    """The camera moves in the middle of a pass: what follows is exactly a fresh render
    of the new view (no tile of the old pass's parameters survives), and its first
    tiles are those the interrupted pass had not reached."""
    scene, settings = small
    scene = replace(scene)   # a copy: its camera changes below
    moved = replace(scene.camera, world_from_camera=scene.camera.world_from_camera.copy())
    moved.world_from_camera[:3, 3] += (0.3, -0.2, 0.5)
    r = Renderer(scene, settings, ctx=gl_ctx)
    fresh = Renderer(replace(scene, camera=moved), settings, ctx=gl_ctx)
    try:
        p = Progressive(r, target_spp=5)
        for _ in range(30):   # a few passes, stopping inside one
            p.advance(0.0)
        assert 0 < p.next_tile
        reached = r.film().count > p.spp
        r.scene.camera = moved
        p.reset()
        p.advance(0.0)
        assert p.origin > 0 and not (reached & (r.film().count > 0)).any()
        while not p.done:
            p.advance(0.0)
        fresh.step(5)
        np.testing.assert_array_equal(r.film().mean, fresh.film().mean)
    finally:
        r.release()
        fresh.release()


def test05_sppm_iterations_spread_over_frames(gl_ctx):
    """SPPM in the preview (SppmProgressive): with a zero budget every call does one
    piece of work (a camera pass, or one photon dispatch), so an iteration of 3
    dispatches takes 4 calls; after 5 iterations the image is SppmRenderer.step(5)'s
    (deposits are float atomics: equal to their summation order), and the buffer the
    display reads holds it with the iteration count."""
    from glrender.photon import SppmRenderer, SppmSettings
    from glrender.photon.sppm import PHOTONS_PER_DISPATCH
    from glrender.preview.progressive import SppmProgressive

    scene = _scene(32, 24)
    sppm = SppmSettings(photons_per_iteration=2 * PHOTONS_PER_DISPATCH + 100)
    whole = SppmRenderer(scene, sppm=sppm, ctx=gl_ctx, seed=3)
    cut = SppmRenderer(scene, sppm=sppm, ctx=gl_ctx, seed=3)
    try:
        whole.step(5)
        p = SppmProgressive(cut, target_spp=5)
        calls = 0
        while not p.done:
            assert p.advance(0.0)
            calls += 1
        assert calls == 5 * 4 and p.spp == 5 and not p.advance(0.0)
        a, b = whole.radiance(), cut.radiance()
        np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-7)
        state = cut.base.state()
        shown, _, count, _, _ = accum.statistics(state["sums"], state["squares"])
        np.testing.assert_allclose(shown.reshape(24, 32, 3), b, rtol=1e-6, atol=1e-7)
        assert (count == 5).all() and b.mean() > 0.05
        assert p.samples_added == 5 * 32 * 24
        p.reset()
        assert p.spp == 0 and not cut.base.state()["sums"].any()
    finally:
        whole.release()
        cut.release()
