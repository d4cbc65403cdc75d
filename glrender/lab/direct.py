"""Direct-lighting strategies on Veach's plates (scenes/veach-mis): light, BSDF, MIS balance, MIS power.

The renderer's ``direct`` integrator with one light sample and one BSDF sample per
camera sample, weighted by each strategy: light sampling alone, BSDF sampling alone,
or both with the balance or the power heuristic (Veach 1997, ch. 9). Four rough
plates (α = 0.005, 0.02, 0.05, 0.1 from plate 1 to plate 4) reflect four sphere lights
of very different sizes: light sampling fails on the sharp plates with big lights,
BSDF sampling on the rough plates with small lights, MIS on neither.

Every strategy renders the same view from independent seeds with the independent
sampler, so each pixel's per-sample variance is exact. Veach's Theorem 9.2 bounds the
balance heuristic with one sample of each technique: Var_MIS ≤ min_i Var_i + (1/min_i
n_i − 1/Σ n_i) μ² = min(Var_light, Var_bsdf) + μ²/2, per pixel and channel; the table
per plate sums both sides over the plate's pixels.
"""
from __future__ import annotations

import numpy as np

from .core import Section
from .renders import load_scene, log_map, region_table, render_variants, tonemap
from .report import pyplot, save

NAME = "direct"
TITLE = "Direct lighting: light vs BSDF sampling vs MIS (Veach's plates)"

STRATEGIES = {"light": "light sampling", "bsdf": "BSDF sampling",
              "mis-balance": "MIS, balance heuristic", "mis-power": "MIS, power heuristic"}
# plate normals (from the plate meshes): the normal AOV picks each plate's pixels
PLATE_NORMALS = {"plate 1 (α 0.005)": (0.0, 0.782, 0.623), "plate 2 (α 0.02)": (0.0, 0.893, 0.45),
                 "plate 3 (α 0.05)": (0.0, 0.955, 0.297), "plate 4 (α 0.1)": (0.0, 0.984, 0.175)}


def plate_masks(normal: np.ndarray) -> dict[str, np.ndarray]:
    n = normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-9)
    return {name: np.linalg.norm(n - np.array(v), axis=-1) < 0.02 for name, v in PLATE_NORMALS.items()}


def veach_bound(renders, mask) -> dict:
    """Both sides of Theorem 9.2 summed over the pixels (and channels) of ``mask``, with the
    standard error of each side and of the worse single strategy from the runs' spread."""
    def per_run(r):
        return r.variances[:, mask, :].sum(axis=(1, 2))
    light, bsdf, bal = (renders[k] for k in ("light", "bsdf", "mis-balance"))
    mu2 = (bal.mean[mask] ** 2).sum()
    lhs_runs = per_run(bal)
    pooled_min = np.minimum(light.variance[mask], bsdf.variance[mask]).sum()
    pooled_max = np.maximum(light.variance[mask], bsdf.variance[mask]).sum()
    k = bal.runs
    se = {key: float(np.std(per_run(r), ddof=1) / np.sqrt(k))
          for key, r in (("light", light), ("bsdf", bsdf), ("balance", bal))}
    return {"pixels": int(mask.sum()), "var_balance": float(lhs_runs.mean()),
            "var_balance_se": se["balance"], "min_single": float(pooled_min),
            "max_single": float(pooled_max), "single_se": max(se["light"], se["bsdf"]),
            "half_mu2": float(0.5 * mu2), "bound": float(pooled_min + 0.5 * mu2),
            "var_light": float(light.variance[mask].sum()), "var_bsdf": float(bsdf.variance[mask].sum()),
            "var_power": float(renders["mis-power"].variance[mask].sum())}


