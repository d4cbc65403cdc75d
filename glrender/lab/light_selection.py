"""Light selection: uniform vs ∝ power, in the renderer, over lights of very unequal power.

Veach's plates scene has five sphere lights whose powers span three orders of
magnitude (radiance 11 to 900 on radii 0.03 to 0.5, and the large distant light).
The direct integrator (MIS, power heuristic) picks one light per light sample either
uniformly (as Mitsuba does) or with probability ∝ its power (an alias table). The
tables give the plates' pixels and the floor's: choosing by power spends the samples
on the lights that matter most on average, which is not the same as most at a given
pixel (a dim light close to a surface matters more there than its power says).
"""
from __future__ import annotations

import numpy as np

from .core import Section
from .direct import plate_masks
from .renders import load_scene, log_map, region_table, render_variants
from .report import bar_figure, pyplot, save

NAME = "light_selection"
TITLE = "Light selection: uniform vs ∝ power (renderer)"

CHOICES = {"uniform": "uniform", "power": "∝ power"}


def run(lab) -> Section:
    width, height = lab.size((96, 64), (384, 256))
    runs, spp = lab.size((16, 32), (16, 128))
    scene = load_scene("veach-mis", width, height)
    variants = {c: dict(integrator="direct", strategy="mis-power", light_selection=c) for c in CHOICES}
    renders = render_variants(lab, scene, variants, runs, spp, aovs_of="uniform")
    masks = plate_masks(renders["uniform"].normal)
    plates = np.logical_or.reduce(list(masks.values()))
    normal = renders["uniform"].normal
    floor = np.linalg.norm(normal - np.array([0.0, 1.0, 0.0]), axis=-1) < 0.02
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1])
    section.tables += [region_table("Whole image", renders, labels=CHOICES),
                       region_table("All plates", renders, plates, labels=CHOICES),
                       region_table("Floor", renders, floor, labels=CHOICES)]
    for t in section.tables:
        u, p = t.row("uniform"), t.row("power")
        section.findings.append(f"{t.title}: ∝ power has ×{p.variance / u.variance:.3g} the variance "
                                f"and ×{p.cost / u.cost:.3g} the cost of uniform selection "
                                f"(efficiency ×{p.efficiency / u.efficiency:.3g})")
    bar_figure(lab.figure_path("light_selection_ratios.png"), section.tables[0],
               "Light selection ∝ power vs uniform (whole image)")
    _ratio_map(lab.figure_path("light_selection_map.png"), renders)
    section.figures += [("light_selection_ratios.png", "Whole image: ratios to uniform selection"),
                        ("light_selection_map.png", "Per-pixel variance per sample of each "
                                                    "choice (log₁₀) and their ratio")]
    return section


def _ratio_map(path, renders) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 2.8))
    vu, vp = (renders[c].variance.mean(axis=2) for c in CHOICES)
    pos = np.concatenate([vu[vu > 0], vp[vp > 0]])
    lo, hi = (np.percentile(pos, 2), np.percentile(pos, 99.8)) if pos.size else (1e-6, 1.0)
    log_map(axes[0], fig, vu, "log₁₀ variance per sample", "uniform selection", lo, hi)
    log_map(axes[1], fig, vp, "log₁₀ variance per sample", "selection ∝ power", lo, hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where((vu > 0) & (vp > 0), np.log10(vp / vu), 0.0)
    im = axes[2].imshow(ratio, cmap="RdBu_r", vmin=-1.5, vmax=1.5)
    axes[2].set_title("variance ratio ∝ power / uniform")
    axes[2].set_xticks([])
    axes[2].set_yticks([])
    axes[2].grid(False)
    fig.colorbar(im, ax=axes[2], label="log₁₀ variance ratio (< 0: power better)", shrink=0.8)
    save(fig, path)
