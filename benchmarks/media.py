"""Participating media: glrender's path tracer, bdpt, vcm and sppm against Mitsuba 3's
volpath, at equal time.

Scenes: cornell-fog (a homogeneous ball of fog in the Cornell box), smoke (a plume from a
voxel grid), volumetric-caustic (a glass sphere focusing an area light into fog) and
window-fog (light shafts through chromatic fog), each in TOML and in Mitsuba's XML (the same
scene), with references from benchmarks/media_reference.py (Mitsuba's volpath at long time;
smoke: glrender's path tracer; their own noise subtracted). Configs: glrender path, bdpt,
vcm and sppm (the scenes' sampler and max depth, the integrators' defaults) and Mitsuba 3's
volpath (llvm_ad_rgb, independent and multijitter). Each config renders in its own process
for the same wall time after its kernel is compiled and warmed up; rounds alternate, medians
are reported. Reported per scene and config: spp/s, RMSE against the reference (and in a
window: the volumetric caustic's cone, the window's shaft), mean against the reference,
efficiency 1 / (MSE x time), whole and in the window, and their ratios to Mitsuba's volpath
with the independent sampler. Targets: the path tracer's efficiency at least Mitsuba's on
cornell-fog and smoke; on volumetric-caustic, in the cone, bdpt, vcm or sppm reaches the RMSE
that Mitsuba reaches in 60 s at least 10x sooner (RMSE^2 falls as 1 / time: an efficiency
in the window at least 10x Mitsuba's). Writes the "## Participating media" section of
benchmarks/RESULTS.md: its header, table and target lines (the notes after them stay).

    .venv/bin/python benchmarks/media.py [--seconds 15] [--rounds 1] [--scenes cornell-fog,smoke,volumetric-caustic,window-fog]
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bdpt import arguments, conditions, equal_time  # noqa: E402
from cornell_vs_mitsuba import ROOT  # noqa: E402
from results_md import commit, put_run_with_targets  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Participating media"
MITSUBA = "Mitsuba path, independent"
TARGET = {"cornell-fog": 1.0, "smoke": 1.0}   # path efficiency / Mitsuba volpath's (independent)
WINDOW_TARGET = {"volumetric-caustic": 10.0}   # best of bdpt, vcm, sppm in the window / Mitsuba's
SCENES = ("cornell-fog", "smoke", "volumetric-caustic", "window-fog")
INTEGRATORS = ("path", "bdpt", "vcm", "sppm")
# (rows, columns) of the 256x256 images: the cone of focused light behind the glass sphere, the
# shaft of sunlight through the window; elsewhere the middle of the image
WINDOWS = {"volumetric-caustic": (slice(70, 150), slice(120, 250)),
           "window-fog": (slice(64, 192), slice(128, 256))}
DEFAULT_WINDOW = (slice(64, 192), slice(64, 192))


def table() -> dict:
    """name -> (TOML, Mitsuba XML, reference, reference per-pixel variance)."""
    out = {}
    for name in SCENES:
        ref = ROOT / "benchmarks" / "refs" / f"{name}-ref.npy"
        if not ref.exists():
            raise SystemExit(f"{ref}: no reference (run benchmarks/media_reference.py first)")
        var = np.load(ref.with_name(f"{name}-ref-stderr.npy")).astype(np.float64) ** 2
        out[name] = (ROOT / "scenes" / name / "scene.toml", ROOT / "scenes" / name / "scene.xml", ref, var,
                     WINDOWS.get(name, DEFAULT_WINDOW))
    return out


def main() -> None:
    args = arguments(__doc__, scenes=",".join(SCENES))
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="glrender-media-bench-") as tmp:
        runs = list(equal_time(Path(tmp), args, INTEGRATORS, table=table()))
    write_results(runs, args, load_start, os.getloadavg())


def write_results(runs, args, load_start, load_end) -> None:
    device = runs[-1][2]
    lines = [f"{MARKER}: the path tracer, bdpt, vcm and sppm vs Mitsuba 3's volpath (equal time)", "",
             conditions(commit(), device, args, (load_start[0], load_end[0]), known="every scene",
                        window=False) +
             ". The 'Mitsuba' rows are its volpath integrator (the scenes' XML). Rerun: `.venv/bin/python benchmarks/media.py` "
             "(references: `benchmarks/media_reference.py`).", "",
             "| scene | renderer | spp/s | RMSE | mean vs ref | efficiency | eff. vs Mitsuba | RMSE in window | "
             "window eff. vs Mitsuba |",
             "|---|---|---|---|---|---|---|---|---|"]
    targets = []
    for name, med, _ in runs:
        mitsuba = med.get(MITSUBA)
        for label, m in med.items():
            label = label.replace("Mitsuba path", "Mitsuba volpath")
            vs = f"{m['eff'] / mitsuba['eff']:.3g}x" if mitsuba else "—"
            vs_w = f"{m['eff_window'] / mitsuba['eff_window']:.3g}x" if mitsuba else "—"
            lines.append(f"| {name} | {label} | {m['spp_s']:.2f} | {m['mse'] ** 0.5:.4g} | "
                         f"{m['mean']:+.2%} | {m['eff']:.4g} | {vs} | {m['mse_window'] ** 0.5:.4g} | {vs_w} |")
        if mitsuba and name in TARGET:
            r = med["glrender path"]["eff"] / mitsuba["eff"]
            targets.append(f"- {name}: the path tracer's efficiency is {r:.3g}x Mitsuba's volpath's; "
                           f"target at least {TARGET[name]:g}x: {'met' if r >= TARGET[name] else 'missed'}.")
        if mitsuba and name in WINDOW_TARGET:
            best, r = max(((k, med[f"glrender {k}"]["eff_window"] / mitsuba["eff_window"])
                           for k in ("bdpt", "vcm", "sppm") if f"glrender {k}" in med), key=lambda x: x[1])
            targets.append(f"- {name}, in the window: {best} reaches Mitsuba's RMSE {r:.3g}x sooner "
                           f"(efficiency in the window); target at least {WINDOW_TARGET[name]:g}x: "
                           f"{'met' if r >= WINDOW_TARGET[name] else 'missed'}.")
    print(put_run_with_targets(RESULTS, MARKER, lines, targets))


if __name__ == "__main__":
    main()
