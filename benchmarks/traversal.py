"""Busy lanes: how rays meet SIMD lanes, measured two ways.

1. Traversal kernels on the same incoherent bounce rays when only a fraction of each
   8-lane vector has a ray (the render kernel's situation: a vector's lanes whose rays
   miss the meshes' box idle through the traversal): the 4-wide per-lane traversal
   (geometry/bvh.glsl, what the renderer runs), the 8-wide per-lane one, and the 8-wide
   cooperative one (geometry/bvh8.glsl: the vector's rays one after another, lane k
   testing child k, hit masks by ballotARB). Mrays/s counts the rays traced (active
   lanes), best of ``--repeats`` alternating runs.
2. The path tracer through the render kernel and through the wavefront executor
   (glrender/render/wavefront.py: queues binned by whether a ray meets the meshes' box),
   on shipped scenes: paths/s of each in alternating rounds (their images are bitwise
   the same), and where the wavefront's time goes, stage by stage.

Writes the "## Busy lanes" section of benchmarks/RESULTS.md (the notes after its table
stay).

    .venv/bin/python benchmarks/traversal.py [--repeats 3] [--rounds 4] [--spp 16]
"""
from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from results_md import END_OF_RUN, commit, put_run  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Busy lanes"
FRACTIONS = (1.0, 0.5, 0.25, 0.125)
SCENES = ("cornell-box", "cornell-bunny", "caustic")

KERNEL = """#version 450
layout(local_size_x = 64) in;
#include "geometry/bvh8.glsl"
layout(std430, binding = 0) readonly buffer RayOrigins { vec4 ray_o[]; };   // w: has a ray
layout(std430, binding = 1) readonly buffer RayDirections { vec4 ray_d[]; };
layout(std430, binding = 2) writeonly buffer Hits { vec4 hits[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 o = ray_o[i];
    vec4 d = ray_d[i];
    bool has = o.w != 0.0;
    BvhHit h;
#if WIDTH == 4
    h = BvhHit(0.0, kBvhNoHit, vec2(0.0));
    if (has) bvh_intersect_closest(o.xyz, d.xyz, d.w, h);
#else
    bvh8_traverse(has, 0u, o.xyz, d.xyz, d.w, false, h);
#endif
    hits[i] = vec4(h.t, uintBitsToFloat(h.prim), h.bary);
}
"""
KERNELS = {"4-wide per lane": (4, 0), "8-wide per lane": (8, 0), "8-wide cooperative": (8, 8)}


