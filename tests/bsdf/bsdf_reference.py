"""float64 references for the BSDF tests: the Fresnel equations and float32 conditioning."""
from __future__ import annotations

import numpy as np

EPS = 2.0 ** -24  # float32 unit roundoff


def fresnel_reference(cos_theta, n):
    """F for light arriving at |cos_theta| from the side where the relative IOR is n
    (complex for conductors): r_s = (c - r) / (c + r), r_p = (n^2 c - r) / (n^2 c + r),
    r = sqrt(n^2 - sin^2) on the principal branch (the refracted wave decays)."""
    c = np.abs(np.asarray(cos_theta, np.float64))
    n = np.asarray(n, np.complex128)
    root = np.sqrt(n * n - (1.0 - c * c))
    r_s = (c - root) / (c + root)
    r_p = (n * n * c - root) / (n * n * c + root)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


def fresnel_conditioning(cos_theta, eta):
    """How much float32 rounding grows in a factor 1 - F(cos_theta): F carries an
    absolute error ~eps (1 + 1 / cos_t) (test_fresnel.py), relative to 1 - F."""
    c = np.abs(cos_theta)
    cos_t = np.sqrt(np.abs(1 - (1 - c * c) / (eta * eta)))
    with np.errstate(divide="ignore"):
        return (1 + 1 / np.maximum(cos_t, 1e-3)) / np.maximum(1 - fresnel_reference(c, eta), 1e-6)
