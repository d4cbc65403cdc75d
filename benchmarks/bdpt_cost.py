"""CPU cost of a bdpt sample, this tree against another commit's renderer, alternately.

Each measurement is a fresh process rendering the scene at a small size with
LP_NUM_THREADS=0 (llvmpipe runs the kernel in the calling thread, so the process's CPU
seconds are the kernel's and other work on the machine slows them less than wall time);
the base commit is exported with `git archive` into a temporary folder. Prints the CPU
milliseconds per sample per pixel (medians over the rounds) of the base's bdpt, this
tree's bdpt and this tree's path tracer, and the image hash of each (equal hashes: the
same image bitwise).

    .venv/bin/python benchmarks/bdpt_cost.py [--base 2091513] [--scenes cornell-box,door,caustic]
        [--size 64] [--spp 48] [--rounds 3]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = r"""
import hashlib, json, sys, time
from dataclasses import replace
import numpy as np, glrender
from glrender.render.renderer import Renderer, settings_from_scene
toml, integrator, size, spp = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
scene = glrender.load(toml)
scene.film = replace(scene.film, width=size, height=size)
r = Renderer(scene, settings_from_scene(scene, integrator=integrator, seed=3, spp=1 << 20, samples_per_pass=4))
r.step(4)   # warm-up: compile and the first dispatches
r.reset()
cpu = time.process_time()
for _ in range(0, spp, 4):
    r.step(4)
cpu = time.process_time() - cpu
mean = np.ascontiguousarray(r.film().mean)
print(json.dumps({"cpu_ms": 1000 * cpu / spp, "hash": hashlib.sha1(mean.tobytes()).hexdigest()[:12]}))
"""


def measure(tree: Path, scene: str, integrator: str, size: int, spp: int) -> dict:
    env = {**os.environ, "LP_NUM_THREADS": "0", "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(tree / "scenes" / scene / "scene.toml"),
                          integrator, str(size), str(spp)], capture_output=True, text=True, env=env,
                         cwd=tree, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="2091513", help="commit to compare against")
    ap.add_argument("--scenes", default="cornell-box,door,caustic")
    ap.add_argument("--size", type=int, default=64, help="image width and height")
    ap.add_argument("--spp", type=int, default=48, help="samples per pixel per measurement (multiple of 4)")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="glrender-bdpt-cost-") as tmp:
        base = Path(tmp)
        archive = subprocess.run(["git", "archive", args.base], cwd=ROOT, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
        (base / "glrender" / "shaders").symlink_to("../shaders")
        configs = [("base bdpt", base, "bdpt"), ("bdpt", ROOT, "bdpt"), ("path", ROOT, "path")]
        for scene in args.scenes.split(","):
            runs: dict[str, list[dict]] = {label: [] for label, _, _ in configs}
            for _ in range(args.rounds):
                for label, tree, integrator in configs:
                    runs[label].append(measure(tree, scene, integrator, args.size, args.spp))
            cost = {label: statistics.median(r["cpu_ms"] for r in rs) for label, rs in runs.items()}
            for label, rs in runs.items():
                print(f"{scene:12s} {label:10s} {cost[label]:7.2f} CPU ms/spp  "
                      f"{sorted(round(r['cpu_ms'], 2) for r in rs)}  image {rs[0]['hash']}")
            print(f"{scene:12s} bdpt / base {cost['bdpt'] / cost['base bdpt']:.3f}, "
                  f"bdpt / path {cost['bdpt'] / cost['path']:.2f} (base {cost['base bdpt'] / cost['path']:.2f})")


if __name__ == "__main__":
    main()
