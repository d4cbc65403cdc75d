"""What every experiment measures, and the shape every experiment module has.

An experiment module defines ``NAME``, ``TITLE`` and ``run(lab) -> Section``. ``lab``
(:class:`Lab`) carries the output folder, the seed, the size (``quick``) and the
device context. A :class:`Section` holds what the report shows: a text, tables of
:class:`Measurement` rows, figures and any extra numbers for results.json.

A :class:`Measurement` is one technique on one problem: ``runs`` independent estimates
of ``samples`` samples each. From them:

- mean +- standard error (the spread of the runs / sqrt(runs)), and z against the
  exact value when it is known;
- variance per sample: with independent samples the mean of the runs' per-sample
  variances, its standard error from their spread; for correlated patterns, samples x
  Var(run estimate) (the N-sample estimator's variance scaled to one sample), relative
  standard error sqrt(2 / (runs - 1)) (run estimates are near normal);
- cost per sample (measured device seconds) and, where counted, deterministic units;
- efficiency = 1 / (variance x cost) and every ratio to the experiment's baseline.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..testing.stats import sidak_t


@dataclass
class Measurement:
    technique: str
    estimates: np.ndarray          # (runs,) independent estimates
    samples: int                   # samples per estimate
    seconds: float                 # device time of all runs x samples
    exact: float | None = None     # exact value or high-sample reference
    exact_stderr: float = 0.0      # the reference's own standard error (0 when exact)
    units: dict = field(default_factory=dict)   # deterministic cost units per sample
    label: str = ""
    run_variances: np.ndarray | None = None   # per-run per-sample variances (independent samples)

    @property
    def title(self) -> str:
        return self.label or self.technique

    @property
    def runs(self) -> int:
        return len(self.estimates)

    @property
    def mean(self) -> float:
        return float(np.mean(self.estimates))

    @property
    def stderr(self) -> float:
        return float(np.std(self.estimates, ddof=1) / math.sqrt(self.runs))

    @property
    def raw_variance(self) -> float:
        """Variance per sample: samples x the variance of one run's estimate."""
        return float(np.var(self.estimates, ddof=1) * self.samples)

    @property
    def zero_variance(self) -> bool:
        """The runs differ by float32 rounding only (a zero-variance estimator): a relative
        spread of the run estimates below 1e-6 (float32 ulps, summed over samples)."""
        return float(np.std(self.estimates)) <= 1e-6 * abs(self.mean)

    @property
    def variance(self) -> float:
        """Variance per sample (0 for a zero-variance estimator: see raw_variance). With
        independent samples, the mean of the runs' own per-sample variances (each run has
        samples - 1 degrees of freedom); else samples x Var(run estimate)."""
        if self.zero_variance:
            return 0.0
        if self.run_variances is not None:
            return float(np.mean(self.run_variances))
        return self.raw_variance

    @property
    def variance_se(self) -> float:
        """Standard error of :attr:`variance`: from the spread of the runs' variances when
        they are known (no normality assumed), else sqrt(2 / (runs - 1)) relative."""
        if self.run_variances is not None and not self.zero_variance:
            return float(np.std(self.run_variances, ddof=1) / math.sqrt(self.runs))
        return self.variance * math.sqrt(2.0 / max(self.runs - 1, 1))

    @property
    def variance_rel_se(self) -> float:
        return self.variance_se / self.variance if self.variance > 0 else 0.0

    @property
    def rmse(self) -> float:
        """Root mean squared error of one run's estimate against the exact value."""
        ref = self.mean if self.exact is None else self.exact
        return float(np.sqrt(np.mean((self.estimates - ref) ** 2)))

    @property
    def cost(self) -> float:
        """Measured device seconds per sample."""
        return self.seconds / (self.runs * self.samples)

    @property
    def efficiency(self) -> float:
        v = self.variance * self.cost
        return 1.0 / v if v > 0 else math.inf

    def z(self) -> float | None:
        if self.exact is None:
            return None
        sigma = math.hypot(self.stderr, self.exact_stderr)
        if sigma == 0:
            return 0.0 if self.mean == self.exact else math.inf
        return (self.mean - self.exact) / sigma

    def unbiased(self, z_max: float, rel_eps: float = 1e-5) -> bool:
        """|mean - exact| <= z sigma + eps |exact| (eps: float32 ulps for zero-variance cases)."""
        if self.exact is None:
            return True
        sigma = math.hypot(self.stderr, self.exact_stderr)
        return abs(self.mean - self.exact) <= z_max * sigma + rel_eps * abs(self.exact) + 1e-12

    def to_json(self, baseline: "Measurement | None" = None) -> dict:
        d = {"technique": self.technique, "label": self.title, "runs": self.runs,
             "samples": self.samples, "mean": self.mean, "stderr": self.stderr,
             "exact": self.exact, "exact_stderr": self.exact_stderr, "z": self.z(),
             "variance_per_sample": self.variance,
             "variance_per_sample_raw": self.raw_variance, "zero_variance": self.zero_variance, "variance_rel_se": self.variance_rel_se,
             "rmse": self.rmse, "seconds": self.seconds, "cost_per_sample_s": self.cost,
             "efficiency": _finite(self.efficiency), "units_per_sample": self.units}
        if baseline is not None:
            d["ratios_to_baseline"] = ratios(self, baseline)
        return d


