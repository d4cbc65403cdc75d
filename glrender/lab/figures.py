"""The lecture's sampling figures, measured: power function, four disk methods, the sphere.

- Power function p(x) = 4x³ (n = 3) by inversion x = u^(1/4) and as the largest of
  n + 1 = 4 uniforms: the same distribution (so the same variance) at different costs;
  the integral ∫₀¹ (x³ + x⁴) dx = 9/20 is estimated by f/p = (1 + x)/4.
- The four disk methods of the lecture on ∫_disk r² dA = π/2: polar with r = u (not
  uniform: its density 1/(2πr) enters the estimator), polar with r = √u, Shirley's
  concentric map and rejection from the square. disks.png shows the warps of a jittered
  grid: the concentric map keeps strata compact, the polar maps stretch them.
- The sphere: ∫_S² (1 + z)² dω = 16π/3 with directions from rejection in the cube
  [−1, 1]³ (accept |p| ≤ 1, then normalize: π/6 of the trials survive, 3 uniforms each)
  vs the direct warp z = 1 − 2u₁, φ = 2πu₂ (sampling/sphere.glsl).
"""
from __future__ import annotations

import math

from .core import Section, Table, ratio_findings
from .kernel import Technique, measure
from .report import bar_figure

NAME = "figures"
TITLE = "The lecture's sampling figures: power function, disk, sphere"

SPHERE_REJECTION = """\
// Uniform direction by rejection from the cube [-1,1]^3 (at most 64 trials: a miss of all
// of them, probability (1 - pi/6)^64 ~ 1e-21, falls back to the last trial's axis).
vec3 sample_uniform_sphere_rejection() {
    vec3 p = vec3(0.0, 0.0, 1.0);
    for (int trial = 0; trial < 64; ++trial) {
        vec3 q = 2.0 * vec3(lab_uniform2(), lab_uniform()) - 1.0;
        float r2 = dot(q, q);
        if (r2 <= 1.0 && r2 > 1e-12) return q * inversesqrt(r2);
        p = q;
    }
    return vec3(0.0, 0.0, 1.0);
}
"""


def techniques_power() -> list[Technique]:
    inc = ("sampling/power.glsl",)
    est = "f = (1.0 + x) * 0.25;"
    return [Technique("inversion", f"float x = sample_power(lab_uniform(), 3.0);\n{est}", inc,
                      label="inversion x = u^(1/4)"),
            Technique("max-of-4", "vec4 u = vec4(lab_uniform2(), lab_uniform2());\n"
                                  f"float x = sample_power_max(u, 3);\n{est}", inc,
                      label="max of 4 uniforms")]


def techniques_disk() -> list[Technique]:
    est = "f = pdf > 0.0 ? dot(p, p) / pdf : 0.0;"
    inc = ("sampling/disk.glsl",)
    return [
        Technique("polar-linear", "vec2 p = sample_disk_linear_radius(lab_uniform2());\n"
                                  f"float pdf = disk_linear_radius_pdf(p);\n{est}", inc,
                  label="polar r = u (density 1/2πr)"),
        Technique("polar-sqrt", "vec2 p = sample_uniform_disk_polar(lab_uniform2());\n"
                                f"float pdf = uniform_disk_pdf();\n{est}", inc,
                  label="polar r = √u"),
        Technique("concentric", "vec2 p = sample_uniform_disk_concentric(lab_uniform2());\n"
                                f"float pdf = uniform_disk_pdf();\n{est}", inc,
                  label="concentric (Shirley)"),
        Technique("rejection", "uint trials;\nvec2 p = sample_uniform_disk_rejection(trials);\n"
                               f"float pdf = uniform_disk_pdf();\n{est}",
                  ("sampling/disk_rejection.glsl",),
                  "vec2 disk_rejection_uniform(uint trial) { return lab_uniform2(); }\n",
                  label="rejection from the square"),
    ]


def techniques_sphere() -> list[Technique]:
    inc = ("sampling/sphere.glsl",)
    est = "f = (1.0 + w.z) * (1.0 + w.z) / uniform_sphere_pdf();"
    return [Technique("warp", f"vec3 w = sample_uniform_sphere(lab_uniform2());\n{est}", inc,
                      label="direct warp"),
            Technique("cube-rejection", f"vec3 w = sample_uniform_sphere_rejection();\n{est}", inc,
                      SPHERE_REJECTION, label="rejection from the cube")]


def run(lab) -> Section:
    from ..sampling.plots import disks_figure

    runs, samples = lab.size((16, 1 << 12), (64, 1 << 16))
    tables = [Table("Power function p = 4x³: ∫₀¹ (x³ + x⁴) dx = 9/20",
                    measure(lab, techniques_power(), runs, samples, 0.45)),
              Table("Four disk methods: ∫_disk r² dA = π/2",
                    measure(lab, techniques_disk(), runs, samples, math.pi / 2), baseline="polar-sqrt"),
              Table("Sphere: ∫ (1 + z)² dω = 16π/3",
                    measure(lab, techniques_sphere(), runs, samples, 16 * math.pi / 3))]
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=tables)
    disks_figure(lab.seed).save(lab.figure_path("disks.png"))
    section.figures.append(("disks.png", "The four disk warps: independent points (top) and a "
                                         "jittered 16×16 grid with its strata (bottom); colour "
                                         "follows u (hue u₁, lightness u₂)"))
    for i, t in enumerate(tables):
        name = f"figures_{i}.png"
        bar_figure(lab.figure_path(name), t, t.title)
        section.figures.append((name, f"{t.title}: ratios to {t.base().title}"))
        section.findings += ratio_findings(t, f"{t.title.split(':')[0]}: ")
    return section
