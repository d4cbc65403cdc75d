"""Error and efficiency of two renders of one scene against a reference (``glrender compare``).

MSE is the mean over pixels and channels of (image − ref)²; relative MSE divides each
term by ref² + 0.01 (the usual guard for dark pixels). The efficiency ratio of B over A
is (MSE_A · t_A) / (MSE_B · t_B): > 1 means B reaches a given error sooner. The per-block
map uses the mean squared error of each block (``block`` × ``block`` pixels), since a
single pixel's squared error is too noisy to compare. The reference's own noise adds to
both MSEs: use a reference with far more samples than A and B.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import UsageError

REL_EPS = 0.01


def _rgb(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image, np.float64)
    if image.ndim == 2:
        image = image[..., None]
    return image[..., :3]


def block_mean(x: np.ndarray, block: int) -> np.ndarray:
    """Mean over block × block tiles (partial tiles at the edges are dropped)."""
    h, w = x.shape[0] // block * block, x.shape[1] // block * block
    if h == 0 or w == 0:
        raise UsageError(f"--block {block}: larger than the image ({x.shape[1]}x{x.shape[0]})")
    x = x[:h, :w]
    return x.reshape(h // block, block, w // block, block, *x.shape[2:]).mean(axis=(1, 3))


def compare_images(a: np.ndarray, b: np.ndarray, ref: np.ndarray, time_a: float = 1.0,
                   time_b: float = 1.0, block: int = 8) -> dict:
    """The numbers and maps of the comparison (maps as numpy arrays under ``maps``)."""
    a, b, ref = _rgb(a), _rgb(b), _rgb(ref)
    if not (a.shape == b.shape == ref.shape):
        raise UsageError(f"images differ in size: A {a.shape[1]}x{a.shape[0]}, "
                         f"B {b.shape[1]}x{b.shape[0]}, reference {ref.shape[1]}x{ref.shape[0]}")
    if time_a <= 0 or time_b <= 0:
        raise UsageError("render times must be positive")
    se_a, se_b = ((a - ref) ** 2).mean(axis=2), ((b - ref) ** 2).mean(axis=2)
    weight = 1.0 / (ref.mean(axis=2) ** 2 + REL_EPS)
    mse_a, mse_b = float(se_a.mean()), float(se_b.mean())
    rel_a, rel_b = float((se_a * weight).mean()), float((se_b * weight).mean())
    blocks_a, blocks_b = block_mean(se_a, block), block_mean(se_b, block)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio_map = np.where((blocks_a > 0) & (blocks_b > 0),
                             (blocks_a * time_a) / (blocks_b * time_b), np.nan)
    eff = (mse_a * time_a) / (mse_b * time_b) if mse_b > 0 else math.inf
    return {"mse": {"a": mse_a, "b": mse_b}, "relative_mse": {"a": rel_a, "b": rel_b},
            "time": {"a": time_a, "b": time_b}, "efficiency_ratio_b_over_a": eff,
            "relative_efficiency_ratio_b_over_a": (rel_a * time_a) / (rel_b * time_b) if rel_b > 0 else math.inf,
            "block": block, "maps": {"se_a": se_a, "se_b": se_b, "efficiency_ratio": ratio_map}}


def heat_maps(result: dict, path: Path, names=("A", "B")) -> None:
    """Squared error of A and B (shared log colour scale) and the block efficiency ratio."""
    from matplotlib.colors import LogNorm

    from .report import pyplot, save

    plt = pyplot()
    maps = result["maps"]
    se = np.concatenate([maps["se_a"].ravel(), maps["se_b"].ravel()])
    positive = se[se > 0]
    lo = max(np.percentile(positive, 1), 1e-12) if positive.size else 1e-12
    hi = max(np.percentile(positive, 99.5), lo * 10) if positive.size else 1.0
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for ax, key, name in zip(axes[:2], ("se_a", "se_b"), names):
        im = ax.imshow(np.maximum(maps[key], lo), norm=LogNorm(lo, hi), cmap="inferno")
        ax.set_title(f"{name}: squared error (MSE {result['mse'][key[-1]]:.3g})")
        fig.colorbar(im, ax=ax, label="squared error per pixel (log)")
    ratio = maps["efficiency_ratio"]
    finite = ratio[np.isfinite(ratio) & (ratio > 0)]
    span = max(abs(np.log10(np.percentile(finite, [2, 98]))).max(), 0.5) if finite.size else 1.0
    im = axes[2].imshow(np.log10(ratio), cmap="RdBu", vmin=-span, vmax=span)
    axes[2].set_title(f"efficiency {names[1]}/{names[0]} per {result['block']}px block "
                      f"(total {result['efficiency_ratio_b_over_a']:.3g})")
    fig.colorbar(im, ax=axes[2], label=f"log₁₀ efficiency ratio (> 0: {names[1]} better)")
    for ax in axes:
        ax.set_xlabel("x (pixels or blocks)")
        ax.set_ylabel("y")
        ax.grid(False)
    save(fig, path)
