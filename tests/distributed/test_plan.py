"""Units and the merge tree: pure functions of (image size, spp, unit size, frames)."""
import numpy as np
import pytest

from glrender.distributed.merge import FrameImage, Partial, merge, merge_tree
from glrender.distributed.plan import Plan, calibrated_unit_size, tree_ranges
from glrender.render import accum


@pytest.mark.parametrize("w,h,spp,size", [(72, 56, 16, 1 << 12), (72, 56, 16, 72 * 8 * 16 * 3),
                                          (3840, 2160, 65536, 1 << 24), (5, 3, 1, 1 << 12),
                                          (100, 100, 1000, 100 * 8 * 8 * 5)])
def test01_units_cover_every_pixel_sample_once(w, h, spp, size):
    plan = Plan(w, h, spp, size, frames=(0, 1))
    rows = [r for first, count in plan.bands for r in range(first, first + count)]
    assert rows == list(range(plan.tile_rows))
    starts = [a for a, _ in plan.ranges]
    assert plan.ranges[0][0] == 0 and plan.ranges[-1][1] == spp
    assert all(a[1] == b[0] for a, b in zip(plan.ranges, plan.ranges[1:]))
    assert all(s % plan.samples_per_pass == 0 for s in starts)   # ranges start at passes
    units = plan.units()
    assert len(units) == len(set(u.name for u in units)) == plan.record()["units"]
    assert sum(plan.unit_pixel_samples(u) for u in units) == plan.pixel_samples
    if len(plan.ranges) > 1:
        assert all(plan.unit_pixel_samples(u) <= max(size, w * 8 * 8) for u in units)
    # the tree holds every range once, in order
    tree = plan.merge_tree()
    assert tree_ranges(tree) == (0, len(plan.ranges) - 1)
    flat = []

    def walk(t):
        if isinstance(t, int):
            flat.append(t)
        else:
            walk(t[0]), walk(t[1])
    walk(tree)
    assert flat == list(range(len(plan.ranges)))


def test02_a_band_at_full_spp_when_a_tile_row_fits():
    plan = Plan(72, 56, 16, 72 * 8 * 16 * 3)
    assert plan.ranges == ((0, 16),)
    assert plan.bands == ((0, 3), (3, 3), (6, 1))
    assert plan.band_height(2) == 8
    plan = Plan(72, 52, 16, 72 * 8 * 16 * 3)
    assert plan.band_height(2) == 4
    # and the same plan whatever else: equal inputs, equal units
    assert Plan(72, 56, 16, 1 << 12).units() == Plan(72, 56, 16, 1 << 12).units()


def test03_bad_plans_are_refused():
    with pytest.raises(ValueError):
        Plan(72, 56, 16, 100)
    with pytest.raises(ValueError):
        Plan(72, 56, 0, 1 << 20)


def test04_calibrated_unit_size_is_a_power_of_two():
    assert calibrated_unit_size(3e6, 1.0) == 1 << 22      # 3e6 -> 2^21.5 rounds up
    assert calibrated_unit_size(1.0, 1.0) == 1 << 12
    assert calibrated_unit_size(3.5e6, 1.0) == calibrated_unit_size(4.5e6, 1.0) == 1 << 22


def _partial(x, start):
    """A partial of samples x (n, pixels, 3) float32, as the device sums them."""
    words = accum.fixed(x)                                   # (n, pixels, 3, 4)
    sums = np.zeros((x.shape[1], 4, 4), np.uint32)
    squares = np.zeros((x.shape[1], 3, 4), np.uint32)
    for w, w2 in zip(words, accum.fixed(x * x)):
        sums[:, :3] = accum.add(sums[:, :3], w)
        squares = accum.add(squares, w2)
    sums[:, 3, 0] = len(x)
    return Partial(sums, squares, None, (start, start + len(x)))


