"""The cost of the renderer's accumulation: this tree against another commit's, alternately.

    .venv/bin/python benchmarks/accumulation.py [--base 9e795ef] [--scene cornell-box]
                                                [--size 128] [--spp 64] [--rounds 8]

Exports ``--base`` (git archive) to a temporary folder, then renders the scene in a fresh
process per run, alternating between that tree and this one in every round (the machine
is shared: compare within a round), and prints each run's wall and CPU seconds of the
render itself (``Renderer.step`` after a warm-up pass; the CPU time of the process,
llvmpipe's threads included, is less sensitive to other work than the wall time) and the
medians. Used to measure exact fixed-point accumulation against float32 Welford sums
(docs/scale-out.md).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import resource, sys, time
from dataclasses import replace
from glrender.scene import load
from glrender.render.renderer import Renderer
scene = load(sys.argv[1]); spp = int(sys.argv[2]); size = int(sys.argv[3])
scene = replace(scene, film=replace(scene.film, width=size, height=size))
r = Renderer(scene, spp=spp, seed=1)
r.step(8); r.reset()
def cpu():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime
t, c = time.perf_counter(), cpu()
r.step(spp)
print(time.perf_counter() - t, cpu() - c)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="9e795ef")
    ap.add_argument("--scene", default="cornell-box")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=8)
    args = ap.parse_args()
    scene = ROOT / "scenes" / args.scene / "scene.toml"
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        base.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.base],
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        (base / "glrender" / "shaders").symlink_to("../shaders")
        trees = {args.base: base, "this tree": ROOT}
        times = {name: [] for name in trees}
        for i in range(args.rounds):
            for name, tree in trees.items():
                out = subprocess.run(
                    [sys.executable, "-c", CHILD, str(scene), str(args.spp), str(args.size)],
                    cwd=tree, check=True, capture_output=True, text=True,
                    env={**os.environ, "PYTHONPATH": str(tree), "LP_NUM_THREADS": "2"})
                wall, cpu = map(float, out.stdout.split()[-2:])
                times[name].append((wall, cpu))
                print(f"round {i + 1} {name:>10}: wall {wall:.3f} s, cpu {cpu:.3f} s", flush=True)
    for name, runs in times.items():
        print(f"median {name:>10}: wall {statistics.median(w for w, _ in runs):.3f} s, "
              f"cpu {statistics.median(c for _, c in runs):.3f} s")
    b, t = (statistics.median(c for _, c in times[n]) for n in trees)
    print(f"cpu this tree / {args.base}: {t / b:.3f}")


if __name__ == "__main__":
    main()
