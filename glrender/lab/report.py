"""The lab's outputs: report.md (one section per experiment), results.json and the figures.

Figures are drawn with matplotlib (the optional extra ``lab``) on the Agg backend; every
figure has axis labels with units and a colour bar where colour carries a value.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import MissingExtra
from .core import Section, Table


def pyplot():
    """matplotlib.pyplot on the Agg backend, or a MissingExtra naming how to install it."""
    try:
        import matplotlib
    except ImportError as exc:   # pragma: no cover - the test extra installs it
        raise MissingExtra("the estimator lab (its figures)", "matplotlib", "lab") from exc
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": 110, "font.size": 9, "axes.titlesize": 10,
                         "axes.grid": True, "grid.alpha": 0.3, "savefig.bbox": "tight",
                         "figure.constrained_layout.use": True})
    return plt


def save(fig, path: Path) -> None:
    fig.savefig(path)
    pyplot().close(fig)


def _num(x, digits: int = 4) -> str:
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    if not math.isfinite(x):
        return "∞" if x > 0 else "–"
    if x == 0:
        return "0"
    if abs(x) >= 1e4 or abs(x) < 1e-3:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}"


def table_markdown(table: Table) -> str:
    base = table.base()
    has_exact = any(r.exact is not None for r in table.rows)
    units = sorted({k for r in table.rows for k in r.units})
    head = ["technique", "mean ± s.e."]
    if has_exact:
        head += ["exact", "z"]
    head += ["variance/sample", "cost/sample (ns)", *[f"{u}/sample" for u in units],
             "efficiency", "var ratio", "cost ratio", "eff. ratio"]
    lines = [f"**{table.title}** (baseline: {base.title}; {base.runs} independent runs × "
             f"{base.samples} samples each)", "", "| " + " | ".join(head) + " |",
             "|" + "---|" * len(head)]
    for r in table.rows:
        rat = r.to_json(base)["ratios_to_baseline"]
        z = r.z()
        cells = [r.title, f"{_num(r.mean, 6)} ± {_num(r.stderr, 2)}"]
        if has_exact:
            cells += [_num(r.exact, 6), "0 var." if r.zero_variance else
                      (_num(z, 2) if z is not None else "–")]
        cells += [_num(r.variance, 3), _num(r.cost * 1e9, 3),
                  *[_num(r.units.get(u), 3) for u in units],
                  _num(r.efficiency, 3), _num(rat["variance"], 3), _num(rat["cost"], 3),
                  _num(rat["efficiency"], 3)]
        lines.append("| " + " | ".join(cells) + " |")
    if table.note:
        lines += ["", table.note]
    return "\n".join(lines)


INTRO = """\
# glrender estimator lab

Each experiment runs every technique it compares on the same problem from many
independent seeds (each run a full randomization) and reports, per technique:
the mean ± standard error of the estimate (from the spread of the runs) against the
exact value, z = (mean − exact)/s.e., the **variance per sample** (with independent
samples the mean of the runs' own per-sample variances; for correlated patterns samples ×
the variance of one run's estimate, so stratification is measured honestly), the **cost
per sample** (device time measured with glFinish around the dispatches: the best of
interleaved repeats), **efficiency = 1/(variance · cost)** and each ratio to the table's
baseline (efficiency ratio > 1: better than the baseline). Deterministic cost units
(uniforms drawn, light evaluations, rays) appear where counted. The machine that ran this
is a shared 2-core one: variances and counts are exact records of the run, measured times
can carry a busy spell of other work (a cost ratio far from its count ratio is one).
"""


def write_report(out: Path, sections: list[Section], meta: dict) -> tuple[Path, Path]:
    """report.md and results.json in ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    parts = [INTRO, f"Device: {meta.get('device', '?')}. Seed {meta.get('seed')}; "
                    f"{'quick sizes' if meta.get('quick') else 'full sizes'}; "
                    f"run time {meta.get('seconds', 0):.0f} s.", ""]
    parts.append("Contents: " + ", ".join(f"[{s.title}](#{s.name})" for s in sections))
    for s in sections:
        parts += ["", f'<a id="{s.name}"></a>', f"## {s.title}", "", s.text.strip(), ""]
        if s.findings:
            parts += ["Measured:", *[f"- {f}" for f in s.findings], ""]
        for t in s.tables:
            parts += [table_markdown(t), ""]
        for name, caption in s.figures:
            parts += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    report = out / "report.md"
    report.write_text("\n".join(parts).rstrip() + "\n")
    results = out / "results.json"
    results.write_text(json.dumps({"meta": meta, "experiments": [s.to_json() for s in sections]},
                                  indent=1, default=_json_default) + "\n")
    return report, results


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serializable: {type(x)}")


def bar_figure(path: Path, table: Table, title: str) -> None:
    """Variance, cost and efficiency of each technique relative to the baseline (log scale)."""
    plt = pyplot()
    from matplotlib.ticker import NullFormatter

    base = table.base()
    names = [r.title for r in table.rows]
    fig, axes = plt.subplots(1, 3, figsize=(10, 0.45 * len(names) + 1.6), sharey=True)
    for ax, key, label in zip(axes, ("variance", "cost", "efficiency"),
                              ("variance / baseline", "cost / baseline",
                               "efficiency / baseline")):
        vals = []
        for r in table.rows:
            v = r.to_json(base)["ratios_to_baseline"][key]
            vals.append(np.nan if v is None else v)
        vals = np.array(vals, float)
        ok = np.isfinite(vals) & (vals > 0)
        lo = min(np.min(vals[ok]), 1.0) if ok.any() else 0.1
        hi = max(np.max(vals[ok]), 1.0) if ok.any() else 10.0
        shown = np.where(ok, vals, lo)
        # bars grow from 1 (the baseline) to the ratio, on a log axis
        ax.barh(range(len(names)), shown - 1.0, left=1.0,
                color=["#4c72b0" if v >= 1 else "#dd8452" for v in shown])
        ax.set_xscale("log")
        ax.set_xlim(lo / 2.5, hi * 4.0)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.axvline(1.0, color="k", lw=0.8)
        ax.set_xlabel(label + " (log scale)")
        for i, v in enumerate(vals):
            text = "0" if v == 0 else ("–" if not np.isfinite(v) else f"{v:.3g}")
            ax.text(max(shown[i], 1.0) * 1.08, i, text, va="center", fontsize=8)
    axes[0].set_yticks(range(len(names)), names)
    axes[0].invert_yaxis()
    fig.suptitle(title)
    save(fig, path)
