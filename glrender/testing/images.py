"""Statistical comparison of rendered images with a reference or a closed form.

The rules of docs (TESTING): error bars come from independent renders (seeds), not
from a render's own per-sample variance (which overstates QMC error 4-5x);
per-pixel variances are pooled over a block of pixels so that each block's sigma
has pixels x (k - 1) degrees of freedom; all blocks x channels of a test are
compared at one Šidák-corrected threshold, so a correct renderer fails the whole
test with probability alpha; zero-variance cases get a float tolerance
|delta| <= z sigma + eps |ref|.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .stats import sidak_t, sidak_z


@dataclass
class Comparison:
    """The outcome of :func:`compare_images`."""

    passed: bool
    z_threshold: float
    worst_z: float
    worst_block: tuple
    mean: float
    ref_mean: float
    mean_sigma: float
    detectable_bias: float          # relative bias of the image mean the test would detect
    mse: float
    expected_mse: float
    mse_ratio: float
    mse_ratio_sigma: float
    messages: list = field(default_factory=list)
    mean_threshold: float = 0.0     # the image-mean test's: z, or Student t (correlated_pixels)

    def summary(self) -> str:
        return (f"mean {self.mean:.6g} vs {self.ref_mean:.6g} ({(self.mean / self.ref_mean - 1) * 100:+.3f}%, "
                f"sigma {self.mean_sigma / abs(self.ref_mean) * 100:.3f}%, detectable bias "
                f"{self.detectable_bias * 100:.3f}%); worst block z {self.worst_z:.2f} at "
                f"{self.worst_block} (threshold {self.z_threshold:.2f}); MSE/expected "
                f"{self.mse_ratio:.3f} +- {self.mse_ratio_sigma:.3f}")


def _blocks(a: np.ndarray, block: int) -> np.ndarray:
    """Mean over non-overlapping block x block tiles: (..., H, W, C) -> (..., H/b, W/b, C)."""
    h, w = a.shape[-3] // block * block, a.shape[-2] // block * block
    a = a[..., :h, :w, :]
    shape = a.shape[:-3] + (h // block, block, w // block, block, a.shape[-1])
    return a.reshape(shape).mean(axis=(-4, -2))


def compare_images(renders: np.ndarray, reference: np.ndarray, reference_stderr: np.ndarray | None = None,
                   block: int = 16, alpha: float = 0.01, extra_tests: int = 0, eps: float = 1e-5,
                   mask: np.ndarray | None = None, check_mse: bool = True,
                   correlated_pixels: bool = False, correlated_blocks: bool = False) -> Comparison:
    """Compare k independent renders (k, H, W, C) with a reference (H, W, C).

    Tests, at family-wise level ``alpha`` over all of them (plus ``extra_tests`` other
    comparisons made by the caller, for Šidák):
    - every block x channel mean: |mean_k - ref| <= t sigma + eps |ref|, with sigma from the
      pooled per-pixel variance across renders (and the reference's own error) and t the
      Šidák-corrected Student-t quantile for the block's pixels x (k - 1) degrees of freedom;
    - the image mean, likewise; with ``correlated_pixels``, its sigma comes from the spread
      of the k renders' own image means instead, at the Student-t threshold for k - 1
      degrees of freedom: splatting integrators (light tracing, bdpt) send one light path
      to several pixels, so their pixels are correlated within a render and the per-pixel
      variances understate the image mean's (1.3-1.8x measured on the Cornell box);
    - with ``correlated_blocks`` (it implies ``correlated_pixels``), each block's sigma too
      comes from the spread of the k renders' own block means, at the Student-t threshold
      for k - 1 degrees of freedom: estimators whose samples reach many pixels within a
      render (vcm's and photon mapping's merges over a radius of a few pixels) make the
      pixels of a block correlated, and pooled per-pixel variances understate the block
      mean's; the MSE test, whose sigma assumes independent pixels, is then left out;
    - (``check_mse``) the MSE of the averaged render against the reference is what the
      render's and reference's noise explain: ratio within z of 1, its sigma estimated from
      the per-pixel terms.
    ``mask`` (H, W) bool selects the pixels compared (others ignored).
    """
    r = np.asarray(renders, np.float64)
    ref = np.asarray(reference, np.float64)
    k = r.shape[0]
    if k < 2:
        raise ValueError("compare_images: need at least 2 independent renders for error bars")
    if r.shape[1:] != ref.shape:
        raise ValueError(f"compare_images: renders {r.shape[1:]} vs reference {ref.shape}")
    ref_var = np.zeros_like(ref) if reference_stderr is None else np.asarray(reference_stderr, np.float64) ** 2
    if ref_var.ndim == ref.ndim - 1:
        ref_var = ref_var[..., None]
    ref_var = np.broadcast_to(ref_var, ref.shape)
    m = np.ones(ref.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    wmask = m[..., None].astype(np.float64) * np.ones(ref.shape[-1])

    pixel_mean = r.mean(axis=0)
    pixel_var = r.var(axis=0, ddof=1)                     # per-render variance of each pixel
    # block statistics: mean difference and its variance (pixels independent)
    counts = _blocks(wmask, block) * block * block
    diff_b = _blocks((pixel_mean - ref) * wmask, block) * block * block
    var_b = _blocks((pixel_var / k + ref_var) * wmask, block) * block * block
    # For skewed sample distributions (rare bright samples) a block whose renders drew
    # low also estimates a low variance, and its z is too large. The variance per pixel
    # is therefore also pooled over the 3x3 neighbourhood of blocks, and each block uses
    # the larger of the two estimates (conservative at edges of the variance, and its
    # own draws weigh 1/9 in the neighbourhood's).
    var_px = np.where(counts > 0, var_b / np.maximum(counts, 1), 0.0)
    neigh_sum, neigh_cnt = np.zeros_like(var_b), np.zeros_like(counts)
    hb, wb = var_b.shape[:2]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            ys = slice(max(dy, 0), hb + min(dy, 0))
            yd = slice(max(-dy, 0), hb + min(-dy, 0))
            xs = slice(max(dx, 0), wb + min(dx, 0))
            xd = slice(max(-dx, 0), wb + min(-dx, 0))
            neigh_sum[yd, xd] += var_b[ys, xs]
            neigh_cnt[yd, xd] += counts[ys, xs]
    var_px = np.maximum(var_px, neigh_sum / np.maximum(neigh_cnt, 1))
    var_b = var_px * counts
    if correlated_blocks:
        correlated_pixels, check_mse = True, False
        sums_k = _blocks(r * wmask, block) * block * block          # (k, H/b, W/b, C)
        var_b = sums_k.var(axis=0, ddof=1) / k + _blocks(ref_var * wmask, block) * block * block
    ref_b = _blocks(np.abs(ref) * wmask, block) * block * block
    valid = counts > 0
    n_blocks = int(valid.sum())
    tests = n_blocks + 2 + extra_tests
    z = sidak_z(alpha, tests)
    # A block's sigma pools its pixels' variances: pixels x (k - 1) degrees of freedom.
    # Partly masked blocks have fewer, so they get Student-t thresholds.
    thresholds = {int(c): sidak_t(alpha, tests, c * (k - 1)) for c in np.unique(counts[valid])}
    t_block = np.vectorize(lambda c: thresholds.get(int(c), np.inf))(counts)
    if correlated_blocks:
        t_block = np.where(valid, sidak_t(alpha, tests, k - 1), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        bmean = diff_b / np.maximum(counts, 1)
        bsig = np.sqrt(var_b) / np.maximum(counts, 1)
        bref = ref_b / np.maximum(counts, 1)
        zb = np.where(valid, np.abs(bmean) / np.maximum(bsig, 1e-300) * (z / t_block), 0.0)
        ok_b = (~valid) | (np.abs(bmean) <= t_block * bsig + eps * bref)
    worst = np.unravel_index(np.argmax(np.where(ok_b, zb, np.inf)), zb.shape)
    messages = []
    passed = bool(ok_b.all())
    if not passed:
        bad = np.argwhere(~ok_b)
        messages.append(f"{len(bad)} of {n_blocks} block-channels differ beyond z = {z:.2f} "
                        f"(first: block {tuple(bad[0][:2])} channel {bad[0][2]}: "
                        f"{bmean[tuple(bad[0])]:+.4g} +- {bsig[tuple(bad[0])]:.3g})")

    total = wmask.sum()
    mean = float((pixel_mean * wmask).sum() / total)
    ref_mean = float((ref * wmask).sum() / total)
    mean_sigma = float(np.sqrt(((pixel_var / k + ref_var) * wmask).sum()) / total)
    z_mean = z
    if correlated_pixels:
        render_means = (r * wmask).sum(axis=(1, 2, 3)) / total
        mean_sigma = float(np.sqrt(render_means.var(ddof=1) / k + (ref_var * wmask).sum() / total ** 2))
        z_mean = sidak_t(alpha, tests, k - 1)
    if abs(mean - ref_mean) > z_mean * mean_sigma + eps * abs(ref_mean):
        passed = False
        messages.append(f"image mean {mean:.6g} vs {ref_mean:.6g}: {abs(mean - ref_mean) / mean_sigma:.1f} sigma")

    err2 = (pixel_mean - ref) ** 2
    expected = pixel_var / k + ref_var
    sel = wmask > 0
    mse, expected_mse = float(err2[sel].mean()), float(expected[sel].mean())
    ratio = mse / expected_mse if expected_mse > 0 else (0.0 if mse == 0 else np.inf)
    # sigma of the ratio from the spread of the per-pixel terms
    terms = err2[sel] - ratio * expected[sel]
    ratio_sigma = float(terms.std(ddof=1) / np.sqrt(terms.size) / expected_mse) if expected_mse > 0 else 0.0
    if check_mse and expected_mse > 0 and abs(ratio - 1.0) > z * ratio_sigma:
        passed = False
        messages.append(f"MSE / expected = {ratio:.3f} +- {ratio_sigma:.3f}: the render's noise "
                        f"does not explain its error")
    detectable = z_mean * mean_sigma / abs(ref_mean) if ref_mean else np.inf
    return Comparison(passed, z, float(zb[worst]), tuple(int(v) for v in worst), mean, ref_mean,
                      mean_sigma, detectable, mse, expected_mse, ratio, ratio_sigma, messages, z_mean)
