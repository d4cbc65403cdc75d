"""Vertex connection and merging against our other integrators and Mitsuba 3, at equal time.

Scenes: the Cornell box and the caustic scene (shared Mitsuba references) and the door
scene (reference: benchmarks/door_reference.py, its own noise subtracted), as in
benchmarks/bdpt.py. No scene with participating media exists yet, so none is measured.
Configs: glrender path, bdpt, sppm (default SppmSettings) and vcm (default VcmSettings:
connections and merges, alpha 0.75, initial radius one pixel footprint; and once more with a
light vertex cache, one connection a camera vertex), the scenes'
sampler and max depth, and Mitsuba 3's path tracer (llvm_ad_rgb, independent and
multijitter) on each scene's Mitsuba XML (the shared ones, scenes/door/scene.xml).
Each config renders in its own process for the same wall time after its kernels
are compiled and warmed up; rounds alternate, medians are reported. sppm and vcm count
iterations (one camera sample per pixel each) where the others count samples per pixel.

Reported per scene and config: spp/s (iterations/s), RMSE against the reference (whole
image and the caustic window, rows 130-170 x columns 130-200), mean against the
reference, efficiency 1 / (MSE x time), vcm's efficiency over the best of glrender path,
bdpt and sppm, and every config's over Mitsuba's independent path tracer. For vcm also
the share of the render time spent ordering the merge points into their grid (the
read-back of their keys and cell hashes, the host's two integer sorts, the offsets'
upload and the ordering dispatch) and in the light pass (from an iteration's
start to its counters' read-back: the dispatch, any retrace, and whatever of the previous
camera pass the device still runs). Targets printed under the table: on the door and the
caustic, vcm's equal-time RMSE within 1.25x of the best of path, bdpt and sppm; on both,
vcm's efficiency at least 3x Mitsuba's independent path tracer's. Writes the
"## Vertex connection and merging" section of benchmarks/RESULTS.md: its header, table and
target lines (the notes after them stay).

    .venv/bin/python benchmarks/vcm.py [--seconds 20] [--rounds 1] [--scenes cornell,door,caustic]
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bdpt import arguments, conditions, equal_time, label_of  # noqa: E402
from cornell_vs_mitsuba import ROOT  # noqa: E402
from results_md import commit, put_run_with_targets  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Vertex connection and merging"
OURS = ("glrender path", "glrender bdpt", "glrender sppm")   # vcm's competitors among ours
CACHE = "vcm:cache_connections=1"     # vcm with a light vertex cache, against vcm's own subpaths
MITSUBA = "Mitsuba path, independent"
RMSE_TARGET = {"door": 1.25, "caustic": 1.25}    # vcm RMSE / the best of OURS at equal time
MITSUBA_TARGET = {"door": 3.0, "caustic": 3.0}  # vcm efficiency / Mitsuba's independent
GRID_LIMIT = 0.10                               # the grid build's share of an iteration


def vcm_seconds(info: dict) -> dict:
    """vcm's light pass and grid seconds in the timed loop (its stats at the end less those
    after the warm-up), or nothing for the other configs."""
    after = info.get("stats", {}).get("vcm", {})
    if "grid_seconds" not in after:
        return {}
    before = info["stats_before"]["vcm"]
    return {k: after[k] - before[k] for k in ("light_pass_seconds", "grid_seconds")}


def main() -> None:
    args = arguments(__doc__)
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="glrender-vcm-bench-") as tmp:
        runs = list(equal_time(Path(tmp), args, ("path", "bdpt", "sppm", "vcm", CACHE), extra=vcm_seconds))
    write_results([(name, med) for name, med, _ in runs], runs[-1][2], args, load_start, os.getloadavg())


def ratios(med: dict) -> dict:
    """vcm against the best of OURS and against Mitsuba: efficiency (whole image, window)
    and equal-time RMSE, with the configs they are measured against."""
    vcm = med["glrender vcm"]
    best = max(OURS, key=lambda k: med[k]["eff"])
    best_w = max(OURS, key=lambda k: med[k]["eff_window"])
    best_rmse = min(OURS, key=lambda k: med[k]["mse"])
    out = {"best": best, "eff": vcm["eff"] / med[best]["eff"],
           "best_window": best_w, "eff_window": vcm["eff_window"] / med[best_w]["eff_window"],
           "best_rmse": best_rmse, "rmse": (vcm["mse"] / med[best_rmse]["mse"]) ** 0.5}
    if MITSUBA in med:
        out["mitsuba"] = vcm["eff"] / med[MITSUBA]["eff"]
        out["mitsuba_window"] = vcm["eff_window"] / med[MITSUBA]["eff_window"]
    return out


def target_lines(results) -> list[str]:
    """The targets, met or missed, and vcm's grid share, per scene run."""
    met = lambda ok: "met" if ok else "missed"  # noqa: E731
    lines = []
    for name, med in results:
        r, vcm = ratios(med), med["glrender vcm"]
        if name in RMSE_TARGET:
            lines.append(f"- {name}: vcm's RMSE {vcm['mse'] ** 0.5:.4g} is {r['rmse']:.3g}x the best of "
                         f"path, bdpt and sppm ({r['best_rmse'].split()[1]}, "
                         f"{med[r['best_rmse']]['mse'] ** 0.5:.4g}); target at most "
                         f"{RMSE_TARGET[name]:g}x: {met(r['rmse'] <= RMSE_TARGET[name])}.")
        if name in MITSUBA_TARGET and "mitsuba" in r:
            lines.append(f"- {name}: vcm's efficiency is {r['mitsuba']:.3g}x Mitsuba's independent path "
                         f"tracer's (window {r['mitsuba_window']:.3g}x); target at least "
                         f"{MITSUBA_TARGET[name]:g}x: {met(r['mitsuba'] >= MITSUBA_TARGET[name])}.")
    cache = label_of(CACHE)
    for name, med in results:
        if cache in med:
            lines.append(f"- {name}: the light vertex cache (one connection a camera vertex to a vertex "
                         f"drawn from all the iteration's light subpaths) has "
                         f"{med[cache]['eff'] / med['glrender vcm']['eff']:.3g}x the efficiency of "
                         f"connections to the pixel's own light subpath.")
    shares = []
    for name, med in results:
        vcm = med["glrender vcm"]
        if "grid_seconds" in vcm:
            shares.append(f"{name} {vcm['grid_seconds'] / vcm['seconds']:.1%} "
                          f"({1e3 * vcm['grid_seconds'] / max(vcm['spp'], 1):.1f} ms of "
                          f"{1e3 * vcm['seconds'] / max(vcm['spp'], 1):.1f} ms an iteration; light pass "
                          f"{vcm['light_pass_seconds'] / vcm['seconds']:.1%})")
    if shares:
        worst = max(med["glrender vcm"]["grid_seconds"] / med["glrender vcm"]["seconds"]
                    for _, med in results if "grid_seconds" in med["glrender vcm"])
        lines.append(f"- vcm's merge grid (key and hash read-back, the host's two integer sorts, "
                     f"the ordering dispatch), share of the render time: {', '.join(shares)}; "
                     f"{'above' if worst > GRID_LIMIT else 'within'} {GRID_LIMIT:.0%}"
                     f"{' (a case for sorting on the device too)' if worst > GRID_LIMIT else ''}.")
    return lines


