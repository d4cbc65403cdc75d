"""Sample clamping (off by default): a sample's largest RGB component is scaled down to the
clamp, so no pixel mean exceeds it; a clamp above every sample changes nothing, bitwise."""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.errors import UsageError
from render_scenes import cornell_box


@pytest.fixture(scope="module")
def scene():
    return cornell_box(32, 32)


def test01_clamp_bounds_every_sample(gl_ctx, scene):
    free = glrender.render(scene, spp=16, seed=3)
    clamped = glrender.render(scene, spp=16, seed=3, clamp=0.25)
    assert free.mean.max() > 1.0                       # the light is far brighter than 0.25
    assert clamped.mean.max() <= 0.25 * (1 + 1e-6)
    # the same samples (same seed), each scaled down or kept: no pixel gets brighter
    assert np.all(clamped.mean <= free.mean * (1 + 1e-5) + 1e-7)
    assert (clamped.mean < free.mean * 0.99).any()


def test02_clamp_above_every_sample_is_bitwise_neutral(gl_ctx, scene):
    free = glrender.render(scene, spp=8, seed=5)
    high = glrender.render(scene, spp=8, seed=5, clamp=1e30)
    np.testing.assert_array_equal(free.mean, high.mean)
    np.testing.assert_array_equal(free.m2, high.m2)


@pytest.mark.parametrize("value", [0, -1.0, float("inf"), float("nan"), "high"])
def test03_bad_clamp_is_refused(scene, value):
    with pytest.raises(UsageError, match=r"clamp: expected a positive number"):
        glrender.render(scene, spp=1, clamp=value)
