"""The renderer's band of tile rows and start sample index (Renderer.reset(start, rows)):
the pieces a distributed render is made of."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.distributed.merge import Partial, merge_tree
from glrender.distributed.plan import Plan
from glrender.errors import UsageError
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


def test02_start_renders_the_later_samples(renderer):
    """Eight one-sample units (start = 0..7) hold each pixel's samples exactly (a
    one-sample Welford mean is the sample): merged along the plan's tree in float64 they
    are the samples' float64 mean and M2 to float64 rounding, and the full render's
    float32 Welford accumulation is within its own rounding bound of them."""
    r = renderer
    r.reset()
    r.step(8)
    full = r.film()
    leaves = []
    for i in range(8):
        r.reset(start=i, rows=(0, 6))
        assert r.spp_done == i
        assert r.step(1) == 1
        st = r.state()
        leaves.append(Partial(st["mean"].reshape(-1, 4), st["m2"].reshape(-1, 4), None, (i, i + 1)))
    r.reset()
    x = np.stack([p.mean[:, :3].astype(np.float64) for p in leaves])          # (8, N, 3)
    assert all((p.m2[:, :3] == 0).all() and (p.mean[:, 3] == 1).all() for p in leaves)
    lit = x.max(axis=0) > 0
    assert np.mean(np.ptp(x, axis=0)[lit] > 0) > 0.9     # the units rendered different samples
    tree = Plan(512, 44, 8, 512 * 8, samples_per_pass=1).merge_tree()   # 8 ranges of 1
    assert tree == (((0, 1), (2, 3)), ((4, 5), (6, 7)))
    merged = merge_tree(tree, leaves)
    assert merged.samples == (0, 8) and (merged.mean[:, 3] == 8).all()
    mean = x.mean(axis=0)
    m2 = ((x - mean) ** 2).sum(axis=0)
    scale = np.abs(x).max(axis=0)
    np.testing.assert_array_less(np.abs(merged.mean[:, :3] - mean), 1e-14 * scale + 1e-300)
    np.testing.assert_array_less(np.abs(merged.m2[:, :3] - m2), 1e-13 * scale ** 2 + 1e-300)
    # float32 Welford: each of the 8 updates rounds the mean by at most ~3 eps max|x|
    full_mean = full.mean.reshape(-1, 3).astype(np.float64)
    assert (np.abs(full_mean - mean) <= 8 * 3 * EPS32 * scale).all()


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
