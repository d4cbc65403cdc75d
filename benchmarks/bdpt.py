"""Bidirectional path tracing and light tracing against the path tracer, at equal time.

Scenes: the Cornell box and the caustic scene (shared Mitsuba references) and the door
scene (reference: benchmarks/door_reference.py, bdpt, its own noise subtracted). Configs:
glrender path, bdpt and lighttrace (the scenes' Sobol' sampler, max depth 8), and
Mitsuba 3's path tracer (llvm_ad_rgb, independent and multijitter) on each scene's Mitsuba
XML (the shared ones, scenes/door/scene.xml). Each config renders in its own
process for the same wall time after its kernel is compiled and warmed up; rounds
alternate. Reported: samples per pixel per second, RMSE against the reference (whole
image and the caustic window, rows 130-170 x columns 130-200), efficiency 1 / (MSE x
time), its ratio to our path tracer and to Mitsuba, and the time each config needs to
reach our path tracer's equal-time MSE (t x MSE / MSE_path, from MSE ~ 1/t). LuxCore's
BIDIRCPU is not rerun: ../shared/notes/peers.md has its figures (biased on the Cornell
box). Writes the "## Bidirectional" section of benchmarks/RESULTS.md: its header and table
(the notes after the table stay).

    .venv/bin/python benchmarks/bdpt.py [--seconds 20] [--rounds 1] [--scenes cornell,door,caustic]
"""
from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cornell_vs_mitsuba import LLVM, MITSUBA_SCRIPT, REFS, ROOT, run  # noqa: E402
from results_md import put_run  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Bidirectional"
CAUSTIC_WINDOW = (slice(130, 170), slice(130, 200))

GLRENDER_SCRIPT = r"""
import json, sys, time, numpy as np, glrender
from glrender.drivers import create_driver, options_class
from glrender.render.renderer import settings_from_scene
toml, integrator, seconds, seed, out = sys.argv[1:6]
seconds, seed = float(seconds), int(seed)
# "name" or "name:key=int,...": the integrator's own settings (sppm, vcm), defaults but these
integrator, _, given = integrator.partition(":")
given = {k: int(v) for k, v in (item.split("=") for item in given.split(",") if item)}
scene = glrender.load(toml)
options = options_class(integrator)
r = create_driver(scene, settings_from_scene(scene, integrator=integrator, seed=seed, spp=1 << 20),
                  None if options is None else options(**given))
r.step(r.samples_per_pass)   # warm-up: the first pass's dispatches
r.reset()
before = r.stats()           # what the warm-up counted (vcm's light pass and grid seconds)
t0 = time.perf_counter()
while time.perf_counter() - t0 < seconds:
    r.step(r.samples_per_pass)
t = time.perf_counter() - t0
f = r.film()
np.save(out, f.mean)
print(json.dumps({"seconds": t, "spp": f.spp, "device": r.ctx.renderer, "stats_before": before,
                  "stats": r.stats()}, default=str))
"""


def scenes(tmp: Path) -> dict:
    """name -> (glrender TOML, Mitsuba XML or None, reference, reference per-pixel variance)."""
    caustic_xml = tmp / "caustic.xml"
    caustic_xml.write_text((REFS / "caustic" / "caustic.xml").read_text().replace(
        "caustic-sphere.obj", str(REFS / "caustic" / "caustic-sphere.obj")))
    door_ref = ROOT / "benchmarks" / "refs" / "door-ref.npy"
    door_var = np.load(door_ref.with_name("door-ref-stderr.npy")).astype(np.float64) ** 2 \
        if door_ref.exists() else None
    return {
        "cornell": (ROOT / "scenes/cornell-box/scene.toml", REFS / "cornell-box.xml",
                    REFS / "cornell-box-ref.npy", np.load(REFS / "cornell-box-ref-stderr.npy") ** 2),
        "door": (ROOT / "scenes/door/scene.toml", ROOT / "scenes/door/scene.xml", door_ref, door_var),
        "caustic": (ROOT / "scenes/caustic/scene.toml", caustic_xml, REFS / "caustic" / "caustic-ref.npy",
                    None),
    }


def mse_of(img, ref, ref_var, window=None):
    sel = (slice(None), slice(None)) if window is None else window
    err = float(((img[sel] - ref[sel]) ** 2).mean())
    noise = 0.0 if ref_var is None else float(np.broadcast_to(ref_var, ref.shape)[sel].mean())
    return max(err - noise, 1e-30)