def run(lab) -> Section:
    width, height = lab.size((96, 64), (384, 256))
    runs, spp = lab.size((16, 32), (16, 128))
    scene = load_scene("veach-mis", width, height)
    variants = {s: dict(integrator="direct", strategy=s) for s in STRATEGIES}
    renders = render_variants(lab, scene, variants, runs, spp, aovs_of="mis-power")
    masks = plate_masks(renders["mis-power"].normal)
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1])
    plates = np.logical_or.reduce(list(masks.values()))
    section.tables.append(region_table("All plates", renders, plates, labels=STRATEGIES,
                                       note="Estimate: the plates' mean radiance; variance: the "
                                            "mean per-pixel per-sample variance; cost: device "
                                            "seconds per sample per pixel of the whole image "
                                            "(pixels that see the lights directly are left out: "
                                            "their variance, from antialiasing bright spheres, "
                                            "is the same for every strategy)."))
    bounds = {}
    for plate, mask in masks.items():
        section.tables.append(region_table(plate, renders, mask, labels=STRATEGIES))
        b = bounds[plate] = veach_bound(renders, mask)
        section.findings.append(
            f"{plate}: Σ Var balance {b['var_balance']:.4g} ≤ bound {b['bound']:.4g} "
            f"(min single {b['min_single']:.4g} + μ²/2 {b['half_mu2']:.4g}); light "
            f"{b['var_light']:.4g}, BSDF {b['var_bsdf']:.4g}, power heuristic {b['var_power']:.4g}")
    section.extra["veach_bound"] = bounds
    section.extra["plate_pixels"] = {p: int(m.sum()) for p, m in masks.items()}
    # Pixels that two strategies render exactly black over every run and a third does not.
    # Counted every way round: rare samples (the Gaussian filter's tails reaching lit pixels
    # next to the shadow under plate 4) make such pixels in every direction, at rates set by
    # how often each strategy finds that light; a leak would show in one direction only
    # (tests/render/test_veach_shadow.py: with a box filter that shadow is black for all).
    black = {s: r.means.max(axis=(0, 3)) == 0 for s, r in renders.items()}
    names = list(STRATEGIES)
    counts = {}
    for lit_in in names:
        for a in names:
            for b in names:
                if a < b and lit_in not in (a, b):
                    counts[f"black in {a} and {b}, lit in {lit_in}"] = int(
                        (black[a] & black[b] & ~black[lit_in]).sum())
    section.extra["black_in_two_lit_in_third"] = counts
    pair = counts.get("black in bsdf and light, lit in mis-power", 0)
    back = counts.get("black in bsdf and mis-power, lit in light", 0)
    among = counts.get("black in bsdf and mis-balance, lit in mis-power", 0)
    odd = black["light"] & black["bsdf"] & ~black["mis-power"]
    rows = f" (rows {np.nonzero(odd)[0].min()}–{np.nonzero(odd)[0].max()})" if odd.any() else ""
    section.findings.append(
        f"{pair} pixels{rows} are black under light and under BSDF sampling in every run but lit under "
        f"MIS (power), and {back} black under BSDF sampling and MIS (power) but lit under light "
        f"sampling; {among} even black under BSDF sampling and MIS (balance) but lit under MIS "
        f"(power): no leak, but rare samples of the Gaussian filter's tails (at the full size, "
        f"rows 229–231 see the floor in the shadow under plate 4, which a box filter renders "
        f"black for every strategy; the dark red blocks along the bottom of the efficiency "
        f"map); results.json has every combination")
    whole = section.tables[0]
    best_single = max(whole.row("light").efficiency, whole.row("bsdf").efficiency)
    for s in ("mis-balance", "mis-power"):
        section.findings.append(f"all plates: {STRATEGIES[s]} efficiency ×"
                                f"{whole.row(s).efficiency / best_single:.3g} of the better "
                                f"single strategy")

    # equal time: each strategy gets the samples the light strategy's budget buys
    budget = renders["light"].cost * spp
    equal_time = {}
    for s in STRATEGIES:
        n = max(1, int(round(budget / renders[s].cost)))
        equal_time[s] = render_variants(lab, scene, {s: variants[s]}, 1, n)[s]
    section.extra["equal_time_spp"] = {s: r.spp for s, r in equal_time.items()}
    _grid_figure(lab.figure_path("direct_grid.png"), renders, equal_time, spp)
    _variance_figure(lab.figure_path("direct_variance.png"), renders)
    _efficiency_figure(lab.figure_path("direct_efficiency.png"), renders)
    section.figures += [
        ("direct_grid.png", f"Veach's Figure 9.2: each strategy at {spp} spp (top) and at equal "
                            "time (bottom: the light strategy's time; spp in the titles)"),
        ("direct_variance.png", "Per-pixel variance per sample (log₁₀, shared scale; mean of "
                                "the channels and of the runs)"),
        ("direct_efficiency.png", "Efficiency ratio per pixel (log₁₀): MIS over the better single "
                                  "strategy in each 4×4-pixel block; > 0 (blue) means MIS is more efficient"),
    ]
    return section


def _grid_figure(path, renders, equal_time, spp) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, len(STRATEGIES), figsize=(3.3 * len(STRATEGIES), 5.0))
    for j, s in enumerate(STRATEGIES):
        for i, (img, title) in enumerate(((renders[s].means[0], f"{STRATEGIES[s]}\n{spp} spp"),
                                          (equal_time[s].means[0],
                                           f"equal time: {equal_time[s].spp} spp"))):
            axes[i, j].imshow(tonemap(img))
            axes[i, j].set_title(title)
            axes[i, j].axis("off")
    save(fig, path)


def _variance_figure(path, renders) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, len(STRATEGIES), figsize=(3.6 * len(STRATEGIES), 2.6))
    allv = np.concatenate([r.variance.mean(axis=2).ravel() for r in renders.values()])
    pos = allv[allv > 0]
    lo, hi = (np.percentile(pos, 2), np.percentile(pos, 99.8)) if pos.size else (1e-6, 1.0)
    for ax, s in zip(axes, STRATEGIES):
        log_map(ax, fig, renders[s].variance.mean(axis=2), "log₁₀ variance per sample",
                STRATEGIES[s], lo, hi)
    save(fig, path)


def _efficiency_figure(path, renders, block: int = 4) -> None:
    """Per block of pixels: a single pixel's variance estimate of a strategy that rarely
    finds the light is often 0 (no hit yet), which would make it look infinitely efficient."""
    from .compare import block_mean

    plt = pyplot()
    var = {s: block_mean(r.variance.mean(axis=2), block) for s, r in renders.items()}
    eff = {s: 1.0 / np.maximum(var[s] * renders[s].cost, 1e-30) for s in renders}
    best = np.maximum(eff["light"], eff["bsdf"])
    fig, axes = plt.subplots(1, 2, figsize=(8.4, 2.8))
    for ax, s in zip(axes, ("mis-balance", "mis-power")):
        ratio = np.log10(eff[s] / best)
        ratio[var[s] <= 0] = 0.0
        im = ax.imshow(ratio, cmap="RdBu", vmin=-2, vmax=2)
        ax.set_title(f"{STRATEGIES[s]} / better single\n(per {block}×{block}-pixel block)")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.grid(False)
        fig.colorbar(im, ax=ax, label="log₁₀ efficiency ratio", shrink=0.8)
    save(fig, path)
