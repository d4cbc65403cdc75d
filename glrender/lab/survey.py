"""The path tracer's defaults chosen by measurement over the scenes users render.

Every setting the defaults decide (the Russian-roulette rule and its start depth, the
MIS heuristic, the light selection) is changed one at a time from Mitsuba's settings
(throughput roulette from depth 5, the power heuristic, uniform light selection: the
renderer's former defaults, the baseline) and each scene of the repository's scenes/
folder that stands for what users render is rendered with the path tracer at its own
depth: the Cornell box, the Cornell box with the bunny (a BVH), the caustic (glass),
Veach's plates (five lights whose powers span three orders of magnitude; path tracer,
depth 8), the door (light through a gap), the environment map and the closed emissive
enclosure (unbounded depth). Every setting renders the same view from independent seeds
with the independent sampler; the estimate is the image's mean radiance, its variance
the mean per-pixel per-sample variance; cost: measured device time per sample (the
settings take turns run by run; the machine is shared, so timings are noisy) and the
rays traced (exact). Efficiency = 1/(variance · cost).

**Criterion.** For each decision the candidate with the highest geometric mean over the
scenes of its efficiency ratio to the baseline (by measured time) wins, among the
candidates that are no worse than ×0.8 of the baseline on any scene (a default may trade
a little on one scene for much on the others, but not lose a fifth of the efficiency on
a scene a user renders) and whose variance stays finite on every scene of albedo up to
0.9 (white paint, snow), a condition a finite run measures badly (the variance sits in
rare long paths), so it is decided from the rule itself (:func:`finite_variance_albedo`). The baseline always qualifies. The geometric mean weighs a
gain and a loss of the same factor alike, whatever the scene's absolute variance. The
chosen settings together are then rendered once more against the baseline on every
scene, to show that they also hold combined.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table
from .renders import load_scene, region_table, render_variants
from .report import pyplot, save
from .roulette import unbiased_finding, unbiasedness

NAME = "survey"
TITLE = "The path tracer's defaults over the scenes users render"

BASELINE = dict(rr="throughput", rr_depth=5, strategy="mis-power", light_selection="uniform")
FLOOR = 0.8   # the criterion's worst-scene limit (efficiency ratio to the baseline)
ALBEDO = 0.9  # the albedo up to which a default must keep the variance finite
THROUGHPUT_CAP = 0.95   # the throughput rule's largest survival probability (Mitsuba's)

# decision -> candidates (name, label, overrides of the baseline); the first is the baseline
DECISIONS = {
    "roulette": [("baseline", "throughput RR from depth 5 (Mitsuba)", {}),
                 ("rr-depth-1", "throughput RR from depth 1", dict(rr_depth=1)),
                 ("rr-depth-3", "throughput RR from depth 3", dict(rr_depth=3)),
                 ("rr-fixed-0.5", "fixed q = 0.5 from depth 5", dict(rr="fixed:0.5")),
                 ("rr-fixed-0.7", "fixed q = 0.7 from depth 5", dict(rr="fixed:0.7")),
                 ("rr-fixed-0.7-d3", "fixed q = 0.7 from depth 3", dict(rr="fixed:0.7", rr_depth=3))],
    "MIS heuristic": [("baseline", "power heuristic (Mitsuba)", {}),
                      ("mis-balance", "balance heuristic", dict(strategy="mis-balance"))],
    "light selection": [("baseline", "uniform (Mitsuba)", {}),
                        ("light-power", "∝ power", dict(light_selection="power"))],
}


def _scenes(lab):
    """(scene folder, title, film (w, h), max depth override or None)."""
    q = lab.quick
    full = [("cornell-box", "Cornell box", (48, 48), None),
            ("cornell-bunny", "Cornell box with the bunny", (48, 48), None),
            ("caustic", "caustic (glass sphere)", (48, 48), None),
            ("veach-mis", "Veach's plates (path, depth 8)", (72, 48), 8),
            ("door", "door ajar", (48, 48), None),
            ("envmap", "environment map", (64, 32), None),
            ("enclosure", "closed enclosure (unbounded)", (32, 32), None)]
    if q:
        return [(n, t, (w // 2, h // 2), d) for n, t, (w, h), d in full
                if n in ("cornell-box", "enclosure")]
    return full


def candidates() -> dict[str, tuple[str, dict]]:
    """Every candidate's label and full settings (baseline overridden), once."""
    out = {}
    for items in DECISIONS.values():
        for name, label, o in items:
            out.setdefault(name, (label if name != "baseline" else "baseline (Mitsuba's settings)",
                                  {**BASELINE, **o}))
    return out


