"""The defaults survey's criterion on made-up measurements, and the renderer's defaults
against the committed full report (docs/lab/results.json)."""
import json
import math
from pathlib import Path

import numpy as np

from glrender.lab.core import Measurement, Table
from glrender.lab.survey import (BASELINE, DECISIONS, FLOOR, chosen_settings, choose,
                                  finite_variance_albedo)

ROOT = Path(__file__).resolve().parents[2]


def scene_table(title, efficiency):
    """A table whose rows have efficiency (by time and by rays) ×efficiency[name] of the
    baseline's (1 where not given): variance 1/e, equal cost."""
    rows = []
    for items in DECISIONS.values():
        for name, _, _ in items:
            if any(r.technique == name for r in rows):
                continue
            e = efficiency.get(name, 1.0)
            rows.append(Measurement(name, np.array([1.0, 1.1]), 100, 1.0,
                                    run_variances=np.array([1.0 / e, 1.0 / e]),
                                    units={"rays": 3.0}))
    return Table(title, rows, baseline="baseline")


def test01_best_geometric_mean_among_those_above_the_floor():
    # rr-depth-1: geometric mean 2 but one scene at x0.5 (< the floor): not admissible;
    # rr-fixed-0.5: the best geometric mean above the floor (x3 and x2), but its variance is
    # infinite beyond albedo 0.71: not admissible; rr-depth-3: x1.5 and x1.2 (geomean 1.34,
    # above the floor): chosen; balance: x0.9 on both: the baseline stays; power selection:
    # x1.3 and x0.85 (geomean 1.05)
    a = scene_table("a", {"rr-depth-1": 8.0, "rr-depth-3": 1.5, "rr-fixed-0.5": 3.0,
                          "mis-balance": 0.9, "light-power": 1.3})
    b = scene_table("b", {"rr-depth-1": 0.5, "rr-depth-3": 1.2, "rr-fixed-0.5": 2.0,
                          "mis-balance": 0.9, "light-power": 0.85})
    for by in ("time", "rays"):
        c = choose([a, b], by)
        rr = c["roulette"]
        assert math.isclose(rr["candidates"]["rr-depth-1"]["geomean"], 2.0)
        assert "rr-depth-1" not in rr["admissible"]
        assert rr["candidates"]["rr-fixed-0.5"]["worst"] >= FLOOR
        assert "rr-fixed-0.5" not in rr["admissible"]
        assert rr["chosen"] == "rr-depth-3"
        assert math.isclose(rr["candidates"]["rr-depth-3"]["geomean"], math.sqrt(1.8))
        assert c["MIS heuristic"]["chosen"] == "baseline"
        assert c["light selection"]["chosen"] == "light-power"
        assert 0.85 >= FLOOR
        assert chosen_settings(c) == {**BASELINE, "rr_depth": 3, "light_selection": "power"}


def test01b_finite_variance_albedo_of_the_roulette_rules():
    """sqrt(q) for fixed survival q, sqrt(0.95) for the throughput rule, 1 without roulette;
    for the fixed rule checked against the terms of a diffuse walk's second moment,
    q^k (rho/q)^(2k): they vanish below sqrt(q) and grow above it."""
    assert math.isclose(finite_variance_albedo("fixed:0.5"), math.sqrt(0.5))
    assert math.isclose(finite_variance_albedo("fixed:0.7"), math.sqrt(0.7))
    assert math.isclose(finite_variance_albedo("throughput"), math.sqrt(0.95))
    assert finite_variance_albedo("off") == 1.0
    q = 0.5
    for rho, finite in ((0.70, True), (0.72, False)):
        term = q**400 * (rho / q) ** 800
        assert (term < 1e-3) == finite
        assert (finite_variance_albedo(f"fixed:{q}") > rho) == finite


def test02_the_renderer_defaults_are_the_committed_report_s_choice():
    """The scene model's defaults (and shader_defines', the same fact) are the settings the
    full run in docs/lab chose by its criterion (the light selection on its scenes); rerun `glrender lab --out docs/lab` when
    the renderer changes, and follow what it chooses."""
    from glrender.render.params import LIGHT_SELECTION, RR_RULES, STRATEGIES, shader_defines
    from glrender.scene.model import Integrator, parse_rr

    results = json.loads((ROOT / "docs" / "lab" / "results.json").read_text())
    assert results["meta"]["quick"] is False
    survey = next(s for s in results["experiments"] if s["name"] == "survey")
    chosen = survey["extra"]["chosen"]
    i = Integrator()
    assert dict(rr=i.rr, rr_depth=i.rr_depth, strategy=i.strategy) == \
        {k: v for k, v in chosen.items() if k != "light_selection"}
    # the light selection by default (auto) is chosen by a scene's light count: on every
    # scene of the survey it is the survey's choice
    import types

    import glrender
    from glrender.gpu.pack import pack_scene
    from glrender.lab.survey import _scenes
    from glrender.render.params import choose_light_selection

    for folder, *_ in _scenes(types.SimpleNamespace(quick=False)):
        lights = len(pack_scene(glrender.load(ROOT / "scenes" / folder / "scene.toml")).lights)
        assert choose_light_selection(i.light_selection, lights) == chosen["light_selection"], folder
    d = shader_defines()
    rule, q = parse_rr(chosen["rr"])
    assert d["GLRENDER_RR_RULE"] == RR_RULES[rule] and d["GLRENDER_RR_SURVIVAL"] == q
    assert d["GLRENDER_RR_DEPTH"] == chosen["rr_depth"]
    assert d["GLRENDER_STRATEGY"] == STRATEGIES[chosen["strategy"]]
    assert d["GLRENDER_LIGHT_SELECTION"] == LIGHT_SELECTION[chosen["light_selection"]]
