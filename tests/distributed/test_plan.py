"""Units and the merge tree: pure functions of (image size, spp, unit size, frames)."""
import numpy as np
import pytest

from glrender.distributed.merge import FrameImage, Partial, merge, merge_tree
from glrender.distributed.plan import Plan, calibrated_unit_size, tree_ranges


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


def test05_chan_merge_matches_float64_statistics():
    """Merging partials of random sample sets gives their pooled mean and M2 (float64)."""
    rng = np.random.default_rng(5)
    sizes = [3, 5, 8, 1, 7]
    xs = [rng.normal(2.0, 3.0, size=(n, 10, 3)) for n in sizes]
    leaves, start = [], 0
    for x in xs:
        n = len(x)
        mean = np.concatenate([x.mean(0), np.full((10, 1), n)], axis=1)
        m2 = np.concatenate([((x - x.mean(0)) ** 2).sum(0), np.zeros((10, 1))], axis=1)
        leaves.append(Partial(mean, m2, None, (start, start + n)))
        start += n
    plan_tree = ((0, 1), (2, (3, 4)))
    got = merge_tree(plan_tree, leaves)
    allx = np.concatenate(xs)
    np.testing.assert_allclose(got.mean[:, :3], allx.mean(0), rtol=1e-13)
    np.testing.assert_allclose(got.m2[:, :3], ((allx - allx.mean(0)) ** 2).sum(0), rtol=1e-12)
    assert (got.mean[:, 3] == len(allx)).all() and got.samples == (0, len(allx))
    with pytest.raises(ValueError, match="adjacent"):
        merge(leaves[0], leaves[2])


def test06_frame_image_places_bands():
    img = FrameImage(4, 12, aovs=False)
    for band, (first, h) in enumerate([(0, 8), (1, 4)]):
        mean = np.full((4 * h, 4), band + 1.0)
        img.place(band, first, Partial(mean, np.zeros((4 * h, 4)), None, (0, 1)))
    film = img.film(1, "sobol")
    assert (film.mean[:8] == 1).all() and (film.mean[8:] == 2).all() and film.spp == 1


def test07_default_unit_size():
    from glrender.distributed.plan import NOMINAL_UNIT_SIZE, default_unit_size

    # Cornell 256^2 at 64 spp: 32 units of one tile row each, every band at full spp
    size = default_unit_size(256, 256, 64)
    plan = Plan(256, 256, 64, size)
    assert size == 256 * 8 * 64 and len(plan.units()) == 32 and plan.ranges == ((0, 64),)
    # 4K at 64k spp: a tile row costs far more than a nominal unit: sample ranges
    size = default_unit_size(3840, 2160, 65536)
    assert size == NOMINAL_UNIT_SIZE and len(Plan(3840, 2160, 65536, size).ranges) > 1
    # small renders: at least the minimum; always a power of two or a tile row's cost
    assert default_unit_size(4, 4, 1) == 1 << 12
