"""Russian roulette and splitting, on a path-tracing random walk with an exact answer.

The walk stands for a path in a closed scene: at vertex k its throughput is
β_k = ρ_0 ··· ρ_{k−1}, each factor ρ_j = ρ̄ (0.5 + u) a random "BSDF weight" of mean
ρ̄ = 0.75 (between 0.375 and 1.125, so β can grow as f cos/p can). At every vertex a
light sample (a shadow ray) adds L_d · V with V = 1 with probability 0.3 (a partly
occluded light). Up to D = 64 vertices:

    L = Σ_k β_k L_d V_k,   E[L] = L_d · 0.3 · (1 − ρ̄^D) / (1 − ρ̄)   (exact).

Techniques: no roulette; Russian roulette from depth k with Mitsuba's throughput rule
(survive with q = min(β, 0.95), β /= q); fixed survival probabilities q from depth 1;
splitting with n shadow rays per vertex (their mean replaces V); and n independent
branches of the walk after the first vertex. Every variant is unbiased; the cost
counted is rays (continuation rays + shadow rays), and the measured device time is
reported too. Efficiency = 1/(variance · cost) picks the best setting on each curve.
"""
from __future__ import annotations

import math

from .core import Section, Table
from .kernel import Technique, measure
from .report import bar_figure, pyplot, save

NAME = "roulette"
TITLE = "Russian roulette and splitting (a path-tracing random walk)"

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


def run(lab) -> Section:
    runs, samples = lab.size((32, 1 << 12), (64, 1 << 15))
    table = Table(f"Walk of up to {DEPTH} vertices: E[L] = {EXACT:.6g}",
                  measure(lab, techniques(), runs, samples, EXACT, work_unit="rays"))
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=[table])
    base = table.base()
    by_rays = {r.technique: 1.0 / (r.variance * r.units["rays"]) for r in table.rows}
    best_rays = max(by_rays, key=by_rays.get)
    best_time = max((r for r in table.rows), key=lambda r: r.efficiency)
    section.extra["efficiency_by_rays"] = by_rays
    section.findings += [
        f"no roulette traces {base.units['rays']:.3g} rays per sample; throughput RR from depth 1 "
        f"{table.row('rr-depth-1').units['rays']:.3g}",
        f"best by rays: {table.row(best_rays).title} (×{by_rays[best_rays] / by_rays['none']:.3g} "
        f"the efficiency of no roulette); best by measured time: {best_time.title} "
        f"(×{best_time.efficiency / base.efficiency:.3g})",
        "measured time falls far less than the ray count: llvmpipe runs 8 walks in lockstep "
        "(one SIMD vector), so a vector lasts as long as its longest walk, and roulette's "
        "divergent exits cost what the fixed-length walk, free of divergence, does not"]
    bar_figure(lab.figure_path("roulette_ratios.png"), table, "Russian roulette and splitting vs none")
    _curve_figure(lab.figure_path("roulette_efficiency.png"), table, by_rays)
    section.figures += [("roulette_efficiency.png", "Efficiency (1/(variance · rays)) and variance "
                                                    "of each setting, relative to no roulette"),
                        ("roulette_ratios.png", "Variance, measured cost and efficiency relative "
                                                "to no roulette")]
    return section


def _curve_figure(path, table, by_rays) -> None:
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
        ax.legend(fontsize=7)
    save(fig, path)
