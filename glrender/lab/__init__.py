"""The estimator lab: variance-reduction techniques measured side by side.

    from glrender import lab
    sections = lab.run(["importance", "patterns"], out="lab-out", quick=True, seed=0)

writes ``report.md``, ``results.json`` and the PNG figures into ``out``. Each experiment
is a module of this package with ``NAME``, ``TITLE`` and ``run(lab) -> Section``.
"""
from __future__ import annotations

import importlib
import time
from pathlib import Path

from ..errors import UsageError

# Experiment modules in report order.
EXPERIMENTS = ["importance", "rejection", "figures", "patterns", "point_lights",
               "direct", "light_selection", "area_lights", "roulette", "survey"]


def experiment(name: str):
    """The module of one experiment (its NAME, TITLE and run)."""
    if name not in EXPERIMENTS:
        raise UsageError(f"unknown lab experiment {name!r} (expected one of {', '.join(EXPERIMENTS)})")
    return importlib.import_module(f"{__name__}.{name}")


def run(names=None, out="lab", *, quick: bool = False, seed: int = 0, ctx=None, progress=None):
    """Run the experiments (all by default) and write report.md, results.json and the
    figures into ``out``; returns the sections. ``progress(name)`` is called before each."""
    from ..gl.context import default_context
    from .core import Lab
    from .report import write_report

    names = list(names or EXPERIMENTS)
    modules = [experiment(n) for n in names]
    ctx = ctx or default_context()
    lab = Lab(Path(out), seed=seed, quick=quick, ctx=ctx)
    lab.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sections = []
    for module in modules:
        if progress:
            progress(module.NAME)
        t = time.perf_counter()
        section = module.run(lab)
        section.seconds = time.perf_counter() - t
        sections.append(section)
    from .defaults import defaults_section

    summary = defaults_section(sections)
    info = ctx.info()
    meta = {"device": info.get("GL_RENDERER"), "seed": seed, "quick": quick,
            "experiments": names, "seconds": time.perf_counter() - t0}
    write_report(lab.out, sections + ([summary] if summary else []), meta)
    return sections
