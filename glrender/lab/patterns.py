"""Sampling patterns: independent, stratified, Latin hypercube, Sobol', antithetic, control variate.

Three integrands over [0, 1)²:

- *smooth, monotone*: ∫∫ e^(x+y) = (e − 1)²;
- *irradiance, unoccluded*: a unit square light (radiance 1) at height 1 above a point,
  parallel to its surface: E = ∫ cos θ cos θ' / r² dA = ∫ 1/r⁴ dA, smooth;
- *irradiance, occluded*: the same with a half-plane occluder at height 0.5 that hides
  the light where x + 0.6 y < 0.1: a discontinuous integrand (a slanted shadow edge).

The exact irradiances come from the closed-form x integral of 1/(x² + a²)² and
Gauss–Legendre quadrature in y. Patterns: independent uniforms; jittered strata
(sampling/stratified.glsl, √N × √N); Latin hypercube (a hashed permutation of the N
strata per axis); Owen-scrambled Sobol' (sampling/sobol.glsl); antithetic pairs (u,
1 − u); and a control variate with independent uniforms (e^(x+y) − c (x + y − 1) with
the optimal c = 6(e − 1)(3 − e); for the light, 1/r⁴ − (1 − 2ρ² − 2/3) with ρ² = x² + y²,
its second-order Taylor expansion). Each pattern is one randomization of N points per
run, so the variance per sample is N × Var(run estimate), and RMSE against the exact
value is plotted against N with the fitted slope of log RMSE on log N.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table
from .kernel import Technique, measure
from .report import pyplot, save

NAME = "patterns"
TITLE = "Sampling patterns: stratified, Latin hypercube, Sobol', antithetic, control variates"

E1 = math.e - 1.0
CV_SMOOTH = 6.0 * E1 * (3.0 - math.e)    # Cov(e^(x+y), x+y) / Var(x+y)


def _row_integral(a2: np.ndarray, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
    """∫_{x0}^{x1} dx / (x² + a²)² in closed form."""
    a = np.sqrt(a2)

    def prim(x):
        return x / (2 * a2 * (x * x + a2)) + np.arctan(x / a) / (2 * a2 * a)
    return prim(x1) - prim(x0)


def exact_irradiance(occluded: bool) -> float:
    """Irradiance at the origin from the square light [−½, ½]² at height 1 (float64)."""
    t, w = np.polynomial.legendre.leggauss(64)
    y = 0.5 * t
    lo = np.maximum(-0.5, 0.1 - 0.6 * y) if occluded else np.full_like(y, -0.5)
    return float(0.5 * np.sum(w * _row_integral(1.0 + y * y, lo, np.full_like(y, 0.5))))


INTEGRANDS = {
    "smooth": ("smooth monotone e^(x+y)", E1 * E1, """\
float lab_f(vec2 u) { return exp(u.x + u.y); }
float lab_control(vec2 u) { return u.x + u.y - 1.0; }   // integral 0
const float kControlWeight = %r;
""" % CV_SMOOTH),
    "light": ("irradiance, unoccluded (smooth)", exact_irradiance(False), """\
// Square light [-1/2, 1/2]^2 at height 1 facing down, radiance 1, seen from the origin
// (normal +z): cos(theta) = cos(theta') = 1 / r, so the integrand is 1 / r^4.
float lab_f(vec2 u) {
    vec3 p = vec3(u - 0.5, 1.0);
    float r2 = dot(p, p);
    return 1.0 / (r2 * r2);
}
float lab_control(vec2 u) { vec2 q = u - 0.5; return 1.0 - 2.0 * dot(q, q) - 2.0 / 3.0; }
const float kControlWeight = 1.0;
"""),
    "occluded": ("irradiance, occluded (discontinuous)", exact_irradiance(True), """\