def finite_variance_albedo(rr: str) -> float:
    """The largest albedo ρ at which the path tracer's estimate keeps a finite variance in
    a closed scene of unbounded depth under the roulette rule ``rr``.

    At a diffuse vertex sampled by the cosine the BSDF weight is ρ. With a fixed survival
    probability q the weight after k roulette vertices is (ρ/q)^k and a path gets there
    with probability q^k, so the second moment of what it collects there is ∝
    q^k (ρ/q)^(2k) = (ρ²/q)^k: the sum over k is finite only for ρ < √q (q = 0.5: ρ <
    0.71). The throughput rule survives with p = min(β, cap): while β < cap the weight
    β/p is 1 (bounded), and only while β ≥ cap does it grow, by ρ/cap per vertex with
    p = cap, finite for ρ < √cap (0.975). Without roulette the weight is ρ^k: finite for
    every ρ < 1."""
    from ..scene.model import parse_rr

    kind, q = parse_rr(rr)
    if kind == "off":
        return 1.0
    return math.sqrt(q if kind == "fixed" else THROUGHPUT_CAP)


def ratio(row, base, by: str) -> float:
    """Efficiency ratio of row to base, by measured time or by rays."""
    if by == "time":
        return row.efficiency / base.efficiency
    return (base.variance * base.units["rays"]) / (row.variance * row.units["rays"])


def choose(tables: list[Table], by: str = "time") -> dict:
    """The criterion over the scenes' tables: per decision, every candidate's geometric mean
    and worst efficiency ratio to the baseline, the albedo up to which its variance stays
    finite, and the chosen one."""
    out = {}
    for decision, items in DECISIONS.items():
        stats = {}
        for name, label, o in items:
            rs = [ratio(t.row(name), t.row("baseline"), by) for t in tables]
            stats[name] = {"label": label, "geomean": float(math.exp(np.mean(np.log(rs)))),
                           "worst": float(min(rs)), "per_scene": {t.title: r for t, r in zip(tables, rs)},
                           "finite_variance_albedo": finite_variance_albedo({**BASELINE, **o}["rr"])}
        admissible = [n for n, s in stats.items() if n == "baseline"
                      or (s["worst"] >= FLOOR and s["finite_variance_albedo"] > ALBEDO)]
        chosen = max(admissible, key=lambda n: stats[n]["geomean"])
        out[decision] = {"candidates": stats, "admissible": admissible, "chosen": chosen,
                         "overrides": next(o for n, _, o in items if n == chosen)}
    return out


def chosen_settings(choice: dict) -> dict:
    settings = dict(BASELINE)
    for c in choice.values():
        settings.update(c["overrides"])
    return settings


