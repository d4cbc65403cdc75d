"""Russian roulette and splitting in the renderer's path tracer, and on a random walk with an exact answer.

The renderer's `path` integrator renders the same scene with each setting of its
roulette rule and splitting options (`--rr`, `--rr-depth`, `--light-samples`,
`--split`): no roulette; Mitsuba's throughput rule (survive with q = min(max(β) η², 0.95),
β /= q) from depth 1, 3, 5 (the default) or 8; a fixed survival probability q from the
default depth 5; 2 or 4 light samples (shadow rays) at every vertex; 2 or 4 BSDF branches
at the first vertex (each carrying 1/n of the throughput). Scenes: the Cornell box with
unbounded depth (paths end by roulette, by leaving through the open front, or at the
renderer's cap of 256 segments) and the closed emissive enclosure (albedo 0.5, emission 1;
depth limited to 32 segments, so that its exact radiance is 2 (1 − 0.5³²) in every pixel).
Every setting renders the same view from independent seeds with the independent sampler;
the estimate is the image's mean radiance, its variance the mean per-pixel per-sample
variance; the cost is counted exactly in rays traced (camera, continuation and shadow
rays, from the renderer's ray counter) and measured in device time (the timings share a
loaded machine: noisy). Efficiency = 1/(variance · cost) by rays and by time; each
setting's estimate is compared with the exact value (enclosure) or with the estimate
without roulette (Cornell box), Šidák-corrected over all of them.

The second table is a GLSL model of the same choices with an exact answer (no renderer):
a random walk whose throughput is a product of random "BSDF weights" of mean 0.75, with
a light sample at each vertex that sees the light with probability 0.3.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table
from .kernel import Technique, measure
from .renders import load_scene, region_table, render_variants
from .report import bar_figure, pyplot, save

NAME = "roulette"
TITLE = "Russian roulette and splitting (the renderer's path tracer)"

# (name, family, setting value, label, overrides of the path integrator's settings)
FAMILIES = {
    "throughput RR from depth k": [(f"rr-depth-{d}", d, dict(rr_depth=d)) for d in (1, 3, 5, 8)],
    "fixed survival q (from depth 5)": [(f"rr-fixed-{q}", q, dict(rr=f"fixed:{q}"))
                                        for q in (0.5, 0.7, 0.9)],
    "light samples per vertex": [(f"light-samples-{n}", n, dict(light_samples=n)) for n in (2, 4)],
    "BSDF branches at the first vertex": [(f"split-{n}", n, dict(split=n)) for n in (2, 4)],
}
DEFAULT = "rr-depth-5"   # the renderer's default: throughput rule from depth 5, no splitting

# -- the random-walk model: L = sum_k beta_k L_d V_k, E[L] = L_d 0.3 (1 - 0.75^D) / (1 - 0.75)
RHO, P_VIS, LD, DEPTH = 0.75, 0.3, 1.0, 64
EXACT = LD * P_VIS * (1 - RHO ** DEPTH) / (1 - RHO)

WALK = f"""\
const float kMeanAlbedo = {RHO};
const float kVisible = {P_VIS};
const float kLd = {LD};
const int kMaxVertices = {DEPTH};

// Survival probability at vertex k (k = 1, 2, ...) for throughput beta; 1 = no roulette.
float survival(int k, float beta);

// Light sample(s) at one vertex: the mean of n shadow rays' visibility times L_d.
float direct_light(int n) {{
    float v = 0.0;
    for (int i = 0; i < n; ++i) v += lab_uniform() < kVisible ? 1.0 : 0.0;
    lab_work += uint(n);
    return kLd * v / float(n);
}}

