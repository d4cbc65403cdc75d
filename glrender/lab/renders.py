"""Renderer experiments: one scene rendered with several settings from independent seeds.

Every variant renders ``runs`` images of ``spp`` samples with the independent sampler,
each with its own seed (a full randomization), so the per-pixel per-sample variance of
each image (M2 from the accumulation's exact sums) is exact and the spread between the
runs gives standard errors. The cost is the device time of ``Renderer.step`` (the
renderer finishes the GL queue around each dispatch), per sample per pixel, and, with
``count_rays``, the rays the path tracer traced (an exact count).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import UsageError

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def load_scene(name: str, width: int, height: int):
    """A scene of the repository's scenes/ folder at the given film size."""
    from ..scene import load

    path = SCENES / name / "scene.toml"
    if not path.is_file():
        raise UsageError(f"the lab's renderer experiments need {path} (run from a source checkout)")
    scene = load(path)
    return replace(scene, film=replace(scene.film, width=width, height=height))


@dataclass
class Renders:
    """``runs`` independent renders of one variant."""

    name: str
    means: np.ndarray        # (runs, H, W, 3) each run's image
    variances: np.ndarray    # (runs, H, W, 3) each run's per-sample variance per pixel
    spp: int
    seconds: float           # device time of all runs
    albedo: np.ndarray | None = None
    normal: np.ndarray | None = None
    rays: int = 0            # rays traced in all runs (count_rays), else 0

    @property
    def runs(self) -> int:
        return len(self.means)

    @property
    def mean(self) -> np.ndarray:
        return self.means.mean(axis=0)

    @property
    def variance(self) -> np.ndarray:
        """Per-sample variance per pixel and channel, averaged over the runs."""
        return self.variances.mean(axis=0)

    @property
    def cost(self) -> float:
        """Device seconds per sample per pixel."""
        h, w = self.means.shape[1:3]
        return self.seconds / (self.runs * self.spp * h * w)

    @property
    def rays_per_sample(self) -> float:
        h, w = self.means.shape[1:3]
        return self.rays / (self.runs * self.spp * h * w)


def render_variants(lab, scene, variants: dict[str, dict], runs: int, spp: int,
                    aovs_of: str | None = None, count_rays: bool = False) -> dict[str, Renders]:
    """Render each variant (settings overrides) ``runs`` times, each run with its own seed
    (independent across runs and variants); the variants take turns run by run, so a
    busy spell of the machine hits them alike. ``count_rays``: count the rays each variant
    traces (every variant counts, so the counters' cost is alike too)."""
    from ..drivers import create_driver
    from ..render.job import JobOptions, job_settings, make_driver

    renderers, settings = {}, {}
    acc = {name: {"means": [], "variances": [], "seconds": 0.0, "albedo": None, "normal": None,
                  "rays": 0} for name in variants}
    try:
        for name, overrides in variants.items():
            overrides = dict(overrides)
            options = JobOptions(integrator=overrides.pop("integrator", None), spp=spp,
                                 settings=dict(sampler="independent", aovs=name == aovs_of,
                                               count_rays=count_rays, **overrides))
            settings[name] = job_settings(scene, options)
            renderers[name] = make_driver(scene, settings[name], create_driver, ctx=lab.ctx)
        for r in range(runs):
            for v, (name, renderer) in enumerate(renderers.items()):
                seed = (lab.seed * 100_003 + v * 1009 + r) & 0x7FFFFFFF
                s = settings[name]
                renderer.settings = replace(s, sampler=replace(s.sampler, seed=seed))
                renderer.reset()
                t0 = time.perf_counter()
                renderer.step(spp)
                a = acc[name]
                a["seconds"] += time.perf_counter() - t0
                film = renderer.film()
                if count_rays:
                    a["rays"] += renderer.rays()
                a["means"].append(film.mean.astype(np.float64))
                a["variances"].append(film.variance.astype(np.float64))
                if name == aovs_of and a["albedo"] is None:
                    a["albedo"], a["normal"] = film.aovs.get("albedo"), film.aovs.get("normal")
    finally:
        for renderer in renderers.values():
            renderer.release()
    return {name: Renders(name, np.stack(a["means"]), np.stack(a["variances"]), spp, a["seconds"],
                          albedo=a["albedo"], normal=a["normal"], rays=a["rays"])
            for name, a in acc.items()}


def tonemap(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear RGB -> sRGB in [0, 1] (clamped), for figures."""
    x = np.clip(image * 2.0 ** exposure, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def region_table(title: str, renders: dict[str, Renders], mask: np.ndarray | None = None,
                 labels: dict[str, str] | None = None, baseline: str | None = None, note: str = "",
                 exact: float | None = None):
    """A :class:`~glrender.lab.core.Table` over the pixels of ``mask`` (all by default): each
    run's estimate is the region's mean radiance, its variance the region's mean per-sample
    variance (channels averaged); cost per sample per pixel (and rays per sample when they
    were counted); ``exact``: the region's exact mean radiance, when known."""
    from .core import Measurement, Table

    rows = []
    for name, r in renders.items():
        m = np.ones(r.means.shape[1:3], bool) if mask is None else mask
        estimates = r.means[:, m, :].mean(axis=(1, 2))
        run_vars = r.variances[:, m, :].mean(axis=(1, 2))
        samples = r.spp * r.means.shape[1] * r.means.shape[2]
        rows.append(Measurement(name, estimates, samples, r.seconds, run_variances=run_vars,
                                label=(labels or {}).get(name, name), exact=exact,
                                units={"rays": r.rays_per_sample} if r.rays else {}))
    return Table(title, rows, baseline=baseline, note=note)


def log_map(ax, fig, values: np.ndarray, label: str, title: str, lo=None, hi=None, cmap="magma"):
    """A log10 heat map with a colour bar (non-positive values shown at the low end)."""
    positive = values[values > 0]
    lo = lo if lo is not None else (np.percentile(positive, 1) if positive.size else 1e-6)
    hi = hi if hi is not None else (np.percentile(positive, 99.5) if positive.size else 1.0)
    im = ax.imshow(np.log10(np.clip(values, lo, hi)), cmap=cmap, vmin=np.log10(lo), vmax=np.log10(hi))
    ax.set_title(title)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.grid(False)
    fig.colorbar(im, ax=ax, label=label, shrink=0.8)
    return lo, hi


def pair_variance_figure(path, va: np.ndarray, vb: np.ndarray, titles: tuple[str, str],
                         ratio_label: str, span: float = 1.0) -> None:
    """Two per-pixel variance maps (log₁₀, shared scale) and log₁₀(vb / va) beside them."""
    from .report import pyplot, save

    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 2.9))
    pos = np.concatenate([va[va > 0], vb[vb > 0]])
    lo, hi = (np.percentile(pos, 2), np.percentile(pos, 99.8)) if pos.size else (1e-6, 1.0)
    for ax, v, title in zip(axes, (va, vb), titles):
        log_map(ax, fig, v, "log₁₀ variance per sample", title, lo, hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where((va > 0) & (vb > 0), np.log10(vb / va), 0.0)
    im = axes[2].imshow(ratio, cmap="RdBu_r", vmin=-span, vmax=span)
    axes[2].set_title(f"variance ratio {titles[1]} / {titles[0]}")
    axes[2].set_xticks([])
    axes[2].set_yticks([])
    axes[2].grid(False)
    fig.colorbar(im, ax=axes[2], label=ratio_label, shrink=0.8)
    save(fig, path)
