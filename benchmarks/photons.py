"""Photon mapping against path tracing: time to reach a fixed RMSE.

Scenes: the caustic scene and the Cornell box (shared Mitsuba references). Configs:
glrender sppm (default photons per iteration and initial radius, alpha 0.7), glrender
photon (2^20 photons per map, the default radius; the maps' tracing time counted), glrender
path and bdpt (the scenes' Sobol' sampler, max depth 8), and Mitsuba 3's path tracer
(llvm_ad_rgb, independent sampler). Each config renders in its own process for up to
--seconds after its kernels are compiled and warmed up, recording the error after every
pass (glrender) and at the end (Mitsuba). The time to a target RMSE, for the whole image
and for the caustic window (rows 130-170 x columns 130-200), is read off the recorded
curve for SPPM and photon (biased: their error does not fall as 1/sqrt(t)); for the
unbiased path tracers it is t_end x MSE_end / target^2 (MSE ~ 1/t), which also covers
targets not reached in the budget. The references' own noise is not subtracted (the
caustic reference's is about 8% of a 20 s Mitsuba render's MSE, below the targets).
Writes the "## Photon mapping" section of benchmarks/RESULTS.md.

    .venv/bin/python benchmarks/photons.py [--seconds 60] [--scenes caustic,cornell]
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bdpt import CAUSTIC_WINDOW, scenes  # noqa: E402
from cornell_vs_mitsuba import LLVM, MITSUBA_SCRIPT, ROOT, run  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Photon mapping"
# target RMSE per scene: (whole image, caustic window)
TARGETS = {"caustic": (0.05, 0.15), "cornell": (0.03, None)}

GLRENDER_SCRIPT = r"""
import json, sys, time, numpy as np, glrender
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.photon import PhotonRenderer, PhotonSettings, SppmRenderer, SppmSettings
toml, integrator, seconds, seed, ref_path, out = sys.argv[1:7]
seconds, seed = float(seconds), int(seed)
ref = np.load(ref_path).astype(np.float64)[..., :3]
win = (slice(130, 170), slice(130, 200))
scene = glrender.load(toml)
settings = settings_from_scene(scene, integrator=integrator, seed=seed, spp=1 << 20)
if integrator == "sppm":
    r = SppmRenderer(scene, settings, SppmSettings())
    r.step(1); r.reset()          # warm-up: the first dispatches
    image = r.radiance
    k = 1
elif integrator == "photon":
    # 2^20 photons per map, the default radius; tracing the maps is charged to its time
    r = PhotonRenderer(scene, settings, PhotonSettings(photons=1 << 20))
    r.step(r.samples_per_pass); r.reset()
    image = lambda: r.film().mean.astype(np.float64)
    k = r.samples_per_pass
else:
    r = Renderer(scene, settings)
    r.step(r.samples_per_pass); r.reset()
    image = lambda: r.film().mean.astype(np.float64)
    k = r.samples_per_pass
curve, measured = [], r.timings.get("photons", 0.0)
while measured < seconds or not curve:
    t0 = time.perf_counter()
    r.step(k)
    measured += time.perf_counter() - t0      # the error evaluation below is not charged
    img = image()
    err = (img - ref) ** 2
    curve.append((measured, float(err.mean()), float(err[win].mean()), r.spp_done))
np.save(out, img.astype(np.float32))
print(json.dumps({"curve": curve, "device": r.ctx.renderer,
                  "memory": getattr(r, "memory", lambda: {})()}))