// The walk from vertex `first` with throughput beta; n shadow rays per vertex.
float walk(int first, float beta, int n) {{
    float L = 0.0;
    for (int k = first; k < kMaxVertices; ++k) {{
        L += beta * direct_light(n);
        if (k + 1 == kMaxVertices) break;
        beta *= kMeanAlbedo * (0.5 + lab_uniform());
        float q = survival(k + 1, beta);
        if (q < 1.0) {{
            if (lab_uniform() >= q) break;
            beta /= q;
        }}
        lab_work += 1u;   // the continuation ray
    }}
    return L;
}}
"""


def _technique(name: str, label: str, survival: str, body: str = "f = walk(0, 1.0, 1);") -> Technique:
    return Technique(name, body, (), WALK + f"float survival(int k, float beta) {{ {survival} }}\n",
                     label=label)


def techniques() -> list[Technique]:
    mitsuba = "return k >= {d} ? min(beta, 0.95) : 1.0;"
    techs = [_technique("none", "no roulette", "return 1.0;")]
    techs += [_technique(f"rr-depth-{d}", f"throughput RR from depth {d}", mitsuba.format(d=d))
              for d in (1, 3, 5)]
    techs += [_technique(f"rr-fixed-{q}", f"fixed q = {q}", f"return {q};") for q in (0.5, 0.7, 0.9)]
    techs += [_technique(f"split-light-{n}", f"{n} shadow rays/vertex, RR from 1",
                         mitsuba.format(d=1), f"f = walk(0, 1.0, {n});") for n in (2, 4, 8)]
    branch = ("float L0 = direct_light(1);\nfloat sum = 0.0;\n"
              "for (int b = 0; b < {n}; ++b) {{\n"
              "    float beta = kMeanAlbedo * (0.5 + lab_uniform());\n"
              "    lab_work += 1u;\n"
              "    sum += walk(1, beta, 1);\n"
              "}}\nf = L0 + sum / {n}.0;")
    techs += [_technique(f"split-branch-{n}", f"{n} branches at vertex 1, RR from 1",
                         mitsuba.format(d=1), branch.format(n=n)) for n in (2, 4)]
    return techs



def _label(name, family, value) -> str:
    if name == DEFAULT:
        return "throughput RR from depth 5 (default)"
    if family.startswith("throughput"):
        return f"throughput RR from depth {value}"
    if family.startswith("fixed"):
        return f"fixed q = {value} from depth 5"
    if family.startswith("light"):
        return f"{value} light samples/vertex"
    return f"{value} BSDF branches at vertex 1"


def variants() -> tuple[dict[str, dict], dict[str, str]]:
    """Every setting's overrides (no roulette first: the baseline) and its label."""
    out, labels = {"off": dict(rr="off")}, {"off": "no roulette"}
    for family, settings in FAMILIES.items():
        for name, value, overrides in settings:
            out[name] = overrides
            labels[name] = _label(name, family, value)
    return out, labels


def _scenes(lab):
    """(scene name, table title, film size, runs, spp, max depth, exact mean or None)."""
    depth = 32
    return [("cornell-box", "Cornell box, unbounded depth", lab.size((32, 32), (128, 128)),
             lab.size(16, 16), lab.size(8, 32), -1, None),
            ("enclosure", f"Closed enclosure, depth {depth}: exact radiance 2 (1 − 0.5^{depth})",
             lab.size((16, 16), (48, 48)), lab.size(12, 16), lab.size(16, 64), depth,
             2.0 * (1.0 - 0.5 ** depth))]


def efficiency_by_rays(row) -> float:
    v = row.variance * row.units["rays"]
    return 1.0 / v if v > 0 else math.inf


def unbiasedness(lab, tables: list[Table], reference: str = "off") -> dict:
    """Each row's t against the exact value (or the ``reference`` row: no roulette), Šidák
    over them all."""
    tests = []
    for t in tables:
        ref = t.row(reference)
        for r in t.rows:
            if r.exact is not None:
                sigma = math.hypot(r.stderr, r.exact_stderr)
                tests.append((t.title, r.technique, (r.mean - r.exact) / sigma))
            elif r is not ref:
                tests.append((t.title, r.technique, (r.mean - ref.mean) / math.hypot(r.stderr, ref.stderr)))
    runs = min(r.runs for t in tables for r in t.rows)
    threshold = lab.threshold(len(tests), runs)
    worst = max(tests, key=lambda x: abs(x[2]))
    return {"tests": len(tests), "threshold": threshold, "max_abs_t": abs(worst[2]),
            "worst": f"{worst[0]}: {worst[1]}", "all_within": all(abs(x[2]) <= threshold for x in tests),
            "t": {f"{a}: {b}": c for a, b, c in tests}}