def run(lab) -> Section:
    runs, spp = lab.size((8, 16), (16, 16))
    cands = candidates()
    labels = {n: label for n, (label, _) in cands.items()}
    tables, scenes = [], []
    for folder, title, (w, h), depth in _scenes(lab):
        scene = load_scene(folder, w, h)
        scenes.append((folder, title, scene, depth))
        extra = {} if depth is None else dict(max_depth=depth)
        variants = {n: dict(integrator="path", **extra, **s) for n, (_, s) in cands.items()}
        renders = render_variants(lab, scene, variants, runs, spp, count_rays=True)
        exact = 2.0 if folder == "enclosure" else None
        tables.append(region_table(title, renders, labels=labels, baseline="baseline", exact=exact,
                                   note="Estimate: the image's mean radiance; variance: the mean "
                                        "per-pixel per-sample variance; cost and efficiency: by "
                                        "measured time; rays/sample: counted."))
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=tables)
    section.extra["baseline"] = BASELINE
    section.extra["floor"] = FLOOR
    section.extra["albedo"] = ALBEDO
    section.extra["choice_by_time"] = by_time = choose(tables, "time")
    section.extra["choice_by_rays"] = by_rays = choose(tables, "rays")
    settings = section.extra["chosen"] = chosen_settings(by_time)
    section.extra["unbiased"] = check = unbiasedness(lab, tables, "baseline")
    section.findings.append(unbiased_finding(check, "the baseline or the exact value"))
    for decision, c in by_time.items():
        parts = [f"{s['label']} ×{s['geomean']:.3g} (worst ×{s['worst']:.3g}"
                 + ("" if s["finite_variance_albedo"] > ALBEDO else
                    f"; variance finite only below albedo {s['finite_variance_albedo']:.2f}") + ")"
                 for n, s in c["candidates"].items() if n != "baseline"]
        r = by_rays[decision]
        section.findings.append(
            f"{decision}: geometric mean of the efficiency ratio to the baseline by time (worst "
            f"scene): " + "; ".join(parts) + f" → chosen **{c['candidates'][c['chosen']]['label']}**"
            f" (by rays: {r['candidates'][r['chosen']]['label']})")

    # the chosen settings together against the baseline, once more on every scene
    combined = []
    for folder, title, scene, depth in scenes:
        extra = {} if depth is None else dict(max_depth=depth)
        variants = {"baseline": dict(integrator="path", **extra, **BASELINE),
                    "chosen": dict(integrator="path", **extra, **settings)}
        renders = render_variants(lab, scene, variants, runs, spp, count_rays=True)
        combined.append(region_table(title, renders, baseline="baseline",
                                     labels={"baseline": "baseline", "chosen": "chosen together"}))
    rs = {t.title: ratio(t.row("chosen"), t.row("baseline"), "time") for t in combined}
    rays = {t.title: ratio(t.row("chosen"), t.row("baseline"), "rays") for t in combined}
    section.extra["combined"] = {"by_time": rs, "by_rays": rays,
                                 "geomean_by_time": float(math.exp(np.mean(np.log(list(rs.values()))))),
                                 "geomean_by_rays": float(math.exp(np.mean(np.log(list(rays.values())))))}
    cm = section.extra["combined"]
    if settings == BASELINE:
        section.findings.append(
            "the chosen settings are the baseline's: the second pass renders the same settings "
            "twice with other seeds, so its per-scene ratios (×"
            f"{min(rs.values()):.3g} to ×{max(rs.values()):.3g} by time) show how far one "
            "scene's ratio strays by noise alone at these sizes")
    section.findings.append(
        f"chosen together ({_describe(settings)}): efficiency ×{cm['geomean_by_time']:.3g} of the "
        f"baseline by time, ×{cm['geomean_by_rays']:.3g} by rays (geometric means); per scene by "
        f"time: " + ", ".join(f"{k} ×{v:.3g}" for k, v in rs.items()))
    _figure(lab.figure_path("survey_ratios.png"), tables, by_time)
    section.figures.append(("survey_ratios.png", "Efficiency ratio to the baseline (Mitsuba's "
                                                 "settings) of every candidate on every scene, by "
                                                 "measured time (log scale); dashed: the ×0.8 "
                                                 "floor of the criterion"))
    return section


def _describe(s: dict) -> str:
    return (f"rr {s['rr']} from depth {s['rr_depth']}, {s['strategy']}, "
            f"light selection {s['light_selection']}")


def _figure(path, tables, choice) -> None:
    plt = pyplot()
    names = [n for items in DECISIONS.values() for n, _, _ in items if n != "baseline"]
    labels = {n: lbl for items in DECISIONS.values() for n, lbl, _ in items}
    fig, ax = plt.subplots(figsize=(11, 4.2))
    width = 0.8 / len(tables)
    for i, t in enumerate(tables):
        vals = [ratio(t.row(n), t.row("baseline"), "time") for n in names]
        ax.bar(np.arange(len(names)) + (i - (len(tables) - 1) / 2) * width, vals, width,
               bottom=0, label=t.title)
    geo = [next(c["candidates"][n]["geomean"] for c in choice.values() if n in c["candidates"])
           for n in names]
    ax.plot(np.arange(len(names)), geo, "k*", ms=12, label="geometric mean")
    ax.set_yscale("log")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(FLOOR, color="k", lw=0.8, ls="--")
    ax.set_xticks(np.arange(len(names)), [labels[n] for n in names], rotation=20, ha="right",
                  fontsize=8)
    ax.set_ylabel("efficiency (by time) / baseline (log scale)")
    ax.legend(fontsize=7, ncol=2)
    save(fig, path)
