"""The renderer's band of tile rows and start sample index (Renderer.reset(start, rows)):
the pieces a distributed render is made of."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.distributed.merge import FrameImage, from_state, merge, merge_tree
from glrender.distributed.plan import Plan
from glrender.errors import UsageError
from glrender.render import accum
from glrender.render.renderer import Renderer, settings_from_scene

ROOT = Path(__file__).resolve().parents[2]
EPS32 = float(np.finfo(np.float32).eps)


@pytest.fixture(scope="module")
def scene():
    s = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    s.film.width, s.film.height = 40, 44     # 5 x 6 tiles, the last row 4 pixels high
    return s


@pytest.fixture(scope="module")
def renderer(gl_ctx, scene):
    r = Renderer(scene, settings_from_scene(scene, spp=8, seed=3, samples_per_pass=4,
                                            aovs=True))
    yield r
    r.release()


def test01_bands_are_the_full_image_rows_bitwise(renderer):
    r = renderer
    r.reset()
    r.step(8)
    full = r.film()
    for rows in [(0, 2), (2, 3), (5, 1), (0, 6)]:
        r.reset(rows=rows)
        r.step(8)
        band = r.film()
        y0, y1 = 8 * rows[0], min(44, 8 * sum(rows))
        assert band.mean.shape == (y1 - y0, 40, 3)
        for name in ("mean", "m2", "count", "nonfinite"):
            np.testing.assert_array_equal(getattr(band, name), getattr(full, name)[y0:y1], name)
        for name in ("albedo", "normal", "depth"):
            np.testing.assert_array_equal(band.aovs[name], full.aovs[name][y0:y1], name)
    r.reset()


def test02_sample_ranges_add_up_to_the_full_render_bitwise(renderer):
    """Eight one-sample units (start = 0..7) merged along the plan's tree, and the same
    samples split 3 + 5, hold the bits of the full render's accumulation (exact
    fixed-point sums), AOVs included; the units rendered different samples."""
    r = renderer
    r.reset()
    r.step(8)
    full, full_state = r.film(), r.state()

    def unit(start, count):
        r.reset(start=start, rows=(0, 6))
        assert r.spp_done == start
        assert r.step(count) == count
        return from_state(r.state(), 40 * 44, True, (start, start + count))

    leaves = [unit(i, 1) for i in range(8)]
    # the device converts as accum.fixed: a one-sample unit's sums are its sample's words
    for p in leaves[:2]:
        x = accum.statistics(p.sums, p.squares)[0]                 # the samples themselves
        np.testing.assert_array_equal(p.sums[:, :3], accum.fixed(x))
        np.testing.assert_array_equal(p.squares, accum.fixed(x * x))
    x = np.stack([accum.statistics(p.sums, p.squares)[0] for p in leaves])    # (8, N, 3)
    lit = x.max(axis=0) > 0
    assert np.mean(np.ptp(x, axis=0)[lit] > 0) > 0.9     # the units rendered different samples
    # a single sample's M2 is the rounding of its float32 square (2^-24 x^2), of the
    # square's fixed point (2^-49) and of the float64 statistics
    for p, xi in zip(leaves, x):
        bound = (2.0 ** -24 + 2.0 ** -50) * xi.astype(np.float64) ** 2 + 2.0 ** -48
        assert (accum.statistics(p.sums, p.squares)[1] <= bound).all()
    tree = Plan(512, 44, 8, 512 * 8, samples_per_pass=1).merge_tree()   # 8 ranges of 1
    assert tree == (((0, 1), (2, 3)), ((4, 5), (6, 7)))
    for merged in (merge_tree(tree, leaves), merge(unit(0, 3), unit(3, 5))):
        assert merged.samples == (0, 8)
        np.testing.assert_array_equal(merged.sums.ravel(), full_state["sums"])
        np.testing.assert_array_equal(merged.squares.ravel(), full_state["squares"])
        np.testing.assert_array_equal(merged.aov.ravel(), full_state["aov"])
        image = FrameImage(40, 44, aovs=True)
        image.place(0, 0, merged)
        film = image.film(8, "sobol")
        for name in ("mean", "m2", "count", "nonfinite"):
            np.testing.assert_array_equal(getattr(film, name), getattr(full, name), name)
        for name in ("albedo", "normal", "depth"):
            np.testing.assert_array_equal(film.aovs[name], full.aovs[name], name)
    # the sums are the samples' mean and M2 (to float32 rounding of the statistics)
    mean = x.astype(np.float64).mean(axis=0)
    scale = np.abs(x).max(axis=0) + 1e-30
    assert (np.abs(full.mean.reshape(-1, 3) - mean) <= 4 * EPS32 * scale).all()
    r.reset()


def test03_bad_bands_and_starts_are_refused(renderer):
    r = renderer
    for kw in [dict(rows=(6, 1)), dict(rows=(0, 7)), dict(rows=(2, 0)), dict(start=-1),
               dict(start=1 << 31)]:
        with pytest.raises(UsageError):
            r.reset(**kw)
    r.reset(rows=(1, 2))
    st = r.state()
    r.reset(rows=(0, 2))
    with pytest.raises(UsageError, match="tile rows"):
        r.restore(st)
    r.reset(rows=(1, 2))
    r.restore(st)
    r.reset()


def test04_splat_image_counts_the_samples_since_start(gl_ctx, scene):
    """Light tracing: the splatted image of samples [8, 16) is normalized by its own 8
    samples (not by 16 from index 0), so the two halves average to the full render's."""
    settings = settings_from_scene(scene, spp=16, seed=3, integrator="lighttrace", max_depth=3)
    with Renderer(scene, settings) as r:
        r.step(16)
        full = r.splat_image().astype(np.float64)
        halves = []
        for start in (0, 8):
            r.reset(start=start)
            r.step(8)
            halves.append(r.splat_image().astype(np.float64))
    assert full.max() > 0
    eps = float(np.finfo(np.float32).eps)
    np.testing.assert_allclose((halves[0] + halves[1]) / 2, full, rtol=4 * eps, atol=1e-30)