def unbiased_finding(check: dict, against: str) -> str:
    """The report's line for :func:`unbiasedness`."""
    if check["all_within"]:
        return (f"unbiased: all {check['tests']} settings agree with {against} (largest |t| "
                f"{check['max_abs_t']:.2f}, {check['worst']}; Šidák threshold "
                f"{check['threshold']:.2f})")
    return (f"NOT within the Šidák threshold {check['threshold']:.2f}: {check['worst']} "
            f"(|t| {check['max_abs_t']:.2f})")


def best(table: Table) -> dict:
    """The most efficient setting by rays (exact cost: its uncertainty is the variance's) and
    by time, and the settings within two standard errors of the best by rays."""
    by_rays = {r.technique: efficiency_by_rays(r) for r in table.rows}
    top = max(by_rays, key=by_rays.get)
    top_row = table.row(top)
    close = [r.technique for r in table.rows if r.technique != top and
             math.log(by_rays[top] / by_rays[r.technique]) <=
             2.0 * math.hypot(r.variance_rel_se, top_row.variance_rel_se)]
    by_time = max(table.rows, key=lambda r: r.efficiency).technique
    base = table.row("off")
    return {"by_rays": top, "by_time": by_time, "within_2se_of_best_by_rays": close,
            "efficiency_by_rays": by_rays,
            "ratio_by_rays": {k: v / by_rays["off"] for k, v in by_rays.items()},
            "ratio_by_time": {r.technique: r.efficiency / base.efficiency for r in table.rows}}


def run(lab) -> Section:
    settings, labels = variants()
    tables = []
    for scene_name, title, (w, h), runs, spp, depth, exact in _scenes(lab):
        scene = load_scene(scene_name, w, h)
        chosen = {name: dict(integrator="path", max_depth=depth, **o) for name, o in settings.items()}
        renders = render_variants(lab, scene, chosen, runs, spp, count_rays=True)
        tables.append(region_table(title, renders, labels=labels, baseline="off", exact=exact,
                                   note="Estimate: the image's mean radiance; variance: the mean "
                                        "per-pixel per-sample variance; rays/sample: camera, "
                                        "continuation and shadow rays counted by the renderer; cost, "
                                        "efficiency and their ratios: by measured time (by "
                                        "rays: the findings and the figure)."))
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=tables)
    section.extra["unbiased"] = check = unbiasedness(lab, tables)
    section.findings.append(unbiased_finding(check, "the exact value or the render without roulette"))
    section.extra["best"] = {}
    for t in tables:
        b = section.extra["best"][t.title] = best(t)
        off, rr = t.row("off"), t.row(DEFAULT)
        close = ", ".join(t.row(n).title for n in b["within_2se_of_best_by_rays"]) or "none"
        section.findings += [
            f"{t.title}: no roulette traces {off.units['rays']:.3g} rays per sample, the default "
            f"{rr.units['rays']:.3g}, at ×{rr.variance / off.variance:.3g} the variance: "
            f"efficiency ×{b['ratio_by_rays'][DEFAULT]:.3g} by rays, ×{b['ratio_by_time'][DEFAULT]:.3g} "
            f"by time",
            f"{t.title}: best by rays **{t.row(b['by_rays']).title}** (×{b['ratio_by_rays'][b['by_rays']]:.3g} "
            f"the efficiency of no roulette; within two standard errors of it: {close}); best by "
            f"measured time {t.row(b['by_time']).title} (×{b['ratio_by_time'][b['by_time']]:.3g})"]

    # the random-walk model: the same choices with an exact answer, and no renderer
    walk_runs, walk_samples = lab.size((32, 1 << 12), (64, 1 << 15))
    walk = Table(f"Random-walk model of up to {DEPTH} vertices: E[L] = {EXACT:.6g}",
                 measure(lab, techniques(), walk_runs, walk_samples, EXACT, work_unit="rays"))
    tables.append(walk)
    walk_rays = {r.technique: efficiency_by_rays(r) for r in walk.rows}
    section.extra["efficiency_by_rays"] = walk_rays
    top = max(walk_rays, key=walk_rays.get)
    section.findings.append(
        f"random-walk model: best by rays {walk.row(top).title} (×{walk_rays[top] / walk_rays['none']:.3g} "
        f"the efficiency of no roulette); its measured time falls far less than its ray count "
        f"(llvmpipe runs 8 walks in lockstep, and a vector lasts as long as its longest walk)")

    _curve_figure(lab.figure_path("roulette_efficiency.png"), tables[:-1], section.extra["best"])
    bar_figure(lab.figure_path("roulette_ratios.png"), tables[0],
               f"{tables[0].title}: settings vs no roulette")
    _walk_figure(lab.figure_path("roulette_walk.png"), walk, walk_rays)
    section.figures += [
        ("roulette_efficiency.png", "Efficiency by rays (1/(variance · rays), left) and by measured "
                                    "time (right) of every setting relative to no roulette, per "
                                    "scene; error bars: two standard errors (from the variance); "
                                    "★ the best by rays"),
        ("roulette_ratios.png", f"{tables[0].title}: variance, measured cost and efficiency of "
                                f"each setting relative to no roulette"),
        ("roulette_walk.png", "The random-walk model: efficiency by rays and by time of each "
                              "setting relative to no roulette")]
    return section


