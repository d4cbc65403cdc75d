"""Where the path tracer's SIMD lanes go: deterministic counts per scene, and timed A/B runs.

llvmpipe runs 8 invocations per SIMD vector and runs a loop while any lane of the vector
is still in it. This script exports this tree (git archive HEAD), applies
``benchmarks/patches/simd-profile.patch`` (counters behind GLRENDER_PROFILE, built on
GL_ARB_shader_ballot) and prints, per scene: segments per path, the path loop's useful lane
share, and for closest-hit and any-hit BVH traversals the calls per path, the lanes
active when a vector enters one, the vector steps (the slowest active lane's loop
iterations) per path and the lanes' useful share of them. The counts do not depend on
the machine's load.

``--variant group`` profiles ``benchmarks/patches/group-tracing.patch`` instead (the
work group packs its BVH rays into shared memory between barriers: fewer vector steps,
but slower on llvmpipe, benchmarks/RESULTS.md "Path tracer SIMD profile");
``--variant stepwise`` applies ``benchmarks/patches/stepwise-tracing.patch`` (closest-hit
queries suspended by a subgroup vote so that finished lanes shade; no counters, so only
``--time`` says anything; also slower on llvmpipe); ``--time N``
also renders each scene N times alternately with the plain export and the variant, in
fresh processes, and prints wall and CPU seconds.

    .venv/bin/python benchmarks/simd_profile.py [--scenes cornell-bunny,caustic] [--spp 8]
                                                [--variant profile|group|stepwise] [--time 3]
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

import glrender
from accumulation import CHILD as TIMED   # one timed render in a fresh process: wall and CPU s

ROOT = Path(__file__).resolve().parents[1]
PATCHES = {"profile": ROOT / "benchmarks" / "patches" / "simd-profile.patch",
           "group": ROOT / "benchmarks" / "patches" / "group-tracing.patch",
           "stepwise": ROOT / "benchmarks" / "patches" / "stepwise-tracing.patch"}

COUNTS = """
import importlib, json, sys
import numpy as np
import glrender
R = importlib.import_module("glrender.render.renderer")
scene_path, spp = sys.argv[1], int(sys.argv[2])
plain = R.shader_defines
R.shader_defines = lambda *a, **k: {**plain(*a, **k), "GLRENDER_PROFILE": 1}
scene = glrender.load(scene_path)
r = R.Renderer(scene, R.settings_from_scene(scene, seed=1, spp=spp))
buf = r.gl.buffer(np.zeros(16, np.uint32).tobytes())
buf.bind_to_storage_buffer(15)
r.step(spp)
print(json.dumps(np.frombuffer(buf.read(), np.uint32).astype(int).tolist()))
"""



def export(dest: Path, patch: Path | None) -> Path:
    dest.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "HEAD"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    if patch is not None:
        subprocess.run(["git", "apply", str(patch)], cwd=dest, check=True)
    (dest / "glrender" / "shaders").symlink_to("../shaders")
    return dest


def child(tree: Path, code: str, *args: str) -> str:
    out = subprocess.run([sys.executable, "-c", code, *args], cwd=tree, check=True, capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": str(tree), "LP_NUM_THREADS": "2"})
    return out.stdout.strip().splitlines()[-1]


def report(name: str, c: list[int], paths: int) -> None:
    loop = f", path loop {c[0] / (8 * c[1]):.3f} of lane work useful" if c[1] else ""
    segments = f"{c[14] / paths:.3f} segments/path" if c[14] else "segments not counted"
    print(f"{name}: {segments}{loop}")
    for kind, b, calls in (("closest", 4, c[12]), ("any", 8, c[13])):
        if c[b + 2]:
            print(f"  {kind:7s}: {calls / paths:.3f} calls/path, {c[b] / calls:.2f} iterations/call; "
                  f"{c[b + 3] / c[b + 2]:.2f} of 8 lanes active per vector call; "
                  f"{c[b + 1] / paths:.3f} vector steps/path; {c[b] / (8 * c[b + 1]):.3f} of lane work useful")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cornell-bunny,caustic")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--variant", choices=sorted(PATCHES), default="profile")
    ap.add_argument("--time", type=int, default=0, help="timed rounds against the plain export")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        variant = export(Path(tmp) / args.variant, PATCHES[args.variant])
        plain = export(Path(tmp) / "plain", None) if args.time else variant
        for name in args.scenes.split(","):
            path = ROOT / "scenes" / name / "scene.toml"
            scene = glrender.load(path)
            counts = json.loads(child(variant, COUNTS, str(path), str(args.spp)))
            report(name, counts, scene.film.width * scene.film.height * args.spp)
            runs: dict[str, list[tuple[float, float]]] = {"plain": [], args.variant: []}
            for i in range(args.time):
                for label, tree in (("plain", plain), (args.variant, variant)):
                    wall, cpu = map(float, child(tree, TIMED, str(path), str(4 * args.spp),
                                                 str(scene.film.width)).split())
                    runs[label].append((wall, cpu))
                    print(f"  round {i + 1} {label:>7}: wall {wall:.3f} s, cpu {cpu:.3f} s", flush=True)
            if args.time:
                b, v = (statistics.median(cpu for _, cpu in runs[k]) for k in ("plain", args.variant))
                print(f"  cpu {args.variant} / plain: {v / b:.3f} (medians)")


if __name__ == "__main__":
    main()
