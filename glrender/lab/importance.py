"""Importance sampling: uniform vs a reasonable pdf vs p ∝ f, in 1D and 2D.

1D: I = ∫_0^1 sin(πx) dx = 2/π, with x uniform, x from the tent pdf 4 min(x, 1 − x)
(by inversion), and x from p = (π/2) sin(πx) ∝ f (x = acos(1 − 2u)/π): f/p = 2/π for
every sample, the lecture's "zero-variance biasing".

2D (directions): I = ∫_H² cos⁸θ dω = 2π/9, with directions from the uniform hemisphere,
the cosine-weighted hemisphere (sampling/hemisphere.glsl) and the Phong lobe of
exponent 8 (sampling/phong.glsl), which is p ∝ f.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table, ratio_findings
from .kernel import Technique, measure
from .report import bar_figure, pyplot, save

NAME = "importance"
TITLE = "Importance sampling"

EXACT_1D = 2.0 / math.pi
PHONG_N = 8.0
EXACT_2D = 2.0 * math.pi / (PHONG_N + 1.0)

_TENT = """\
// Tent density 4 min(x, 1 - x) on [0, 1] by inversion of its CDF.
float sample_tent(float u) {
    return u < 0.5 ? sqrt(0.5 * u) : 1.0 - sqrt(0.5 * (1.0 - u));
}
float tent_pdf(float x) {
    return 4.0 * min(x, 1.0 - x);
}
"""

_SINE = """\
// Density (pi / 2) sin(pi x) on [0, 1] by inversion: P(x) = (1 - cos(pi x)) / 2.
float sample_sine(float u) {
    return acos(1.0 - 2.0 * u) * kInvPi;
}
float sine_pdf(float x) {
    return 0.5 * kPi * sin(kPi * x);
}
"""


def techniques_1d() -> list[Technique]:
    inc = ("common/constants.glsl",)
    return [
        Technique("uniform", "float x = lab_uniform();\nf = sin(kPi * x);", inc,
                  label="uniform p = 1"),
        Technique("tent", "float x = sample_tent(lab_uniform());\n"
                          "float p = tent_pdf(x);\nf = p > 0.0 ? sin(kPi * x) / p : 0.0;",
                  inc, _TENT, label="tent p = 4 min(x, 1−x)"),
        Technique("proportional", "float x = sample_sine(lab_uniform());\n"
                                  "float p = sine_pdf(x);\nf = p > 0.0 ? sin(kPi * x) / p : 0.0;",
                  inc, _SINE, label="p ∝ f = (π/2) sin πx"),
    ]


def techniques_2d() -> list[Technique]:
    n = f"{PHONG_N:.1f}"
    return [
        Technique("uniform-hemisphere",
                  "vec3 w = sample_uniform_hemisphere(lab_uniform2());\n"
                  f"f = pow(w.z, {n}) / uniform_hemisphere_pdf();",
                  ("sampling/hemisphere.glsl",), label="uniform hemisphere"),
        Technique("cosine-hemisphere",
                  "vec3 w = sample_cosine_hemisphere(lab_uniform2());\n"
                  "float p = cosine_hemisphere_pdf(w.z);\n"
                  f"f = p > 0.0 ? pow(w.z, {n}) / p : 0.0;",
                  ("sampling/hemisphere.glsl",), label="cosine hemisphere"),
        Technique("phong-lobe",
                  f"vec3 w = sample_phong_lobe(lab_uniform2(), {n});\n"
                  f"float p = phong_lobe_pdf(w.z, {n});\n"
                  f"f = p > 0.0 ? pow(w.z, {n}) / p : 0.0;",
                  ("sampling/phong.glsl",), label=f"Phong lobe n = {PHONG_N:g} (p ∝ f)"),
    ]


def run(lab) -> Section:
    runs, samples = lab.size((16, 1 << 12), (64, 1 << 16))
    t1 = Table("1D: ∫₀¹ sin(πx) dx = 2/π",
               measure(lab, techniques_1d(), runs, samples, EXACT_1D))
    t2 = Table(f"2D: ∫ cos^{PHONG_N:g}θ dω over the hemisphere = 2π/{PHONG_N + 1:g}",
               measure(lab, techniques_2d(), runs, samples, EXACT_2D))
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=[t1, t2])
    _pdf_figure(lab.figure_path("importance_1d.png"))
    bar_figure(lab.figure_path("importance_ratios.png"), t1, "1D importance sampling vs uniform")
    section.figures += [("importance_1d.png",
                         "The 1D integrand sin(πx) and the three densities; the estimator f/p "
                         "of each (right): constant for p ∝ f."),
                        ("importance_ratios.png",
                         "Variance, cost and efficiency relative to uniform sampling (1D)")]
    for t in (t1, t2):
        section.findings += ratio_findings(t, f"{t.title.split(':')[0]}: ")
    return section


def _pdf_figure(path) -> None:
    plt = pyplot()
    x = np.linspace(1e-3, 1 - 1e-3, 400)
    f = np.sin(np.pi * x)
    pdfs = {"uniform p = 1": np.ones_like(x), "tent p = 4 min(x, 1−x)": 4 * np.minimum(x, 1 - x),
            "p ∝ f": 0.5 * np.pi * f}
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.2))
    a.plot(x, f, "k", lw=2, label="f(x) = sin πx")
    for name, p in pdfs.items():
        a.plot(x, p, label=name)
        b.plot(x, f / p, label=name)
    a.set_xlabel("x")
    a.set_ylabel("f(x), p(x)")
    a.set_title("integrand and sampling densities")
    a.legend(fontsize=7)
    b.axhline(EXACT_1D, color="k", ls=":", lw=1, label="I = 2/π")
    b.set_ylim(0, 2.0)
    b.set_xlabel("x")
    b.set_ylabel("f(x) / p(x)")
    b.set_title("the estimator's value at x")
    b.legend(fontsize=7)
    save(fig, path)
