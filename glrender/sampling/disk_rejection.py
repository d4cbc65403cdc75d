"""The unit disk by bounded rejection from the square: numpy twin of ``shaders/sampling/disk_rejection.glsl``."""
from __future__ import annotations

import numpy as np

from .disk import sample_uniform_disk_concentric

DISK_REJECTION_MAX_TRIALS = 64


def sample_uniform_disk_rejection(u_trials) -> tuple[np.ndarray, np.ndarray]:
    """Uniform points of the unit disk by rejection.

    ``u_trials``: uniforms of shape (N, T, 2), trial t of sample i in ``u_trials[i, t]``
    (T <= 64 trials are used, as in GLSL). Returns the points (N, 2) and the number of
    trials drawn per sample (N,); a sample whose T trials all miss takes the concentric
    map of its last candidate, as the GLSL fallback does.
    """
    u = np.asarray(u_trials, np.float64)
    u = u[:, :DISK_REJECTION_MAX_TRIALS]
    p = 2.0 * u - 1.0
    inside = np.sum(p * p, axis=2) <= 1.0
    hit = inside.any(axis=1)
    first = np.where(hit, np.argmax(inside, axis=1), u.shape[1] - 1)
    rows = np.arange(len(u))
    points = p[rows, first]
    fallback = sample_uniform_disk_concentric(u[rows, first])
    points = np.where(hit[:, None], points, fallback)
    return points, first + 1
