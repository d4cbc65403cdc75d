"""Image comparisons: calibrated on synthetic renders with a known answer, and powerful."""
import numpy as np
import pytest

from glrender.testing.images import compare_images
from glrender.testing.stats import student_t_quantile, student_t_sf

scipy_stats = pytest.importorskip("scipy.stats")


@pytest.mark.parametrize("t, dof", [(2.0, 3), (5.2, 6), (0.5, 48), (-1.3, 10), (4.0, 1000)])
def test01_student_t_matches_scipy(t, dof):
    assert student_t_sf(t, dof) == pytest.approx(scipy_stats.t.sf(t, dof), rel=1e-9)
    p = 1 - scipy_stats.t.sf(abs(t), dof)
    assert student_t_quantile(p, dof) == pytest.approx(abs(t), rel=1e-7)


def synthetic(rng, k=4, shape=(32, 32, 3), bias=0.0, skew=False):
    truth = np.linspace(0.1, 2.0, np.prod(shape)).reshape(shape)
    noise = rng.exponential(1.0, (k,) + shape) - 1.0 if skew else rng.standard_normal((k,) + shape)
    return truth * (1 + bias) + 0.05 * truth * noise, truth


def test02_correct_renders_pass_at_the_family_rate():
    """200 independent trials of unbiased (normal and skewed) renders: alpha = 0.01 means
    about 2 failures expected; more than 8 is a miscalibration (binomial tail < 1e-3)."""
    rng = np.random.default_rng(0)
    failures = 0
    for trial in range(200):
        imgs, truth = synthetic(rng, skew=trial % 2 == 1)
        mask = np.ones(truth.shape[:2], bool)
        mask[5:11, 3:7] = False  # partly masked blocks get Student-t thresholds
        failures += not compare_images(imgs, truth, block=4, mask=mask).passed
    assert failures <= 8


def test03_a_small_bias_is_rejected():
    rng = np.random.default_rng(1)
    imgs, truth = synthetic(rng, bias=0.005)
    c = compare_images(imgs, truth, block=4)
    assert c.detectable_bias < 0.0025  # the test states its power (a bias of half of 0.5%) ...
    assert not c.passed                 # ... and has it at twice that
    imgs, truth = synthetic(rng)
    assert compare_images(imgs, truth, block=4).passed


def test04_a_local_error_is_rejected():
    rng = np.random.default_rng(2)
    imgs, truth = synthetic(rng)
    imgs[:, 8:12, 8:12, 1] *= 1.05  # one 4x4 block, one channel, 5% off
    c = compare_images(imgs, truth, block=4)
    assert not c.passed and c.worst_block == (2, 2, 1)


def splats(rng, k=8, size=32, events=20_000, spread=9):
    """k renders in which each of `events` light paths adds one exponential value to `spread`
    random pixels (all channels): pixels correlated within a render, as splatting makes them."""
    pixels = rng.integers(0, size * size, (k, events, spread))
    values = np.broadcast_to(rng.exponential(1.0, (k, events, 1)), pixels.shape)
    imgs = np.stack([np.bincount(p.ravel(), v.ravel(), size * size) for p, v in zip(pixels, values)])
    imgs = np.repeat(imgs.reshape(k, size, size, 1), 3, axis=-1)
    return imgs, np.full((size, size, 3), events * spread / (size * size))


def test05_correlated_pixels_take_the_mean_sigma_from_the_renders():
    """Splat-like renders: the per-pixel variances understate the image mean's 3x here, so
    the plain image-mean test fails correct renders far beyond alpha; `correlated_pixels`
    takes its sigma from the renders' own means and passes at the family rate (200 trials,
    more than 8 failures is a miscalibration; measured 53 and 4) while a bias of twice the
    detectable one (4%) still fails the image-mean test."""
    rng = np.random.default_rng(3)
    plain = corrected = 0
    for _ in range(200):
        imgs, truth = splats(rng)
        plain += not compare_images(imgs, truth, block=4).passed
        corrected += not compare_images(imgs, truth, block=4, correlated_pixels=True).passed
    assert corrected <= 8 < 20 < plain, (corrected, plain)
    imgs, truth = splats(rng)
    c = compare_images(imgs * 1.04, truth, block=4, correlated_pixels=True)
    assert c.detectable_bias < 0.022 and any(m.startswith("image mean") for m in c.messages), c.summary()


def merges(rng, k=8, size=32, events=4_000, reach=3):
    """k renders in which each of `events` light vertices adds one exponential value to the
    (2 reach + 1)^2 pixels around a random one (wrapping around the edges): neighbouring
    pixels correlated within a render, as density estimation over a radius makes them."""
    offsets = np.arange(-reach, reach + 1)
    imgs = np.zeros((k, size, size))
    for img in imgs:
        centres = rng.integers(0, size, (events, 2))
        values = rng.exponential(1.0, events)
        ys = (centres[:, 0, None, None] + offsets[None, :, None]) % size
        xs = (centres[:, 1, None, None] + offsets[None, None, :]) % size
        np.add.at(img, (ys, xs), np.broadcast_to(values[:, None, None], ys.shape))
    imgs = np.repeat(imgs[..., None], 3, axis=-1)
    truth = np.full((size, size, 3), events * (2 * reach + 1) ** 2 / (size * size))
    return imgs, truth


def test06_correlated_blocks_take_each_block_sigma_from_the_renders():
    """Merge-like renders (each event spread over 7x7 pixels): pooled per-pixel variances
    understate an 8x8 block mean's, so the plain block test fails correct renders far beyond
    alpha; `correlated_blocks` takes each block's sigma from the renders' own block means and
    passes at the family rate (200 trials, more than 8 failures is a miscalibration), while
    one block 40% off still fails, at that block (its Student-t threshold with 7 degrees of
    freedom sees about 20% there: the few light vertices per block make these blocks
    noisy)."""
    rng = np.random.default_rng(5)
    plain = corrected = 0
    for _ in range(200):
        imgs, truth = merges(rng)
        plain += not compare_images(imgs, truth, block=8, check_mse=False).passed
        corrected += not compare_images(imgs, truth, block=8, correlated_blocks=True).passed
    assert corrected <= 8 < 20 < plain, (corrected, plain)
    imgs, truth = merges(rng)
    imgs[:, 8:16, 16:24, 2] *= 1.4
    c = compare_images(imgs, truth, block=8, correlated_blocks=True)
    assert not c.passed and c.worst_block == (1, 2, 2), c.summary()