def _curve_figure(path, tables, bests) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(len(tables), 2, figsize=(11, 3.4 * len(tables)), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for row_axes, t in zip(axes, tables):
        b = bests[t.title]
        off = t.row("off")
        for ax, key, label in ((row_axes[0], "ratio_by_rays", "efficiency by rays / no roulette"),
                               (row_axes[1], "ratio_by_time", "efficiency by time / no roulette")):
            x0 = 0
            ticks, names = [], []
            for c, (family, items) in enumerate(FAMILIES.items()):
                xs = list(range(x0, x0 + len(items)))
                ys = [b[key][n] for n, _, _ in items]
                rel = [math.hypot(t.row(n).variance_rel_se, off.variance_rel_se) for n, _, _ in items]
                ax.errorbar(xs, ys, yerr=[2 * y * e for y, e in zip(ys, rel)], fmt="o-",
                            color=colours[c], label=family, capsize=2)
                for x, (n, value, _) in zip(xs, items):
                    ticks.append(x)
                    names.append(f"{value:g}" + (" (default)" if n == DEFAULT else ""))
                    if n == b["by_rays"] and key == "ratio_by_rays":
                        ax.plot([x], [b[key][n]], "*", ms=16, color="gold", mec="k", zorder=5)
                x0 += len(items) + 1
            ax.axhline(1.0, color="k", lw=0.8, ls=":")
            ax.set_xticks(ticks, names, rotation=45, fontsize=7)
            ax.set_xlabel("setting (start depth k / survival q / light samples n / branches n)")
            ax.set_ylabel(label)
            ax.set_title(t.title, fontsize=9)
            ax.legend(fontsize=7)
    save(fig, path)


def _walk_figure(path, table, by_rays) -> None:
    plt = pyplot()
    base = table.base()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    groups = {"throughput RR, start depth": [f"rr-depth-{d}" for d in (1, 3, 5)],
              "fixed survival q": [f"rr-fixed-{q}" for q in (0.5, 0.7, 0.9)],
              "shadow rays per vertex": [f"split-light-{n}" for n in (2, 4, 8)],
              "branches at vertex 1": [f"split-branch-{n}" for n in (2, 4)]}
    xs = {"throughput RR, start depth": [1, 3, 5], "fixed survival q": [0.5, 0.7, 0.9],
          "shadow rays per vertex": [2, 4, 8], "branches at vertex 1": [2, 4]}
    for ax, key, label in ((a, "eff", "efficiency by rays / no roulette"),
                           (b, "time", "efficiency by time / no roulette")):
        for g, names in groups.items():
            if key == "eff":
                ys = [by_rays[n] / by_rays["none"] for n in names]
            else:
                ys = [table.row(n).efficiency / base.efficiency for n in names]
            ax.plot(range(len(names)), ys, "o-", label=g)
            for i, (x, y) in enumerate(zip(xs[g], ys)):
                ax.annotate(f"{x:g}", (i, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_xlabel("setting within each family (its value is written at each point)")
        ax.set_xticks([0, 1, 2], ["1st", "2nd", "3rd"])
        ax.set_ylabel(label)
        ax.set_title("random-walk model", fontsize=9)
        ax.legend(fontsize=7)
    save(fig, path)
