"""Display transforms: known values of the sRGB curve and the tone curves."""
from __future__ import annotations

import numpy as np
import pytest

from glrender.film.tonemap import aces, filmic, linear_to_srgb, srgb_to_linear, tonemap

EPS = 1e-12   # float64 arithmetic


def test01_srgb_known_values():
    # IEC 61966-2-1: the linear toe below 0.0031308, 0.5 linear -> 0.735357
    np.testing.assert_allclose(linear_to_srgb([0.0, 0.002, 0.5, 1.0, 2.0]),
                               [0.0, 0.02584, 0.7353569830524495, 1.0, 1.0], rtol=1e-12, atol=1e-15)
    x = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=1e-12)


def test02_filmic_fixed_points():
    """Hable's curve: 0 -> 0, the white point W / bias = 5.6 -> 1, monotonic in between."""
    assert filmic(0.0) == pytest.approx(0.0, abs=EPS)
    assert filmic(5.6) == pytest.approx(1.0, abs=EPS)
    y = filmic(np.linspace(0, 5.6, 1000))
    assert (np.diff(y) > 0).all()
    # Hable's own table value: f(2 * 0.18) / f(11.2) for middle grey
    a, b, c, d, e, f = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30
    h = lambda x: (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f
    assert filmic(0.18) == pytest.approx(h(0.36) / h(11.2), rel=1e-12)


def test03_aces_fit():
    """Hill's fit: black stays black, grey stays grey (the matrices keep white's rows
    summing to ~1), large values saturate at 1, and the curve rises."""
    assert np.allclose(aces(np.zeros(3)), 0.0)
    grey = aces(np.full(3, 0.18))
    assert np.ptp(grey) < 2e-3 and 0.1 < grey[0] < 0.2
    assert np.allclose(aces(np.full(3, 1e4)), 1.0, atol=2e-3)
    ramp = aces(np.linspace(0, 10, 200)[:, None].repeat(3, 1))[:, 0]
    assert (np.diff(ramp) >= 0).all()


def test04_tonemap_exposure_and_encoding():
    img = np.array([[[0.25, 0.5, 1.0], [np.nan, np.inf, -1.0]]], np.float32)
    out = tonemap(img, exposure=1.0, srgb=False)     # x 2, clamp, linear 8-bit
    np.testing.assert_array_equal(out, [[[128, 255, 255], [0, 255, 0]]])
    out = tonemap(img)
    np.testing.assert_array_equal(out[0, 0], np.round(linear_to_srgb([0.25, 0.5, 1.0]) * 255))
    assert out.dtype == np.uint8
    assert tonemap(img, curve="filmic")[0, 1].tolist() == [0, 255, 0]   # per channel
    assert tonemap(img, curve="aces")[0, 1].tolist() == [255, 255, 255]  # mixes channels


def test05_unknown_curve():
    from glrender import UsageError

    with pytest.raises(UsageError, match="tone curve"):
        tonemap(np.zeros((1, 1, 3)), curve="reinhard")
