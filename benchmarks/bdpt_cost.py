"""CPU cost of a bdpt sample, this tree against another commit's renderer, alternately.

Each measurement is a fresh process rendering the scene at a small size with
LP_NUM_THREADS=0 (llvmpipe runs the kernel in the calling thread, so the process's CPU
seconds are the kernel's and other work on the machine slows them less than wall time);
the base commit is exported with `git archive` into a temporary folder. Prints the CPU
milliseconds per sample per pixel (medians over the rounds) of the base's bdpt, this
tree's bdpt and this tree's path tracer, the median and range of the per-round ratios
of this tree's bdpt to the base's (the two ran one after the other, under about the same
load), and the image hash of each (equal hashes: the same image bitwise).

    .venv/bin/python benchmarks/bdpt_cost.py [--base 2091513] [--scenes cornell-box,door,caustic]
        [--size 64] [--spp 48] [--rounds 3]

``--define NAME`` compares this tree's bdpt with the same kernel compiled with the shader
define NAME (one of params.glsl's switches) instead of another commit: one process per scene
renders both (and the path tracer) alternately, 24 samples per pixel at a time, which
takes the machine's load out of the comparison better than fresh processes do. Variants
that are not switches live in ``benchmarks/patches/`` (``bdpt-indexed-stores.patch``: the
plain indexed vertex stores); commit one on a branch and pass it as ``--base``.
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

INPROCESS = r"""
import importlib, json, sys, time
from dataclasses import replace
import glrender
R = importlib.import_module("glrender.render.renderer")
toml, define, size, spp, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
plain = R.shader_defines
renderers = {}
for label, integrator, extra in (("bdpt", "bdpt", {}), (define, "bdpt", {define: 1}), ("path", "path", {})):
    R.shader_defines = lambda *a, _extra=extra, **k: {**plain(*a, **k), **_extra}
    scene = glrender.load(toml)
    scene.film = replace(scene.film, width=size, height=size)
    r = R.Renderer(scene, R.settings_from_scene(scene, integrator=integrator, seed=3, spp=1 << 20,
                                                samples_per_pass=4))
    r.step(4)
    renderers[label] = r
times = {label: [] for label in renderers}
for _ in range(rounds):
    for label, r in renderers.items():
        r.reset()
        cpu = time.process_time()
        for _ in range(0, spp, 4):
            r.step(4)
        r.film()
        times[label].append(1000 * (time.process_time() - cpu) / spp)
print(json.dumps(times))
"""


def compare_define(scene: str, define: str, args) -> None:
    env = {**os.environ, "LP_NUM_THREADS": "0", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", INPROCESS, str(ROOT / "scenes" / scene / "scene.toml"), define,
                          str(args.size), "24", str(args.rounds)], capture_output=True, text=True, env=env,
                         cwd=ROOT, check=True)
    times = json.loads(out.stdout.strip().splitlines()[-1])
    cost = {label: statistics.median(ts) for label, ts in times.items()}
    for label, ts in times.items():
        print(f"{scene:12s} {label:20s} {cost[label]:7.2f} CPU ms/spp  {sorted(round(t, 2) for t in ts)}")
    paired = sorted(a / b for a, b in zip(times["bdpt"], times[define]))
    print(f"{scene:12s} bdpt / {define} {cost['bdpt'] / cost[define]:.3f} (per round {statistics.median(paired):.3f}, "
          f"range {paired[0]:.3f}-{paired[-1]:.3f}), bdpt / path {cost['bdpt'] / cost['path']:.2f} "
          f"({define} {cost[define] / cost['path']:.2f})")


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
    ap.add_argument("--define", help="compare with this tree's kernel compiled with this shader define")
    args = ap.parse_args()
    if args.define:
        for scene in args.scenes.split(","):
            compare_define(scene, args.define, args)
        return
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
            # paired: the two trees' runs of one round ran next to each other (under the same load)
            paired = sorted(b["cpu_ms"] / a["cpu_ms"] for a, b in zip(runs["base bdpt"], runs["bdpt"]))
            print(f"{scene:12s} bdpt / base {cost['bdpt'] / cost['base bdpt']:.3f} "
                  f"(per round {statistics.median(paired):.3f}, range {paired[0]:.3f}-{paired[-1]:.3f}), "
                  f"bdpt / path {cost['bdpt'] / cost['path']:.2f} (base {cost['base bdpt'] / cost['path']:.2f})")


if __name__ == "__main__":
    main()