def _finite(x: float):
    return x if math.isfinite(x) else None


def ratios(m: Measurement, base: Measurement) -> dict:
    """Variance, cost and efficiency relative to the baseline (efficiency > 1: better)."""
    def div(a, b):
        return _finite(a / b) if b else None
    return {"variance": div(m.variance, base.variance), "cost": div(m.cost, base.cost),
            "efficiency": div(m.efficiency, base.efficiency)}


def log_variance_margin(a: Measurement, b: Measurement) -> tuple[float, float]:
    """log(Var_b / Var_a) and its standard error (from each variance's relative SE)."""
    if a.variance <= 0 or b.variance <= 0:
        return math.inf if a.variance <= 0 < b.variance else 0.0, 0.0
    return math.log(b.variance / a.variance), math.hypot(a.variance_rel_se, b.variance_rel_se)


def significantly_lower(a: Measurement, b: Measurement, z: float) -> bool:
    """Var_a < Var_b by more than z standard errors of the log variance ratio."""
    diff, se = log_variance_margin(a, b)
    return diff > z * se


@dataclass
class Table:
    """Measurements of one problem; the first (or ``baseline``) is the baseline."""

    title: str
    rows: list[Measurement]
    baseline: str | None = None
    note: str = ""

    def base(self) -> Measurement:
        if self.baseline is None:
            return self.rows[0]
        return next(r for r in self.rows if r.technique == self.baseline)

    def row(self, technique: str) -> Measurement:
        return next(r for r in self.rows if r.technique == technique)

    def to_json(self) -> dict:
        base = self.base()
        return {"title": self.title, "baseline": base.technique, "note": self.note,
                "rows": [r.to_json(base) for r in self.rows]}


@dataclass
class Section:
    """One experiment's part of the report."""

    name: str
    title: str
    text: str = ""
    tables: list[Table] = field(default_factory=list)
    figures: list[tuple[str, str]] = field(default_factory=list)   # (file name, caption)
    extra: dict = field(default_factory=dict)                      # more numbers for the JSON
    findings: list[str] = field(default_factory=list)              # measured statements
    seconds: float = 0.0

    def all_measurements(self) -> list[Measurement]:
        return [r for t in self.tables for r in t.rows]

    def to_json(self) -> dict:
        return {"name": self.name, "title": self.title, "seconds": self.seconds,
                "tables": [t.to_json() for t in self.tables],
                "figures": [f for f, _ in self.figures], "findings": self.findings,
                "extra": self.extra}


@dataclass
class Lab:
    """Where and how big: passed to every experiment's ``run``."""

    out: Path
    seed: int = 0
    quick: bool = False
    ctx: object = None
    alpha: float = 0.01

    def size(self, quick, full):
        return quick if self.quick else full

    def figure_path(self, name: str) -> Path:
        self.out.mkdir(parents=True, exist_ok=True)
        return self.out / name

    def threshold(self, tests: int, runs: int) -> float:
        """Šidák-corrected two-sided Student-t threshold for ``tests`` comparisons of means
        from ``runs`` independent runs, at the lab's alpha."""
        return sidak_t(self.alpha, max(tests, 1), max(runs - 1, 1))


def ratio_findings(table: Table, prefix: str = "") -> list[str]:
    """One line per non-baseline row: its variance, cost and efficiency relative to the
    baseline (a zero-variance row is said to be one)."""
    base = table.base()
    lines = []
    for r in table.rows:
        if r is base:
            continue
        if r.zero_variance:
            lines.append(f"{prefix}{r.title}: zero variance (p ∝ f), cost ×{r.cost / base.cost:.3g} "
                         f"of {base.title}")
            continue
        units = "".join(f", {r.units[u]:.3g} vs {base.units[u]:.3g} {u}" for u in r.units
                        if u in base.units and r.units[u] != base.units[u])
        lines.append(f"{prefix}{r.title}: variance ×{r.variance / base.variance:.3g}, cost "
                     f"×{r.cost / base.cost:.3g}{units}, efficiency "
                     f"×{r.efficiency / base.efficiency:.3g} of {base.title}")
    return lines