"""


def time_to(curve, column: int, target: float) -> float | None:
    """The first recorded time at which the MSE in ``column`` is at most target^2."""
    for row in curve:
        if row[column] <= target ** 2:
            return row[0]
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="render time per config")
    ap.add_argument("--scenes", default="caustic,cornell")
    ap.add_argument("--configs", default="sppm,photon,path,bdpt,mitsuba")
    ap.add_argument("--no-write", action="store_true", help="print the rows, leave RESULTS.md alone")
    args = ap.parse_args()
    rows, device = [], None
    tmp = Path(tempfile.mkdtemp(prefix="glrender-photon-bench-"))
    for name, (toml, xml, ref_path, _) in scenes(tmp).items():
        if name not in args.scenes.split(","):
            continue
        ref, targets = np.load(ref_path).astype(np.float64)[..., :3], TARGETS[name]
        for config in args.configs.split(","):
            out = tmp / f"{name}-{config}.npy"
            if config == "mitsuba":
                if xml is None:
                    continue
                info = run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml), "independent", str(args.seconds),
                            "16", "1", str(out)], env={"DRJIT_LIBLLVM_PATH": LLVM})
                img = np.load(out).astype(np.float64)[..., :3]
                err = (img - ref) ** 2
                curve = [(info["seconds"], float(err.mean()), float(err[CAUSTIC_WINDOW].mean()), info["spp"])]
                label = "Mitsuba path, independent"
            else:
                info = run([sys.executable, "-c", GLRENDER_SCRIPT, str(toml), config, str(args.seconds), "1",
                            str(ref_path), str(out)])
                device = info["device"]
                curve = [tuple(row) for row in info["curve"]]
                label = f"glrender {config}"
            t_end, mse, mse_w, done = curve[-1]
            times = []
            for column, target in ((1, targets[0]), (2, targets[1])):
                if target is None:
                    times.append(None)
                elif config in ("sppm", "photon"):
                    times.append(time_to(curve, column, target))
                else:
                    times.append(t_end * curve[-1][column] / target ** 2)
            rows.append((name, label, t_end, done, mse, mse_w, times, targets))
            print(f"[{name}] {label:28s} {done:7d} {'iterations' if config == 'sppm' else 'spp'} in "
                  f"{t_end:.1f} s  RMSE {mse ** 0.5:.4g} (window {mse_w ** 0.5:.4g})  time to targets "
                  f"{times}", flush=True)
    if args.no_write:
        return
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT)
    write_results(rows, device, head.stdout.strip(), args)


def replace_section(section: str) -> None:
    """Put ``section`` in RESULTS.md in place of the block under MARKER (a level-2
    heading up to the next one), or at the end."""
    text = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    blocks = text.rstrip("\n").split("\n## ")
    heads = [i for i, block in enumerate(blocks) if i and ("## " + block).startswith(MARKER)]
    if heads:
        blocks[heads[0]] = section.rstrip("\n")[3:] + "\n"
    else:
        blocks.append(section.rstrip("\n")[3:] + "\n")
    RESULTS.write_text("\n## ".join(blocks).rstrip("\n") + "\n")


def write_results(rows, device, commit, args) -> None:
    fmt = lambda t: "not reached" if t is None else f"{t:.1f} s"  # noqa: E731
    intro = (f"Measured {datetime.date.today()} at commit `{commit}`: glrender on `{device}` and Mitsuba 3 "
             f"`llvm_ad_rgb` on the same {os.cpu_count()}-core CPU, which other work shares (noisy "
             f"timings). Every config gets up to {args.seconds:.0f} s after warming up, in one run. "
             "SPPM's and photon's time to a target is read off the error curve (they are biased); "
             "the path tracers' is t x MSE / target^2. The window is the caustic's, rows 130-170 x "
             "columns 130-200. Rerun with `.venv/bin/python benchmarks/photons.py`.")
    lines = [f"{MARKER}: SPPM and photon vs path tracing (time to a fixed RMSE)", "", intro, "",
             "| scene | renderer | time | iterations / spp | RMSE | RMSE window | target RMSE (image / window) "
             "| time to image target | time to window target |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, label, t_end, done, mse, mse_w, times, targets in rows:
        tw = "—" if targets[1] is None else f"{targets[1]:g}"
        lines.append(f"| {name} | {label} | {t_end:.1f} s | {done} | {mse ** 0.5:.4g} | {mse_w ** 0.5:.4g} | "
                     f"{targets[0]:g} / {tw} | {fmt(times[0])} | "
                     f"{'—' if targets[1] is None else fmt(times[1])} |")
    section = "\n".join(lines) + "\n"
    replace_section(section)
    print(section)


if __name__ == "__main__":
    main()
