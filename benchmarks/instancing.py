"""Two-level instancing against flattening: the K trees of scenes/forest nearest its camera
(104,448 triangles each), drawn once through the two-level BVH (one tree's triangles shared
by K copies) and once flattened (K copies in the one BVH), alternating, for several K: the
seconds to reach the device (pack, BVH builds and upload, the BVH cache off), the device
bytes of the geometry, and the path tracer's paths per second (after a first pass that
generates the kernels' code). This is what ``INSTANCE_MIN_TRIANGLES`` (glrender/gpu/pack.py)
is chosen from: the copies' memory and build time against the second level's traversal cost.

    .venv/bin/python benchmarks/instancing.py [--copies 2,4,8,16,32] [--rounds 2] [--spp 8]

Writes the "## Instancing" section of benchmarks/RESULTS.md (the notes after its table stay)
with GL_RENDERER, the commit and the load average.
"""
from __future__ import annotations

import argparse
import datetime
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
SCENE = ROOT / "scenes" / "forest" / "scene.toml"
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tools"))


def measure(ctx, count: int, instanced: bool, spp: int, size: tuple[int, int]) -> dict:
    import glrender
    from glrender.gpu import pack
    from glrender.render.renderer import Renderer, settings_from_scene
    from make_forest import nearest_trees

    pack.INSTANCE_MIN_TRIANGLES = 0 if instanced else 1 << 62
    scene = nearest_trees(glrender.load(SCENE), count)
    scene.film.width, scene.film.height = size
    settings = settings_from_scene(scene, spp=spp + 1, seed=1, integrator="path")
    with Renderer(scene, settings, ctx=ctx) as r:
        assert bool(r.device_scene.packed.instanced_meshes) == instanced
        r.step(1)
        ctx.gl.finish()
        t0 = time.perf_counter()
        r.step(spp)
        ctx.gl.finish()
        seconds = time.perf_counter() - t0
        capacity = r.device_scene.mesh_capacity()
        return {"build": r.timings["build"], "bytes": capacity["device_bytes"],
                "mpaths": spp * size[0] * size[1] / seconds / 1e6}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", default="2,4,8,16,32")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--spp", type=int, default=8)
    parser.add_argument("--size", default="240x135")
    args = parser.parse_args(argv)
    os.environ["GLRENDER_CACHE"] = "off"
    import results_md
    from glrender.gl.context import default_context
    from glrender.gpu import pack

    size = tuple(int(x) for x in args.size.split("x"))
    counts = [int(c) for c in args.copies.split(",")]
    ctx = default_context()
    loads = [os.getloadavg()[0]]
    runs: dict[tuple[int, bool], list[dict]] = {}
    default = pack.INSTANCE_MIN_TRIANGLES
    for _ in range(args.rounds):
        for count in counts:
            for instanced in (True, False):
                runs.setdefault((count, instanced), []).append(measure(ctx, count, instanced, args.spp, size))
                loads.append(os.getloadavg()[0])
                print(count, instanced, runs[count, instanced][-1], flush=True)
    pack.INSTANCE_MIN_TRIANGLES = default
    med = {key: {k: statistics.median(r[k] for r in v) for k in v[0]} for key, v in runs.items()}
    info = ctx.gl.info
    lines = [
        "## Instancing: two-level BVH against flattened copies", "",
        f"`benchmarks/instancing.py --copies {args.copies} --rounds {args.rounds} --spp {args.spp} "
        f"--size {args.size}`, commit {results_md.commit()}, {datetime.date.today()}, device "
        f"`{info['GL_RENDERER']}`, load average {min(loads):.1f}-{max(loads):.1f}. The K trees of "
        f"`scenes/forest` nearest its camera (104,448 triangles each), instanced (one tree's "
        f"triangles under a top-level tree over the K copies) and flattened (K copies in one "
        f"BVH), alternating; medians of {args.rounds} rounds. Build: seconds from the scene to "
        f"the device (pack, BVH builds, upload; BVH cache off). Paths/s of the path tracer "
        f"(max depth 5) after a first pass.", "",
        "| trees | placed triangles | build instanced (s) | build flattened (s) | device MB instanced | "
        "device MB flattened | Mpaths/s instanced | Mpaths/s flattened | speed instanced / flattened |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for count in counts:
        a, b = med[count, True], med[count, False]
        lines.append(f"| {count} | {count * 104448:,} | {a['build']:.2f} | {b['build']:.2f} | "
                     f"{a['bytes'] / 1e6:.1f} | {b['bytes'] / 1e6:.1f} | {a['mpaths']:.3f} | "
                     f"{b['mpaths']:.3f} | {a['mpaths'] / b['mpaths']:.2f} |")
    text = "\n".join(lines)
    print(text)
    results_md.put_run(RESULTS, "## Instancing", text + "\n")


if __name__ == "__main__":
    main()
