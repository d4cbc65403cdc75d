"""Display transforms: linear radiance -> 8-bit images.

The pipeline is exposure (in stops), a tone curve, then the sRGB transfer function
(IEC 61966-2-1) or none (linear 8-bit). Curves:

- ``clamp``: values above 1 are clipped (the default; the image as rendered).
- ``filmic``: John Hable's Uncharted 2 curve (GDC 2010, "Uncharted 2: HDR Lighting"),
  with his exposure bias 2 and white point W = 11.2, so radiance 5.6 maps to white.
- ``aces``: Stephen Hill's fit of the ACES RRT + sRGB ODT (BakingLab, ACES.hlsl): input
  and output matrices around a rational fit; input is linear sRGB, output linear sRGB.
"""
from __future__ import annotations

import numpy as np

from ..errors import UsageError

TONE_CURVES = ("clamp", "filmic", "aces")

# Hable's parameters: shoulder strength, linear strength, linear angle, toe strength,
# toe numerator, toe denominator; white point and exposure bias
_HABLE = dict(a=0.15, b=0.50, c=0.10, d=0.20, e=0.02, f=0.30)
_HABLE_WHITE = 11.2
_HABLE_BIAS = 2.0

# Hill's ACES fit: sRGB -> (AP1 rotated) and back, row-vector convention (x @ M.T)
_ACES_IN = np.array([[0.59719, 0.35458, 0.04823],
                     [0.07600, 0.90834, 0.01566],
                     [0.02840, 0.13383, 0.83777]])
_ACES_OUT = np.array([[1.60475, -0.53108, -0.07367],
                      [-0.10208, 1.10813, -0.00605],
                      [-0.00327, -0.07276, 1.07602]])


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function on [0, 1] (inputs are clipped to it)."""
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """Inverse of :func:`linear_to_srgb` on [0, 1]."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def _hable_partial(x: np.ndarray) -> np.ndarray:
    a, b, c, d, e, f = (_HABLE[k] for k in "abcdef")
    return (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f


def filmic(x: np.ndarray) -> np.ndarray:
    """Hable's filmic curve: 0 -> 0, W / bias -> 1, monotonic, saturating."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    return _hable_partial(_HABLE_BIAS * x) / _hable_partial(np.float64(_HABLE_WHITE))


def aces(rgb: np.ndarray) -> np.ndarray:
    """Hill's ACES fit on linear sRGB triples (..., 3); output in [0, 1] linear sRGB."""
    v = np.maximum(np.asarray(rgb, np.float64), 0.0) @ _ACES_IN.T
    v = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)
    return np.clip(v @ _ACES_OUT.T, 0.0, 1.0)


def tone_curve(rgb: np.ndarray, curve: str = "clamp") -> np.ndarray:
    """Apply a tone curve to linear RGB (..., 3): the result is display-linear in [0, 1]."""
    if curve == "clamp":
        return np.clip(np.asarray(rgb, np.float64), 0.0, 1.0)
    if curve == "filmic":
        return np.clip(filmic(rgb), 0.0, 1.0)
    if curve == "aces":
        return aces(rgb)
    raise UsageError(f"tone curve {curve!r}: expected one of {', '.join(TONE_CURVES)}")


def tonemap(image: np.ndarray, exposure: float = 0.0, curve: str = "clamp",
            srgb: bool = True) -> np.ndarray:
    """Linear RGB (H, W, 3) -> 8-bit RGB: exposure in stops, tone curve, sRGB encoding
    (or linear 8-bit with ``srgb=False``). NaN becomes 0, +inf the curve's white."""
    rgb = np.nan_to_num(np.asarray(image, np.float64)[..., :3], nan=0.0, posinf=1e30, neginf=0.0)
    display = tone_curve(rgb * (2.0 ** float(exposure)), curve)
    if srgb:
        display = linear_to_srgb(display)
    return np.round(display * 255.0).astype(np.uint8)
