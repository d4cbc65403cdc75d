"""Expected values vs rejection: hit-or-miss against the expected-value estimator.

Hit-or-miss throws points into a box around the graph of f and counts those below it;
the expected-value estimator integrates the indicator over y analytically and keeps
f(x) itself. Both are unbiased; the second never has more variance (Rao–Blackwell:
Var[f(X)] = Var[E(hit | X)] ≤ Var[hit]).

- ∫₀¹ sin(πx) dx = 2/π: hit-or-miss 1[y < sin πx] over the unit square vs sin(πx).
- π as four quarter discs: 4·1[x² + y² ≤ 1] vs 4√(1 − x²).
- ∫ over the unit disk of r² dA = π/2 with uniform points of the disk by rejection from
  the square (sampling/disk_rejection.glsl: 4/π ≈ 1.27 trials, 2.55 uniforms per point)
  vs the concentric warp (2 uniforms): the same distribution, so the same variance;
  the cost per sample includes the rejected trials.
"""
from __future__ import annotations

import math

from .core import Section, Table, ratio_findings
from .kernel import Technique, measure
from .report import bar_figure

NAME = "rejection"
TITLE = "Expected values vs rejection"

REJECTION_UNIFORM = """\
vec2 disk_rejection_uniform(uint trial) {
    return lab_uniform2();
}
"""


def techniques_sine() -> list[Technique]:
    inc = ("common/constants.glsl",)
    return [Technique("hit-or-miss", "vec2 u = lab_uniform2();\nf = u.y < sin(kPi * u.x) ? 1.0 : 0.0;",
                      inc, label="hit-or-miss 1[y < f(x)]"),
            Technique("expected-value", "f = sin(kPi * lab_uniform());", inc,
                      label="expected value f(x)")]


def techniques_pi() -> list[Technique]:
    return [Technique("hit-or-miss", "vec2 u = lab_uniform2();\nf = dot(u, u) <= 1.0 ? 4.0 : 0.0;",
                      label="hit-or-miss 4·1[x²+y² ≤ 1]"),
            Technique("expected-value", "float x = lab_uniform();\nf = 4.0 * sqrt(1.0 - x * x);",
                      label="expected value 4√(1−x²)")]


def techniques_disk() -> list[Technique]:
    inc = ("sampling/disk_rejection.glsl",)
    return [Technique("rejection", "uint trials;\nvec2 p = sample_uniform_disk_rejection(trials);\n"
                                   "f = dot(p, p) / uniform_disk_pdf();", inc, REJECTION_UNIFORM,
                      label="rejection from the square"),
            Technique("concentric", "vec2 p = sample_uniform_disk_concentric(lab_uniform2());\n"
                                    "f = dot(p, p) / uniform_disk_pdf();", ("sampling/disk.glsl",),
                      label="concentric warp")]


def run(lab) -> Section:
    runs, samples = lab.size((16, 1 << 12), (64, 1 << 16))
    tables = [Table("∫₀¹ sin(πx) dx = 2/π", measure(lab, techniques_sine(), runs, samples, 2 / math.pi)),
              Table("π = 4 ∫∫ 1[x²+y² ≤ 1]", measure(lab, techniques_pi(), runs, samples, math.pi)),
              Table("∫_disk r² dA = π/2 with uniform points of the disk",
                    measure(lab, techniques_disk(), runs, samples, math.pi / 2))]
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=tables)
    for i, t in enumerate(tables):
        name = f"rejection_{i}.png"
        bar_figure(lab.figure_path(name), t, t.title)
        section.figures.append((name, f"{t.title}: variance, cost and efficiency relative to "
                                      f"{t.base().title}"))
        section.findings += ratio_findings(t, f"{t.title}: ")
    return section
