"""Point lights given by flux: all lights summed vs one light chosen ∝ Φ vs one chosen uniformly.

n = 32 point lights of flux Φ spread log-uniformly over four decades hang above a
diffuse floor (albedo ρ = 0.5); the quantity is the floor's mean radiance over the unit
square [0, 1]²: a point light of flux Φ has intensity I = Φ/4π (the lecture's Φ/4πr²
formula for the irradiance at distance r, times cos θ), so

    L̄ = (ρ/π) Σᵢ (Φᵢ/4π) Ωᵢ,  Ωᵢ = ∫ cos θ / r² dA = the solid angle of the square seen
    from light i (closed form, inclusion–exclusion of corner rectangles).

Each sample picks a uniform point x of the square, then either sums all n lights (n
light evaluations), or picks one light with probability Φᵢ/ΣΦ or 1/n and divides by
that probability (one evaluation). The cost counted is light evaluations per sample.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table
from .kernel import Technique, measure
from .report import bar_figure, pyplot, save

NAME = "point_lights"
TITLE = "Point lights by flux: sum all vs choose ∝ Φ vs choose uniformly"

ALBEDO = 0.5
COUNT = 32


def lights(count: int = COUNT, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """The fixed problem: positions (n, 3) and fluxes (n,) (independent of the lab seed)."""
    rng = np.random.default_rng(seed)
    pos = np.column_stack([rng.uniform(-0.5, 1.5, count), rng.uniform(-0.5, 1.5, count),
                           rng.uniform(0.3, 2.0, count)])
    flux = 10.0 ** rng.uniform(-2.0, 2.0, count)
    return pos, flux


def square_solid_angle(p: np.ndarray) -> np.ndarray:
    """Solid angle of the unit square [0,1]² (z = 0) seen from points p (n, 3) above it."""
    h = p[:, 2]

    def corner(a, b):
        return np.arctan(a * b / (h * np.sqrt(a * a + b * b + h * h)))
    x0, x1, y0, y1 = -p[:, 0], 1 - p[:, 0], -p[:, 1], 1 - p[:, 1]
    return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)


def exact_mean_radiance(pos, flux) -> float:
    return float(ALBEDO / math.pi * np.sum(flux / (4 * math.pi) * square_solid_angle(pos)))


def _preamble(pos, flux) -> str:
    n = len(flux)
    cdf = np.cumsum(flux) / flux.sum()
    vec = ", ".join(f"vec4({x:.9g}, {y:.9g}, {z:.9g}, {f / (4 * math.pi):.9g})"
                    for (x, y, z), f in zip(pos, flux))
    return f"""\
const int kLightCount = {n};
// xyz: position; w: intensity I = flux / (4 pi)
const vec4 kLights[{n}] = vec4[]({vec});
const float kLightCdf[{n}] = float[]({", ".join(f"{c:.9g}" for c in cdf[:-1])}, 1.0);
const float kAlbedo = {ALBEDO};

// Radiance toward the viewer from the diffuse floor point x (normal +z) lit by light i.
float light_contribution(vec2 x, int i) {{
    vec3 d = kLights[i].xyz - vec3(x, 0.0);
    float r2 = dot(d, d);
    return kAlbedo * kInvPi * kLights[i].w * (d.z * inversesqrt(r2)) / r2;
}}

// Light index with probability flux_i / sum(flux) (linear search of the CDF), and its pmf.
int select_light_by_flux(float u, out float pmf) {{
    int i = 0;
    while (i < kLightCount - 1 && u >= kLightCdf[i]) ++i;
    pmf = kLightCdf[i] - (i > 0 ? kLightCdf[i - 1] : 0.0);
    return i;
}}
"""


def techniques(pos, flux) -> list[Technique]:
    pre = _preamble(pos, flux)
    inc = ("common/constants.glsl",)
    return [
        Technique("sum-all", "vec2 x = lab_uniform2();\n"
                             "for (int i = 0; i < kLightCount; ++i) f += light_contribution(x, i);\n"
                             "lab_work += uint(kLightCount);", inc, pre,
                  label=f"sum all {len(flux)} lights"),
        Technique("by-flux", "vec2 x = lab_uniform2();\nfloat pmf;\n"
                             "int i = select_light_by_flux(lab_uniform(), pmf);\n"
                             "f = light_contribution(x, i) / pmf;\nlab_work += 1u;", inc, pre,
                  label="one light ∝ Φ"),
        Technique("uniform", "vec2 x = lab_uniform2();\n"
                             "int i = min(int(lab_uniform() * float(kLightCount)), kLightCount - 1);\n"
                             "f = light_contribution(x, i) * float(kLightCount);\nlab_work += 1u;",
                  inc, pre, label="one light uniformly"),
    ]


def run(lab) -> Section:
    pos, flux = lights()
    exact = exact_mean_radiance(pos, flux)
    runs, samples = lab.size((16, 1 << 12), (64, 1 << 16))
    table = Table(f"Mean floor radiance under {COUNT} point lights (Φ from 10⁻² to 10²)",
                  measure(lab, techniques(pos, flux), runs, samples, exact,
                          work_unit="light evaluations"))
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=[table])
    base = table.base()
    for r in table.rows[1:]:
        section.findings.append(
            f"{r.title}: variance ×{r.variance / base.variance:.3g} and measured cost "
            f"×{r.cost / base.cost:.3g} of summing all lights ({r.units['light evaluations']:.0f} "
            f"vs {base.units['light evaluations']:.0f} light evaluations): efficiency "
            f"×{r.efficiency / base.efficiency:.3g}; counting light evaluations as the cost "
            f"(what dominates once each needs a shadow ray): efficiency "
            f"×{base.variance * base.units['light evaluations'] / (r.variance * r.units['light evaluations']):.3g}")
    section.findings.append(
        "Without shadow rays a light evaluation costs little beside the sample's fixed cost, "
        "so summing all lights wins on measured time here; by light evaluations, choosing ∝ Φ "
        "is the efficient choice and uniform choice wastes most samples on dim lights.")
    bar_figure(lab.figure_path("point_lights_ratios.png"), table, "Point lights: ratios to summing all")
    _flux_figure(lab.figure_path("point_lights_flux.png"), pos, flux)
    section.figures += [("point_lights_flux.png", "The lights seen from above, area ∝ flux; "
                                                  "the floor square is outlined"),
                        ("point_lights_ratios.png", "Variance, measured cost and efficiency "
                                                    "relative to summing all lights")]
    return section


def _flux_figure(path, pos, flux) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.6, 4))
    sc = ax.scatter(pos[:, 0], pos[:, 1], s=8 + 60 * np.log10(flux / flux.min() * 1.01),
                    c=np.log10(flux), cmap="viridis", edgecolor="k", lw=0.3)
    ax.plot([0, 1, 1, 0, 0], [0, 0, 1, 1, 0], "r-", lw=1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    fig.colorbar(sc, ax=ax, label="log₁₀ flux Φ (W)")
    save(fig, path)
