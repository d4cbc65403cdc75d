"""Films whose accumulation exceeds one storage-buffer binding are rendered in slices of tile
rows, each bound at its offset: the image is bitwise the one rendered in a single binding."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.render.accumulation import AOV_BYTES, SUM_BYTES
from glrender.render.renderer import Renderer, settings_from_scene

CORNELL = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"


def cornell(width, height):
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=width, height=height)
    return scene


@pytest.mark.parametrize("aovs, count_loops", [(False, False), (True, True)])
def test01_slices_equal_one_binding(gl_ctx, monkeypatch, aovs, count_loops):
    scene = cornell(52, 45)              # 7 x 6 tiles, odd sizes: a short last slice
    settings = settings_from_scene(scene, spp=8, seed=3, aovs=aovs, count_loops=count_loops)
    with Renderer(scene, settings, ctx=gl_ctx) as whole:
        assert len(whole.slices()) == 1
        whole.step(4)
        whole.step(4)
        expected = whole.film()
    # a binding of 2 tile rows of the widest buffer: 3 slices
    widest = AOV_BYTES if aovs else SUM_BYTES
    monkeypatch.setattr(Renderer, "binding_limit", lambda self: 2 * 8 * 52 * widest)
    with Renderer(scene, settings, ctx=gl_ctx) as sliced:
        slices = sliced.slices()
        assert len(slices) == 3 and sum(n for _, n in slices) == 6
        sliced.step(4)
        sliced.step(4, should_stop=lambda: False)
        got = sliced.film()
    np.testing.assert_array_equal(got.mean, expected.mean)
    np.testing.assert_array_equal(got.m2, expected.m2)
    np.testing.assert_array_equal(got.count, expected.count)
    for name in expected.aovs:
        np.testing.assert_array_equal(got.aovs[name], expected.aovs[name])
    if count_loops:
        np.testing.assert_array_equal(got.loop_counts, expected.loop_counts)


def test02_stopped_pass_is_undone_across_slices(gl_ctx, monkeypatch):
    scene = cornell(40, 40)
    settings = settings_from_scene(scene, spp=8, seed=1, samples_per_pass=4, time_target=1e-9)
    monkeypatch.setattr(Renderer, "binding_limit", lambda self: 2 * 8 * 40 * SUM_BYTES)
    with Renderer(scene, settings, ctx=gl_ctx) as r:
        assert len(r.slices()) == 3
        r.step(4)
        before = r.film()
        asked = 0

        def stop():
            nonlocal asked
            asked += 1
            return asked > 18          # in the second slice of the second pass
        assert r.step(4, should_stop=stop) == 0
        after = r.film()
    np.testing.assert_array_equal(after.mean, before.mean)
    np.testing.assert_array_equal(after.count, before.count)


@pytest.mark.slow
def test03_dci_4k_film(gl_ctx):
    """4096 x 2160 (8.8M pixels, 566 MB of per-pixel sums, above llvmpipe's 128 MiB
    binding) at 1 spp: rows across the slice boundary equal a crop rendered in one binding."""
    scene = cornell(4096, 2160)
    settings = settings_from_scene(scene, spp=1, seed=9)
    with Renderer(scene, settings, ctx=gl_ctx) as r:
        slices = r.slices()
        assert len(slices) >= 2
        r.step(1)
        full = r.film()
    boundary = 8 * slices[1][0]                          # first pixel row of the second slice
    with Renderer(scene, settings, ctx=gl_ctx) as r:
        r.reset(rows=(boundary // 8 - 2, 4))             # 4 tile rows around the boundary
        assert len(r.slices()) == 1
        r.step(1)
        band = r.film()
    np.testing.assert_array_equal(band.mean, full.mean[boundary - 16:boundary + 16])
    assert full.mean[boundary:].max() > 0.5 and full.mean.mean() > 0.05
