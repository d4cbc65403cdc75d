"""The door scene's reference image: bdpt with the Sobol' sampler, k independent seeds
rendered for a fixed time each; their mean is the reference and the spread between them
its per-pixel standard error. Writes benchmarks/refs/door-ref.npy, door-ref-stderr.npy
and door-ref.json (spp, seconds, GL_RENDERER).

    .venv/bin/python benchmarks/door_reference.py [--seconds 150] [--seeds 4]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import glrender
from glrender.render.renderer import Renderer, settings_from_scene

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "refs"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=150.0, help="render time per seed")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--integrator", default="bdpt")
    args = ap.parse_args()
    scene = glrender.load(ROOT / "scenes" / "door" / "scene.toml")
    images, spps = [], []
    for seed in range(args.seeds):
        r = Renderer(scene, settings_from_scene(scene, integrator=args.integrator, spp=1 << 20,
                                                seed=1000 + seed))
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < args.seconds:
            r.step(8)
        images.append(r.film().mean.astype(np.float64))
        spps.append(r.spp_done)
        renderer_name = r.ctx.renderer
        r.release()
        print(f"seed {seed}: {spps[-1]} spp", flush=True)
    stack = np.stack(images)
    OUT.mkdir(parents=True, exist_ok=True)
    np.save(OUT / "door-ref.npy", stack.mean(axis=0).astype(np.float32))
    np.save(OUT / "door-ref-stderr.npy",
            (stack.std(axis=0, ddof=1) / np.sqrt(len(images))).astype(np.float32))
    (OUT / "door-ref.json").write_text(json.dumps({
        "integrator": args.integrator, "sampler": "sobol", "seeds": len(images), "spp": spps,
        "seconds_per_seed": args.seconds, "gl_renderer": renderer_name}, indent=1) + "\n")


if __name__ == "__main__":
    main()