def write_results(results, device, args, load_start, load_end) -> None:
    ratio = lambda r: "—" if r is None else f"{r:.3g}x"  # noqa: E731
    lines = [f"{MARKER}: vcm vs path, bdpt, sppm and Mitsuba 3 (equal time)", "",
             conditions(commit(), device, args, (load_start[0], load_end[0])) + "; 'vs best of ours' "
             "= vcm's over the most efficient of glrender path, bdpt and sppm (named); 'vs Mitsuba' "
             "= over Mitsuba's path tracer with its independent sampler. spp/s counts iterations for "
             "sppm and vcm (one camera sample per pixel each). Rerun: "
             "`.venv/bin/python benchmarks/vcm.py`.", "",
             "| scene | renderer | spp/s | RMSE | RMSE window | mean vs ref | efficiency | "
             "eff. vs best of ours | window eff. vs best of ours | eff. vs Mitsuba | "
             "window eff. vs Mitsuba |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, med in results:
        r = ratios(med)
        mitsuba = med.get(MITSUBA)
        for label, m in med.items():
            ours = (f"{ratio(r['eff'])} ({r['best'].split()[1]})",
                    f"{ratio(r['eff_window'])} ({r['best_window'].split()[1]})") \
                if label == "glrender vcm" else ("—", "—")
            lines.append(f"| {name} | {label} | {m['spp_s']:.2f} | {m['mse'] ** 0.5:.4g} | "
                         f"{m['mse_window'] ** 0.5:.4g} | {m['mean']:+.2%} | {m['eff']:.4g} | "
                         f"{ours[0]} | {ours[1]} | "
                         f"{ratio(m['eff'] / mitsuba['eff'] if mitsuba else None)} | "
                         f"{ratio(m['eff_window'] / mitsuba['eff_window'] if mitsuba else None)} |")
    print(put_run_with_targets(RESULTS, MARKER, lines, target_lines(results)))


if __name__ == "__main__":
    main()
