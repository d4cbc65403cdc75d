"""Scale-out overhead: the Cornell box at a fixed spp rendered by one process with 2
llvmpipe threads, and on local Dask clusters of 1 and 2 workers with 1 thread each.

    .venv/bin/python benchmarks/scale.py [--spp 64] [--size 256] [--repeats 3]

Each configuration runs ``glrender render`` in a fresh process (LP_NUM_THREADS is read
when a context is made), the configurations alternating within each round (the machine
is shared: compare within a round, report medians). From each run's --stats:

- render wall time (the cluster's start-up reported apart),
- overhead per unit = (render wall x workers - sum of the units' render time) / units:
  what a unit costs beyond its own rendering (scheduling, transfers, merging, the first
  unit's scene load and kernel compile on each worker, idle slots at the end),
- bytes to the client (each band's final accumulation) and the scene's bytes (sent once
  to each worker).

Writes the "## Scale-out on Dask" section of benchmarks/RESULTS.md; docs/scale-out.md
uses the overhead per unit in its model.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
SCENE = ROOT / "scenes" / "cornell-box" / "scene.toml"
TITLE = "## Scale-out on Dask"


def run(config: str, args, folder: Path) -> dict:
    stats = folder / f"{config}.json"
    cmd = [sys.executable, "-m", "glrender", "render", str(SCENE), "--spp", str(args.spp),
           "--width", str(args.size), "--height", str(args.size), "-o", str(folder / "out.exr"),
           "--stats", str(stats), "--quiet"]
    if config == "1 process, 2 threads":
        cmd += ["--threads", "2"]
    else:
        cmd += ["--workers", config[0], "--threads", "1"]
        if args.unit_size:
            cmd += ["--unit-size", str(args.unit_size)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env={**os.environ, "LP_NUM_THREADS": "2"})
    s = json.loads(stats.read_text())
    s["process_seconds"] = time.perf_counter() - t0
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--unit-size", type=int, default=None)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    configs = ["1 process, 2 threads", "1 worker, 1 thread", "2 workers, 1 thread each"]
    runs = {c: [] for c in configs}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            order = configs if r % 2 == 0 else configs[::-1]
            for c in order:
                runs[c].append(run(c, args, Path(tmp)))
                print(f"round {r}: {c}: {runs[c][-1]['seconds']['render']:.2f} s", file=sys.stderr)
    from glrender.distributed.source import from_file

    _, source = from_file(SCENE, {})
    rows = []
    base = statistics.median(s["seconds"]["render"] for s in runs[configs[0]])
    for c in configs:
        ss = runs[c]
        wall = statistics.median(s["seconds"]["render"] for s in ss)
        total = statistics.median(s["process_seconds"] for s in ss)
        if "plan" in ss[0]:
            units = ss[0]["plan"]["units"]
            workers = ss[0]["workers"]
            over = statistics.median((s["seconds"]["render"] * workers - s["seconds"]["units"])
                                     / units for s in ss)
            unit_s = statistics.median(s["seconds"]["units"] / units for s in ss)
            extra = (f"{units} | {unit_s * 1e3:.0f} ms | {over * 1e3:.0f} ms | "
                     f"{ss[0]['bytes_to_client'] / 1e6:.2f} MB + {source.nbytes / 1e3:.1f} kB/worker")
        else:
            extra = "- | - | - | -"
        rows.append(f"| {c} | {wall:.2f} s | {base / wall:.2f}x | {total:.1f} s | {extra} |")
    unit_size = runs[configs[1]][0]["unit_size"]
    section = "\n".join([
        TITLE, "",
        f"`benchmarks/scale.py`: Cornell box {args.size}x{args.size}, {args.spp} spp (Sobol'), "
        f"llvmpipe, {args.repeats} alternating rounds, medians; unit size {unit_size} "
        f"pixel-samples. Render = wall time of the render itself (after the cluster is up); "
        f"process = the whole command (cluster start-up, scene load, output).", "",
        "| configuration | render | speed vs 1 process | process | units | render per unit "
        "| overhead per unit | to client + scene |",
        "|---|---|---|---|---|---|---|---|",
        *rows, ""])
    print(section)
    if not args.no_write:
        text = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
        start = text.find("\n" + TITLE)
        if start < 0:
            text = text.rstrip("\n") + "\n\n" + section
        else:
            end = text.find("\n## ", start + 1)
            text = text[:start + 1] + section + ("\n" + text[end + 1:] if end >= 0 else "")
        RESULTS.write_text(text.rstrip("\n") + "\n")


if __name__ == "__main__":
    main()
