"""`glrender lab --quick` end to end: its outputs, and the statistics every experiment must show.

One quick run of the whole lab (fixed seed 0) feeds every test here; the tests read its
results.json, the record the report is written from. Statistical rules (TESTING.md):
means are compared with Šidák-corrected Student-t thresholds over all comparisons of the
run (σ from the spread of independent runs), zero-variance estimators within float32
ulps, and variance orderings with margins from the standard error of each variance.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from PIL import Image

from glrender.testing.stats import sidak_alpha, sidak_z, student_t_quantile

ALPHA = 0.01
pytestmark = pytest.mark.slow     # the quick lab run takes about a minute on two cores


@pytest.fixture(scope="module")
def lab(tmp_path_factory, gl_ctx):
    from glrender.commands.cli import main

    out = tmp_path_factory.mktemp("lab")
    assert main(["lab", "--quick", "--quiet", "--seed", "0", "--out", str(out)]) == 0
    results = json.loads((out / "results.json").read_text())
    return out, results


def section(results, name):
    return next(s for s in results["experiments"] if s["name"] == name)


def table(results, name, index=0):
    return section(results, name)["tables"][index]


def row(tab, technique):
    return next(r for r in tab["rows"] if r["technique"] == technique)


def lower(a, b, z):
    """Variance of row a below row b by more than z standard errors of log(Var_b / Var_a)."""
    if a["zero_variance"]:
        return b["variance_per_sample"] > 0
    diff = math.log(b["variance_per_sample"] / a["variance_per_sample"])
    return diff > z * math.hypot(a["variance_rel_se"], b["variance_rel_se"])


def same_variance(a, b, z):
    diff = math.log(b["variance_per_sample"] / a["variance_per_sample"])
    return abs(diff) <= z * math.hypot(a["variance_rel_se"], b["variance_rel_se"])


def comparisons(results):
    """Every (estimate, reference, sigma, dof, label) the unbiasedness test makes: rows with
    an exact value against it; renderer rows (no exact value) against the row of the table
    with the smallest standard error, sigma_delta = hypot of both standard errors."""
    out = []
    for s in results["experiments"]:
        for t in s["tables"]:
            base = min(t["rows"], key=lambda r: r["stderr"])
            for r in t["rows"]:
                label = f"{s['name']}/{t['title']}/{r['technique']}"
                if r["exact"] is not None:
                    out.append((r["mean"], r["exact"], math.hypot(r["stderr"], r["exact_stderr"]),
                                r["runs"] - 1, r["zero_variance"], label))
                elif r is not base:
                    out.append((r["mean"], base["mean"], math.hypot(r["stderr"], base["stderr"]),
                                min(r["runs"], base["runs"]) - 1, False, label))
    return out


def test01_outputs_exist_and_every_figure_is_a_readable_png(lab):
    out, results = lab
    report = (out / "report.md").read_text()
    from glrender.lab import EXPERIMENTS

    names = [s["name"] for s in results["experiments"]]
    assert names == EXPERIMENTS + ["defaults"]   # the closing section: defaults vs measured
    assert len(section(results, "defaults")["findings"]) == 5
    for s in results["experiments"]:
        assert f"## {s['title']}" in report
        assert s["figures"] or s["name"] == "defaults", s["name"]
        for name in s["figures"]:
            assert f"]({name})" in report, name
            with Image.open(out / name) as im:
                assert im.format == "PNG" and min(im.size) >= 200, (name, im.size)
                # a figure with content: not a single flat colour
                assert np.asarray(im.convert("L")).std() > 5, name
        for t in s["tables"]:
            for r in t["rows"]:
                assert r["cost_per_sample_s"] > 0 and r["seconds"] > 0, r["technique"]
                assert r["variance_per_sample"] >= 0
    assert results["meta"]["quick"] is True and results["meta"]["device"]


def test02_every_technique_is_unbiased(lab):
    _, results = lab
    comps = comparisons(results)
    per_test = sidak_alpha(ALPHA, len(comps))
    detectable = []
    for mean, ref, sigma, dof, zero_var, label in comps:
        if zero_var:   # p ∝ f: every sample equals the integral up to float32 rounding
            assert abs(mean - ref) <= 1e-5 * abs(ref), label
            continue
        t = student_t_quantile(1.0 - per_test / 2.0, dof)
        assert abs(mean - ref) <= t * sigma, f"{label}: {mean} vs {ref} ± {sigma} (t = {t:.2f})"
        detectable.append(t * sigma / abs(ref))
    # The smallest relative bias each comparison can detect (t·σ/|reference|): on the GLSL
    # integrals ~1% at the median, at most ~11% (Russian roulette with a fixed q = 0.5, whose
    # variance is 280x that of no roulette: the lab's worst estimator by design), ~6% for the
    # renderer's roulette settings on the quick Cornell box (the survey's, with fewer samples,
    # are left out of that bound); on the renderer's plates up to ~45% for light
    # sampling alone of the sharpest plate, whose mean rests on rare highlights of tiny
    # lights. The renderer's strategies are tested for bias at the 1% level against
    # analytic scenes in tests/render; here the plates check that the lab's bookkeeping
    # (regions, runs, seeds) adds none.
    harness = [d for d, c in zip(detectable, [c for c in comps if not c[4]])
               if not c[5].startswith(("direct/", "light_selection/", "survey/"))]
    assert np.median(harness) < 0.02 and max(harness) < 0.12, sorted(harness)[-3:]
    assert max(detectable) < 0.5, sorted(detectable)[-3:]


def test03_importance_sampling_orderings(lab):
    _, results = lab
    z = sidak_z(ALPHA, 4)
    one, two = table(results, "importance", 0), table(results, "importance", 1)
    assert lower(row(one, "tent"), row(one, "uniform"), z)
    assert row(one, "proportional")["zero_variance"]
    assert lower(row(two, "cosine-hemisphere"), row(two, "uniform-hemisphere"), z)
    assert row(two, "phong-lobe")["zero_variance"]


def test04_expected_values_beat_hit_or_miss(lab):
    _, results = lab
    z = sidak_z(ALPHA, 2)
    for i in (0, 1):
        t = table(results, "rejection", i)
        assert lower(row(t, "expected-value"), row(t, "hit-or-miss"), z), t["title"]


def test05_same_distribution_same_variance(lab):
    """Inversion vs max of uniforms, the uniform disk three ways, the sphere two ways: the
    same distribution gives the same variance (a wrong warp or pdf would not)."""
    _, results = lab
    pairs = [("figures", 0, "inversion", "max-of-4"), ("figures", 1, "polar-sqrt", "concentric"),
             ("figures", 1, "polar-sqrt", "rejection"), ("figures", 2, "warp", "cube-rejection"),
             ("rejection", 2, "rejection", "concentric")]
    z = sidak_z(ALPHA, len(pairs))
    for name, i, a, b in pairs:
        t = table(results, name, i)
        assert same_variance(row(t, a), row(t, b), z), (name, a, b)
    t = table(results, "figures", 1)
    assert lower(row(t, "polar-sqrt"), row(t, "polar-linear"), sidak_z(ALPHA, 1))


def test06_pattern_slopes_and_antithetic(lab):
    _, results = lab
    rmse = section(results, "patterns")["extra"]["rmse"]
    z = sidak_z(ALPHA, 5)
    for integrand in ("smooth", "light"):
        slopes, se = rmse[integrand]["slopes"], rmse[integrand]["slope_stderr"]
        for pattern in ("stratified", "sobol"):
            assert slopes[pattern] + z * se < -0.7, (integrand, pattern, slopes[pattern], se)
    t = table(results, "patterns", 0)      # the smooth monotone integrand
    assert lower(row(t, "antithetic/smooth"), row(t, "independent/smooth"), z)


def test07_mis_within_veach_bound_and_far_below_the_worse_strategy(lab):
    _, results = lab
    bounds = section(results, "direct")["extra"]["veach_bound"]
    assert len(bounds) == 4
    z = sidak_z(ALPHA, 2 * len(bounds))
    for plate, b in bounds.items():
        assert b["pixels"] > 50, plate
        se = math.hypot(b["var_balance_se"], b["single_se"])
        assert b["var_balance"] <= b["bound"] + z * se, (plate, b)
        assert b["max_single"] - b["var_balance"] > z * se, (plate, b)
        assert b["var_balance"] < 0.5 * b["max_single"], (plate, b)


def more_efficient_by_rays(a, b, z):
    """Var x rays of row a below row b by more than z standard errors of the log ratio (rays
    are exact counts: the margin is the variances')."""
    diff = math.log(b["variance_per_sample"] * b["units_per_sample"]["rays"] /
                    (a["variance_per_sample"] * a["units_per_sample"]["rays"]))
    return diff > z * math.hypot(a["variance_rel_se"], b["variance_rel_se"])


def test08_russian_roulette_is_more_efficient_by_rays(lab):
    """In the renderer (rays counted by its ray counter): throughput roulette from depth 1, 3
    and 5 (the default) beats no roulette on the Cornell box; in the closed enclosure, where
    every vertex emits, the later or fixed rules do (early throughput roulette loses there:
    the report's curve). Unbiasedness of every setting is test02's. And on the random-walk
    model with its exact answer, throughput roulette from depth 1, 3 and 5."""
    _, results = lab
    cornell, enclosure, walk = (table(results, "roulette", i) for i in range(3))
    z = sidak_z(ALPHA, 9)
    for tab, names in ((cornell, ("rr-depth-1", "rr-depth-3", "rr-depth-5")),
                       (enclosure, ("rr-depth-8", "rr-fixed-0.5", "rr-fixed-0.7"))):
        off = row(tab, "off")
        for name in names:
            rr = row(tab, name)
            assert rr["units_per_sample"]["rays"] < off["units_per_sample"]["rays"], name
            assert more_efficient_by_rays(rr, off, z), (tab["title"], name)
    none = row(walk, "none")
    for name in ("rr-depth-1", "rr-depth-3", "rr-depth-5"):
        assert more_efficient_by_rays(row(walk, name), none, z), name
    assert none["units_per_sample"]["rays"] == pytest.approx(127.0)   # 64 shadow + 63 bounces
    best = section(results, "roulette")["extra"]["best"]
    assert set(best) == {cornell["title"], enclosure["title"]}
    for b in best.values():   # each curve's best setting is named, and is a roulette rule
        assert b["by_rays"].startswith("rr-"), b["by_rays"]


def test09_light_choice_and_area_sampling_orderings(lab):
    _, results = lab
    z = sidak_z(ALPHA, 3)
    t = table(results, "point_lights")
    assert lower(row(t, "by-flux"), row(t, "uniform"), z)
    t = table(results, "area_lights", 0)
    assert lower(row(t, "cone"), row(t, "cap-area"), z)
    assert lower(row(t, "cap-area"), row(t, "sphere-area"), z)


def test09b_the_survey_measures_every_candidate_on_every_scene(lab):
    """The defaults survey: every candidate of every decision on every scene (rays counted),
    the criterion's statistics for each, a choice among the admissible ones, and the second
    pass of the chosen settings against the baseline on every scene."""
    from glrender.lab.survey import DECISIONS, FLOOR

    _, results = lab
    s = section(results, "survey")
    names = {n for items in DECISIONS.values() for n, _, _ in items}
    for t in s["tables"]:
        assert {r["technique"] for r in t["rows"]} == names, t["title"]
        assert all(r["units_per_sample"]["rays"] > 0 for r in t["rows"])
    assert s["extra"]["unbiased"]["all_within"], s["extra"]["unbiased"]
    for by in ("choice_by_time", "choice_by_rays"):
        for decision, c in s["extra"][by].items():
            assert set(c["candidates"]) == {n for n, _, _ in DECISIONS[decision]}
            assert c["chosen"] in c["admissible"]
            for n in c["admissible"]:
                assert n == "baseline" or c["candidates"][n]["worst"] >= FLOOR
                assert c["candidates"][n]["geomean"] <= c["candidates"][c["chosen"]]["geomean"]
    assert set(s["extra"]["combined"]["by_time"]) == {t["title"] for t in s["tables"]}


def test10_unknown_experiment_is_a_one_line_error(tmp_path, capsys):
    from glrender.commands.cli import main

    assert main(["lab", "nonsense", "--quick", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown lab experiment 'nonsense'" in err and len(err.strip().splitlines()) == 1