class Tracer:
    def __init__(self, ctx, bvh, width, coop):
        from glrender.gl.shaders import compile_compute
        from glrender.gpu.bvh_upload import GpuBvh
        from glrender.render.params import shader_defines

        self.gl, self.gpu = ctx.gl, GpuBvh(ctx, bvh)
        self.program = compile_compute(ctx, source=KERNEL, defines={
            **shader_defines(), "WIDTH": width, "GLRENDER_COOP_LANES": coop})

    def trace(self, o, d, has):
        n = len(o)
        bufs = [self.gl.buffer(np.concatenate([o, has[:, None]], 1).astype(np.float32).tobytes()),
                self.gl.buffer(np.concatenate([d, np.full((n, 1), np.inf)], 1).astype(np.float32).tobytes()),
                self.gl.buffer(reserve=n * 16)]
        try:
            for unit, b in enumerate(bufs):
                b.bind_to_storage_buffer(unit)
            self.gpu.bind()
            self.gl.finish()
            start = time.perf_counter()
            self.program.run(group_x=n // 64)
            self.gl.finish()
            elapsed = time.perf_counter() - start
            prim = np.frombuffer(bufs[2].read(), np.float32).reshape(n, 4)[:, 1].view(np.uint32).copy()
        finally:
            for b in bufs:
                b.release()
        return elapsed, prim


def traversal_rows(ctx, sizes, repeats):
    import bvh as meshes

    from glrender.accel import build_bvh

    rows = []
    for size in sizes:
        v, f = meshes.scanned_mesh(meshes.SIZES[size])
        trees = {4: build_bvh(v, f), 8: build_bvh(v, f, width=8)}
        tracers = {name: Tracer(ctx, trees[w], w, coop) for name, (w, coop) in KERNELS.items()}
        o, d = meshes.camera_rays(v)
        n = len(o)
        _, prim = tracers["4-wide per lane"].trace(o, d, np.ones(n))
        hit = prim != 0xFFFFFFFF
        tri = trees[4].prim_order[np.where(hit, prim, 0)]
        ids = np.where(hit, tri, -1)
        t, hit_ids = meshes._primary_hits(v, f, o, d, ids)
        o2, d2 = meshes.bounce_rays(v, f, o, d, t, hit_ids)
        m = len(o2) // 64 * 64
        o2, d2 = o2[:m], d2[:m]
        u = np.random.default_rng(7).random(m)
        for frac in FRACTIONS:
            has = (u < frac).astype(np.float32)
            times = {name: [] for name in tracers}
            answers = {}
            for name, tracer in tracers.items():
                tracer.trace(o2[:4096], d2[:4096], has[:4096])  # warm-up (first-use compile)
            for _ in range(repeats):
                for name, tracer in tracers.items():
                    elapsed, answers[name] = tracer.trace(o2, d2, has)
                    times[name].append(elapsed)
            # the same rays hit the same things in every kernel (BVH order differs by width)
            hits = {name: int(np.count_nonzero(a != 0xFFFFFFFF)) for name, a in answers.items()}
            assert len(set(hits.values())) == 1 or max(hits.values()) - min(hits.values()) <= 2, hits
            active = int(has.sum())
            rows.append({"mesh": f"bunny {len(f) // 1000}k", "fraction": frac,
                         **{name: active / min(ts) / 1e6 for name, ts in times.items()}})
            print(rows[-1], flush=True)
    return rows


def executor_rows(spp, rounds):
    import glrender
    from glrender.render import wavefront as wf
    from glrender.render.renderer import Renderer, settings_from_scene

    rows = []
    for name in SCENES:
        scene = glrender.load(ROOT / "scenes" / name / "scene.toml")
        renderers = {ex: Renderer(scene, settings_from_scene(scene, spp=10**6, executor=ex))
                     for ex in ("megakernel", "wavefront")}
        try:
            for r in renderers.values():
                r.step(8)   # compile and warm up
            times = {ex: [] for ex in renderers}
            for _ in range(rounds):
                for ex, r in renderers.items():
                    start = time.perf_counter()
                    r.step(spp)
                    times[ex].append(time.perf_counter() - start)
            paths = scene.film.width * scene.film.height * spp
            ratio = [a / b for a, b in zip(times["megakernel"], times["wavefront"])]
            # where the wavefront's time goes: each stage timed alone (a finish after each)
            stages: dict[str, list[float]] = {}
            wave = renderers["wavefront"].wavefront
            run = wf.Wavefront._run

            def timed(self, stage, count, *args):
                self.gl.finish()
                start = time.perf_counter()
                run(self, stage, count, *args)
                self.gl.finish()
                entry = stages.setdefault(stage, [0.0, 0])
                entry[0] += time.perf_counter() - start
                entry[1] += count

            wf.Wavefront._run = timed
            try:
                renderers["wavefront"].step(spp)
            finally:
                wf.Wavefront._run = run
            steps = sum(b for _, b, _ in wave.last_waves)
            rows.append({"scene": name, "megakernel": paths / np.median(times["megakernel"]) / 1e6,
                         "wavefront": paths / np.median(times["wavefront"]) / 1e6,
                         "ratio": float(np.median(ratio)), "steps": steps,
                         "stages": {k: (v[0], v[1]) for k, v in stages.items()}})
            print(rows[-1], flush=True)
        finally:
            for r in renderers.values():
                r.release()
    return rows


def format_section(trav, execs, device, repeats, rounds, spp):
    load = os.getloadavg()
    lines = [MARKER + ": cooperative traversal and the wavefront executor", "",
             f"{datetime.date.today()}, commit {commit()}, {device}, load average "
             f"{load[0]:.2f} / {load[1]:.2f} at the end. Traversal: the 69k-triangle bunny's "
             f"diffuse bounce rays, a fraction of each vector's lanes with a ray, Mrays/s of "
             f"rays traced, best of {repeats} alternating runs (benchmarks/traversal.py). "
             f"Executors: {spp} spp per round, {rounds} alternating rounds, median paths/s; "
             f"stage times from one more pass, a finish after each dispatch.", "",
             "| mesh | lanes with a ray | " + " | ".join(f"{k} Mrays/s" for k in KERNELS) + " |",
             "|---|---|" + "---|" * len(KERNELS)]
    for r in trav:
        lines.append(f"| {r['mesh']} | {r['fraction']:.3g} | " +
                     " | ".join(f"{r[k]:.2f}" for k in KERNELS) + " |")
    lines += ["", "| scene | render kernel Mpaths/s | wavefront Mpaths/s | wavefront / kernel | "
                  "wavefront stages, ns per item (share of its time) |", "|---|---|---|---|---|"]
    for r in execs:
        total = sum(t for t, _ in r["stages"].values())
        stages = ", ".join(f"{k} {1e9 * t / max(n, 1):.0f} ({100 * t / total:.0f}%)"
                           for k, (t, n) in r["stages"].items())
        lines.append(f"| {r['scene']} | {r['megakernel']:.2f} | {r['wavefront']:.2f} | "
                     f"{r['ratio']:.2f}x | {stages} |")
    return "\n".join(lines + ["", END_OF_RUN]) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--sizes", default="100k")
    args = parser.parse_args(argv)
    from glrender.gl.context import default_context

    ctx = default_context()
    device = f"{ctx.renderer}, {ctx.gl.info['GL_VERSION']}"
    trav = traversal_rows(ctx, args.sizes.split(","), args.repeats)
    execs = executor_rows(args.spp, args.rounds)
    section = format_section(trav, execs, device, args.repeats, args.rounds, args.spp)
    put_run(RESULTS, MARKER, section)
    print(section)


if __name__ == "__main__":
    main()