// The same light behind a half-plane occluder at z = 0.5 that covers x + 0.6 y < 0.05:
// the segment from the origin to the light point p crosses z = 0.5 at p / 2.
float lab_f(vec2 u) {
    vec3 p = vec3(u - 0.5, 1.0);
    vec3 q = 0.5 * p;
    if (q.x + 0.6 * q.y < 0.05) return 0.0;
    float r2 = dot(p, p);
    return 1.0 / (r2 * r2);
}
float lab_control(vec2 u) { vec2 q = u - 0.5; return 1.0 - 2.0 * dot(q, q) - 2.0 / 3.0; }
const float kControlWeight = 1.0;
"""),
}

SEEDS = """\
uvec3 lab_dim_seeds(uint k) {
    return uvec3(hash_combine(lab_seed, 3u * k), hash_combine(lab_seed, 3u * k + 1u),
                 hash_combine(lab_seed, 3u * k + 2u));
}
"""

PATTERNS = {
    "independent": ("independent", "vec2 u = lab_uniform2();\nf = lab_f(u);", ()),
    "stratified": ("stratified (jittered)",
                   "uint nx = uint(round(sqrt(float(lab_count))));\n"
                   "vec2 u = stratified_2d(lab_index, lab_count, nx, lab_dim_seeds(0u));\nf = lab_f(u);",
                   ("sampling/stratified.glsl",)),
    "latin": ("Latin hypercube",
              "uvec3 s = lab_dim_seeds(0u);\n"
              "vec2 cell = vec2(permute_index(lab_index, lab_count, s.x), "
              "permute_index(lab_index, lab_count, s.y));\n"
              "vec2 u = min((cell + lab_uniform2()) / float(lab_count), vec2(0.99999994));\nf = lab_f(u);",
              ("sampling/stratified.glsl",)),
    "sobol": ("Sobol' (Owen-scrambled)",
              "vec2 u = owen_sobol_2d(lab_index, lab_dim_seeds(0u));\nf = lab_f(u);",
              ("sampling/sobol.glsl",)),
    "antithetic": ("antithetic pairs",
                   "uint pair = hash_combine(lab_seed, lab_index >> 1u);\n"
                   "vec2 v = vec2(uint_to_unit_float(hash_combine(pair, 1u)), "
                   "uint_to_unit_float(hash_combine(pair, 2u)));\n"
                   "vec2 u = (lab_index & 1u) == 0u ? v : min(1.0 - v, vec2(0.99999994));\nf = lab_f(u);",
                   ()),
    "control": ("control variate",
                "vec2 u = lab_uniform2();\nf = lab_f(u) - kControlWeight * lab_control(u);", ()),
}
CORRELATED = {"stratified", "latin", "sobol", "antithetic"}


def technique(pattern: str, integrand: str) -> Technique:
    label, body, includes = PATTERNS[pattern]
    return Technique(f"{pattern}/{integrand}", body, includes,
                     SEEDS + INTEGRANDS[integrand][2], label=label)


def fit_slope(ns, rmse) -> float:
    """Least-squares slope of log RMSE against log N."""
    x, y = np.log(np.asarray(ns, float)), np.log(np.asarray(rmse, float))
    return float(np.polyfit(x, y, 1)[0])


def slope_stderr(ns, runs: int) -> float:
    """Standard error of the fitted slope: each log RMSE from ``runs`` independent runs has
    a standard error of about 1/sqrt(2 runs) (the RMSE is a root mean of squares)."""
    x = np.log(np.asarray(ns, float))
    return float(1.0 / math.sqrt(2.0 * runs) / math.sqrt(((x - x.mean()) ** 2).sum()))


def run(lab) -> Section:
    counts = lab.size([16, 64, 256, 1024], [16, 64, 256, 1024, 4096, 16384])
    runs = lab.size(24, 64)
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1])
    curves = {}
    slopes = {}
    for integrand, (title, exact, _) in INTEGRANDS.items():
        per_n = {}
        for n in counts:
            techs = [technique(p, integrand) for p in PATTERNS]
            ind = measure(lab, techs[:1] + [t for t in techs[1:] if t.name.split("/")[0] not in CORRELATED],
                          runs, n, exact, repeats=1 if n != counts[-1] else None)
            cor = measure(lab, [t for t in techs if t.name.split("/")[0] in CORRELATED], runs, n,
                          exact, repeats=1 if n != counts[-1] else None, independent=False)
            rows = {r.technique.split("/")[0]: r for r in ind + cor}
            per_n[n] = [rows[p] for p in PATTERNS]
        last = per_n[counts[-1]]
        section.tables.append(Table(f"{title}: I = {exact:.6g}, N = {counts[-1]} per run", last,
                                    note="Variance per sample = N × Var(estimate) for the "
                                         "correlated patterns; 'uniforms' counts the generic "
                                         "uniform draws only (the patterns hash their own)."))
        curves[integrand] = {p: [per_n[n][i].rmse for n in counts] for i, p in enumerate(PATTERNS)}
        slopes[integrand] = {p: fit_slope(counts, curves[integrand][p]) for p in PATTERNS}
        section.extra.setdefault("rmse", {})[integrand] = {
            "exact": exact, "counts": counts, "rmse": curves[integrand],
            "slopes": slopes[integrand], "slope_stderr": slope_stderr(counts, runs),
            "bias_z": {p: [per_n[n][i].z() for n in counts] for i, p in enumerate(PATTERNS)}}
        section.findings.append(f"{title}: slopes of log RMSE vs log N: " + ", ".join(
            f"{PATTERNS[p][0]} {s:+.2f}" for p, s in slopes[integrand].items()))
    occ = slopes["occluded"]
    section.findings.append(
        f"On the discontinuous integrand stratified and Sobol' points lose most of their "
        f"advantage (slopes {occ['stratified']:+.2f} and {occ['sobol']:+.2f}): only the strata "
        f"the shadow edge crosses keep their variance, which predicts N^-0.75 in 2D (Mitchell "
        f"1996) instead of N^-1 (stratified) and about N^-1.5 (scrambled Sobol') on smooth ones. "
        f"Antithetic pairs help only the monotone integrand; on the symmetric light the pair's "
        f"two points give the same value, which doubles the variance per sample.")
    path = lab.figure_path("patterns_rmse.png")
    _rmse_figure(path, counts, curves, slopes)
    section.figures.append(("patterns_rmse.png",
                            "RMSE of one run's estimate vs samples per run N (log–log) for each "
                            "pattern; the slope of the fitted line is in the legend (−0.5: "
                            "independent Monte Carlo)"))
    return section


def _rmse_figure(path, counts, curves, slopes) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, len(curves), figsize=(4.2 * len(curves), 3.8), sharey=False)
    for ax, (integrand, by_pattern) in zip(axes, curves.items()):
        for p, rmse in by_pattern.items():
            ax.loglog(counts, rmse, "o-", ms=3, label=f"{PATTERNS[p][0]} ({slopes[integrand][p]:+.2f})")
        ref = np.array(counts, float)
        first = by_pattern["independent"][0]
        ax.loglog(ref, first * (ref / ref[0]) ** -0.5, "k:", lw=1, label="N^−0.5")
        ax.set_xlabel("samples per estimate N")
        ax.set_ylabel("RMSE of the estimate")
        ax.set_title(INTEGRANDS[integrand][0])
        ax.legend(fontsize=6.5, loc="lower left")
    save(fig, path)
