"""Participating media as every loader reads them (docs/scene-format.md, "Participating
media"): the ranges of a medium's values, checked the same way whatever the format; the
native format's ``sigma_a`` / ``sigma_s`` form; glTF's KHR_materials_volume rule.

The SceneErrors say only why; the caller names the file, its line or field.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import SceneError
from .. import model as m
from .diagnostics import excerpt

MEDIUM_KINDS = ("homogeneous", "heterogeneous")
PHASES = ("isotropic", "hg")
HG_DEFAULT_G = 0.8                  # Mitsuba's hg
# what each value may hold: sigma_t an extinction coefficient, albedo a ratio sigma_s / sigma_t
_RANGES = {"sigma_t": (0.0, math.inf, "finite non-negative numbers"),
           "albedo": (0.0, 1.0, "numbers in [0, 1]")}


def check_value(value: m.MediumValue, role: str) -> m.MediumValue:
    """``value`` (an RGB triple or a :class:`~glrender.scene.model.Volume`) as the medium
    field ``role`` (``sigma_t`` or ``albedo``) may hold it: a grid of 1 or 3 channels,
    finite, sigma_t >= 0, albedo in [0, 1]; SceneError otherwise."""
    lo, hi, expected = _RANGES[role]
    if isinstance(value, m.Volume):
        data = value.data
        if data.shape[-1] not in (1, 3):
            raise SceneError(f"a grid of {data.shape[-1]} channels: {role} takes 1 (grey) or 3 (RGB)")
        if not np.all(np.isfinite(data)):
            raise SceneError("the grid holds NaN or infinite values")
        low, high = float(data.min()), float(data.max())
        if low < lo or high > hi:
            raise SceneError(f"the grid's values lie in [{low:g}, {high:g}]: {role} takes "
                             f"{expected}")
        return value
    r, g, b = (float(v) for v in value)
    rgb = (r, g, b)
    if not all(math.isfinite(v) and lo <= v <= hi for v in rgb):
        raise SceneError(f"expected {expected}, got {excerpt(list(rgb))}")
    return rgb


def check_scale(scale: float) -> float:
    """A medium's ``scale`` (sigma_t's factor): finite, >= 0."""
    if not (math.isfinite(scale) and scale >= 0):
        raise SceneError(f"expected a finite number >= 0, got {scale:g}")
    return scale


def check_g(g: float) -> float:
    """The Henyey-Greenstein mean cosine: in (-1, 1), as Mitsuba's hg requires."""
    if not -1.0 < g < 1.0:
        raise SceneError(f"expected a mean cosine in (-1, 1), got {g:g}")
    return g


def absorption_scattering(sigma_a: m.RGB, sigma_s: m.RGB) -> tuple[m.RGB, m.RGB]:
    """(sigma_t, albedo) of absorption and scattering coefficients, per channel:
    sigma_t = sigma_a + sigma_s, albedo = sigma_s / sigma_t (0 where sigma_t is 0)."""
    r, g, b = (a + s for a, s in zip(sigma_a, sigma_s))
    sigma_t = (r, g, b)
    r, g, b = (s / t if t > 0 else 0.0 for s, t in zip(sigma_s, sigma_t))
    return sigma_t, (r, g, b)


# the smallest positive float32: a channel of attenuationColor 0 absorbs completely, to within
# a transmittance of 1e-38 over the attenuation distance
_MIN_ATTENUATION = float(np.finfo(np.float32).tiny)


def attenuation_medium(color: m.RGB, distance: float, name: str = "") -> m.Medium:
    """glTF's KHR_materials_volume: light crossing ``distance`` keeps ``color`` of itself
    (Beer-Lambert), so the interior absorbs with sigma_a = -ln(color) / distance per channel
    and does not scatter: a homogeneous medium of sigma_t = sigma_a and albedo 0. An
    infinite distance (glTF's default) absorbs nothing."""
    r, g, b = (max(0.0, -math.log(max(c, _MIN_ATTENUATION)) / distance) for c in color)
    return m.Medium("homogeneous", sigma_t=(r, g, b), albedo=(0.0, 0.0, 0.0), name=name)