def test05_merges_are_exact_in_any_grouping():
    """Partials of random float32 sample sets (a wide range of magnitudes and signs)
    merged along different trees hold the same bits, the exact integer sums of the
    samples' fixed-point values, and their statistics are the pooled mean and M2."""
    rng = np.random.default_rng(5)
    sizes = [3, 5, 8, 1, 7]
    xs = [(rng.normal(0.5, 3.0, size=(n, 10, 3)) * 10.0 ** rng.integers(-6, 7, size=(n, 10, 3))
           ).astype(np.float32) for n in sizes]
    leaves, start = [], 0
    for x in xs:
        leaves.append(_partial(x, start))
        start += len(x)
    a = merge_tree(((0, 1), (2, (3, 4))), leaves)
    b = merge_tree((((0, 1), 2), (3, 4)), leaves)
    c = merge(merge(merge(merge(leaves[0], leaves[1]), leaves[2]), leaves[3]), leaves[4])
    allx = np.concatenate(xs)
    d = _partial(allx, 0)
    for got in (a, b, c):
        np.testing.assert_array_equal(got.sums, d.sums)
        np.testing.assert_array_equal(got.squares, d.squares)
        assert got.samples == (0, len(allx))
    # the words are the exact sums of the samples' values in units of 2^-48
    exact = [sum(int(round(float(v) * 2 ** accum.FRACTION)) for v in allx[:, 4, 1])]
    words = [int(w) << (32 * k) for k, w in enumerate(a.sums[4, 1])]
    assert (sum(words) - (1 << 128 if sum(words) >> 127 else 0)) == exact[0]
    mean, m2, count, dropped, _ = accum.statistics(a.sums, a.squares)
    x64 = allx.astype(np.float64)
    np.testing.assert_allclose(mean, x64.mean(0), rtol=1e-6, atol=1e-14)
    np.testing.assert_allclose(m2, ((x64 - x64.mean(0)) ** 2).sum(0), rtol=1e-5)
    assert (count == len(allx)).all() and (dropped == 0).all()
    with pytest.raises(ValueError, match="adjacent"):
        merge(leaves[0], leaves[2])


def test06_frame_image_places_bands():
    img = FrameImage(4, 12, aovs=False)
    for band, (first, h) in enumerate([(0, 8), (1, 4)]):
        img.place(band, first, _partial(np.full((1, 4 * h, 3), band + 1.0, np.float32), 0))
    film = img.film(1, "sobol")
    assert (film.mean[:8] == 1).all() and (film.mean[8:] == 2).all() and film.spp == 1


def test07_default_unit_size():
    from glrender.distributed.plan import NOMINAL_UNIT_SIZE, default_unit_size

    # Cornell 256^2 at 64 spp: about 1/32 of the render per unit, a power of two
    size = default_unit_size(256, 256, 64)
    assert size == 1 << 17 and len(Plan(256, 256, 64, size).units()) == 32
    # 4K at 64k spp: the calibrated (here: nominal) size, sample ranges
    size = default_unit_size(3840, 2160, 65536)
    assert size == NOMINAL_UNIT_SIZE and len(Plan(3840, 2160, 65536, size).ranges) > 1
    assert default_unit_size(3840, 2160, 65536, largest=1 << 20) == 1 << 20
    # small renders: at least the minimum
    assert default_unit_size(4, 4, 1) == 1 << 12


def test08_distributed_checkpoints_keep_sums_and_refuse_other_versions(tmp_path, monkeypatch):
    from glrender.errors import UsageError
    from glrender.render import checkpoint

    part = _partial(np.arange(24, dtype=np.float32).reshape(2, 4, 3), 0)
    path = tmp_path / "c.ckpt"
    checkpoint.save_band_checkpoint(path, {"job": "j", "plan": {"unit_size": 4096}},
                                    {(None, 0): part})
    (got,) = checkpoint.load_band_checkpoint(path, "j", Partial).values()
    np.testing.assert_array_equal(got.sums, part.sums)
    np.testing.assert_array_equal(got.squares, part.squares)
    assert checkpoint.band_checkpoint_unit_size(path) == 4096
    monkeypatch.setattr(checkpoint, "BAND_VERSION", 1)
    checkpoint.save_band_checkpoint(path, {"job": "j"}, {(None, 0): part})
    monkeypatch.setattr(checkpoint, "BAND_VERSION", 2)
    for read in (lambda: checkpoint.load_band_checkpoint(path, "j", Partial),
                 lambda: checkpoint.band_checkpoint_unit_size(path)):
        with pytest.raises(UsageError, match="version 1, this glrender reads version 2"):
            read()
