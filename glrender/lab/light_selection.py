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
from .renders import load_scene, pair_variance_figure, region_table, render_variants
from .report import bar_figure

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
    vu, vp = (renders[c].variance.mean(axis=2) for c in CHOICES)
    pair_variance_figure(path, vu, vp, ("uniform", "∝ power"),
                         "log₁₀ variance ratio (< 0: power better)", span=1.5)