def arguments(doc: str, scenes: str = "cornell,door,caustic") -> argparse.Namespace:
    """--seconds, --rounds and --scenes of an equal-time benchmark (``doc``: its docstring)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="render time per config")
    ap.add_argument("--rounds", type=int, default=1, help="alternating rounds (medians reported)")
    ap.add_argument("--scenes", default=scenes)
    return ap.parse_args()


def label_of(integrator: str) -> str:
    """A config's label: "glrender vcm" for "vcm", "glrender vcm (cache connections 1)" for
    "vcm:cache_connections=1"."""
    name, _, given = integrator.partition(":")
    items = [item.replace("_", " ").replace("=", " ") for item in given.split(",") if item]
    return f"glrender {name}" + (f" ({', '.join(items)})" if items else "")


def equal_time(tmp: Path, args, integrators, extra=None, table=None):
    """Per scene of ``args.scenes``: render glrender's ``integrators`` and, where the scene
    has a Mitsuba XML, Mitsuba's path tracer (independent, multijitter), each config in its
    own process for ``args.seconds`` after its warm-up, in ``args.rounds`` rounds that
    alternate the configs. Yields (scene, label -> the rounds' medians, the device glrender
    ran on); a median record holds seconds, spp, mse, mse_window, spp_s, mean, eff,
    eff_window and what ``extra(info)`` adds from the config's JSON output. An integrator
    "name:key=value,..." renders with those of its own settings (integers), labelled
    "glrender name (key value, ...)". ``table``: name -> (TOML, XML or None, reference,
    reference variance or None[, the window of mse_window: by default CAUSTIC_WINDOW]), by
    default this module's scenes."""
    table = scenes(tmp) if table is None else table
    for name in args.scenes.split(","):
        toml, xml, ref_path, ref_var, *rest = table[name]
        window = rest[0] if rest else CAUSTIC_WINDOW
        ref = np.load(ref_path).astype(np.float64)[..., :3]
        configs = [(label_of(k), "glrender", k) for k in integrators]
        if xml is not None:
            configs += [("Mitsuba path, independent", "mitsuba", "independent"),
                        ("Mitsuba path, multijitter", "mitsuba", "multijitter")]
        results: dict[str, list[dict]] = {}
        device = None
        for rnd in range(args.rounds):
            for label, who, what in configs:
                out = tmp / f"{name}-{label.replace(' ', '_').replace(',', '')}-{rnd}.npy"
                if who == "mitsuba":
                    info = run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml), what, str(args.seconds),
                                "16", str(rnd + 1), str(out)], env={"DRJIT_LIBLLVM_PATH": LLVM},
                               cwd=Path(xml).parent)
                else:
                    info = run([sys.executable, "-c", GLRENDER_SCRIPT, str(toml), what, str(args.seconds),
                                str(rnd + 1), str(out)])
                    device = info["device"]
                img = np.load(out).astype(np.float64)[..., :3]
                mse = mse_of(img, ref, ref_var)
                mse_w = mse_of(img, ref, ref_var, window)
                results.setdefault(label, []).append({
                    "seconds": info["seconds"], "spp": info["spp"], "mse": mse, "mse_window": mse_w,
                    "spp_s": info["spp"] / info["seconds"], "mean": float(img.mean() / ref.mean() - 1),
                    **(extra(info) if extra is not None else {})})
                print(f"[{name}] round {rnd + 1} {label:28s} {info['spp']:6d} spp  RMSE {mse ** 0.5:.4g} "
                      f"(window {mse_w ** 0.5:.4g})  mean {img.mean() / ref.mean() - 1:+.2%}", flush=True)
        med = {label: {k: float(np.median([r[k] for r in rs])) for k in rs[0]} for label, rs in results.items()}
        for m in med.values():
            m["eff"] = 1.0 / (m["mse"] * m["seconds"])
            m["eff_window"] = 1.0 / (m["mse_window"] * m["seconds"])
        yield name, med, device


def main() -> None:
    args = arguments(__doc__)
    tmp = Path(tempfile.mkdtemp(prefix="glrender-bdpt-bench-"))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip()
    rows = []
    for name, med, device in equal_time(tmp, args, ("path", "bdpt", "lighttrace")):
        path = med["glrender path"]
        mitsuba = med.get("Mitsuba path, independent")
        for label, m in med.items():
            rows.append((name, label, m, m["eff"] / path["eff"], m["eff_window"] / path["eff_window"],
                         m["eff"] / mitsuba["eff"] if mitsuba else None,
                         m["eff_window"] / mitsuba["eff_window"] if mitsuba else None,
                         m["seconds"] * m["mse"] / path["mse"]))
    write_results(rows, device, commit, args)


def conditions(commit, device, args, load=None, known="Cornell, door", window=True) -> str:
    """The opening of a run's header paragraph: date, commit, devices, ``load`` (the load
    average at the start and the end) where given, the time each config renders and how the
    error and the efficiency are measured (``known``: the scenes whose reference noise is
    subtracted; ``window``: the table has the caustic window's columns)."""
    load = "" if load is None else f"; load average {load[0]:.2f} at the start, {load[1]:.2f} at the end"
    return (f"{datetime.date.today()}, commit `{commit}`, glrender on `{device}`, Mitsuba 3 `llvm_ad_rgb` "
            f"on the same CPU ({os.cpu_count()} cores, shared with other work: timings are noisy{load}). "
            f"Each config renders {args.seconds:g} s after its warm-up, {args.rounds} round(s), "
            f"medians. MSE against the scene's reference minus the reference's own noise where "
            f"known ({known})" + ("; 'window' = the caustic window, rows 130-170 x columns 130-200" if window
                                  else "") + ". Efficiency = 1/(MSE x time)")


def write_results(rows, device, commit, args) -> None:
    ratio = lambda r: "—" if r is None else f"{r:.2f}x"  # noqa: E731
    lines = [f"{MARKER}: bdpt and lighttrace vs the path tracer and Mitsuba 3 (equal time)", "",
             conditions(commit, device, args) + "; 'time to path MSE' = the time to reach our path "
             "tracer's equal-time MSE. Rerun: `.venv/bin/python benchmarks/bdpt.py`.", "",
             "| scene | renderer | spp/s | RMSE | RMSE window | mean vs ref | eff. vs our path | "
             "window eff. vs our path | eff. vs Mitsuba | window eff. vs Mitsuba | time to path MSE |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, label, m, r_path, r_path_w, r_mi, r_mi_w, t_path in rows:
        lines.append(f"| {name} | {label} | {m['spp_s']:.2f} | {m['mse'] ** 0.5:.4g} | "
                     f"{m['mse_window'] ** 0.5:.4g} | {m['mean']:+.2%} | {ratio(r_path)} | {ratio(r_path_w)} | "
                     f"{ratio(r_mi)} | {ratio(r_mi_w)} | {t_path:.1f} s |")
    section = "\n".join(lines) + "\n"
    put_run(RESULTS, MARKER, section)
    print(section)


if __name__ == "__main__":
    main()
