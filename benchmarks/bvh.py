"""BVH build and traversal: glrender beside Embree (embreex) on the same meshes and rays.

Meshes at about 10k, 100k and 1M triangles: the Stanford bunny (a real scan,
../shared/scenes/meshes/bunny.ply; decimated by vertex clustering for 10k,
midpoint-subdivided for 1M) and a tessellated, displaced sphere. Per mesh:

- build seconds (glrender: ``build_bvh``, numpy; Embree: scene commit, TBB
  threads), the SAH cost of glrender's tree beside a full binned-SAH build of
  the same mesh, and bytes per triangle of the packed buffers;
- Mrays/s for coherent primary rays (pinhole camera, 8x8 pixel tiles) and
  incoherent diffuse bounce rays (cosine-distributed from the primary hits),
  closest hit and any hit, on the same rays for both.

All cores for both: llvmpipe runs LP_NUM_THREADS = cores threads; Embree (whose
Python binding traces one ray at a time, holding the GIL) runs one process per
core, each on its share of the rays, started together behind a barrier.
Times are the best of ``--repeats`` runs. Writes the "## BVH" section of
benchmarks/RESULTS.md (other sections are kept).

    .venv/bin/python benchmarks/bvh.py [--sizes 10k,100k,1M] [--repeats 3] [--no-reference]
"""
from __future__ import annotations

import argparse
import datetime
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from results_md import commit  # noqa: E402
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
BUNNY = ROOT.parent / "shared" / "scenes" / "meshes" / "bunny.ply"
SIZES = {"10k": 10_000, "100k": 100_000, "1M": 1_000_000}

KERNEL = """#version 450
layout(local_size_x = 64) in;
#include "geometry/bvh.glsl"
layout(std430, binding = 0) readonly buffer RayOrigins { vec4 ray_o[]; };
layout(std430, binding = 1) readonly buffer RayDirections { vec4 ray_d[]; };  // w: t_max
layout(std430, binding = 2) writeonly buffer Hits { vec4 hits[]; };
uniform uint u_count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
    vec4 o = ray_o[i];
    vec4 d = ray_d[i];
#if ANY_HIT
    hits[i] = vec4(bvh_intersect_any(o.xyz, d.xyz, d.w) ? 1.0 : 0.0);
#else
    BvhHit h;
    bvh_intersect_closest(o.xyz, d.xyz, d.w, h);
    hits[i] = vec4(h.t, uintBitsToFloat(h.prim), h.bary);
#endif
}
"""


# -- meshes ----------------------------------------------------------------------------------
def load_bunny() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    mesh = trimesh.load(BUNNY, process=False)
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def decimate(v, f, target):
    """Vertex clustering on a grid sized so that about ``target`` triangles remain."""
    extent = v.max(axis=0) - v.min(axis=0)
    cell = extent.max() / 64
    for _ in range(40):
        key = np.floor((v - v.min(axis=0)) / cell).astype(np.int64)
        _, cluster, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        cluster = cluster.ravel()
        g = cluster[f]
        keep = (g[:, 0] != g[:, 1]) & (g[:, 1] != g[:, 2]) & (g[:, 0] != g[:, 2])
        g = np.unique(np.sort(g[keep], axis=1), axis=0, return_index=True)[1]
        faces = cluster[f][keep][np.sort(g)]
        if len(faces) <= target * 1.05:
            break
        cell *= 1.05 if len(faces) < target * 1.5 else 1.2
    centres = np.zeros((counts.size, 3))
    np.add.at(centres, cluster, v)
    return centres / counts[:, None], faces


def subdivide(v, f):
    """Split every triangle into four at its edge midpoints (shared midpoints)."""
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mid = len(v) + inverse.ravel().reshape(3, -1).T
    v = np.concatenate([v, v[unique].mean(axis=1)])
    a, b, c = f.T
    f = np.concatenate([np.stack([a, mid[:, 0], mid[:, 2]], 1), np.stack([b, mid[:, 1], mid[:, 0]], 1),
                        np.stack([c, mid[:, 2], mid[:, 1]], 1), mid])
    return v, f


def scanned_mesh(target):
    v, f = load_bunny()
    while len(f) * 4 <= target * 1.3:
        v, f = subdivide(v, f)
    if len(f) > target * 1.5:
        v, f = decimate(v, f, target)
    return v.astype(np.float32), f


def procedural_mesh(target):
    """A displaced UV sphere of about ``target`` triangles."""
    k = int(np.sqrt(target / 2))
    th, ph = np.meshgrid(np.linspace(0, np.pi, k + 1), np.linspace(0, 2 * np.pi, k + 1), indexing="ij")
    r = 1 + 0.1 * np.sin(7 * th) * np.cos(5 * ph)
    v = np.stack([r * np.sin(th) * np.cos(ph), r * np.sin(th) * np.sin(ph), r * np.cos(th)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = (i * (k + 1) + j).ravel()
    f = np.concatenate([np.stack([a, a + k + 1, a + 1], 1), np.stack([a + 1, a + k + 1, a + k + 2], 1)])
    return v.astype(np.float32), f


# -- rays ------------------------------------------------------------------------------------
def camera_rays(v, res=512, tile=8):
    """Pinhole rays over the mesh, ordered in tile x tile pixel blocks (one work group each)."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    direction = np.array([0.3, 0.4, 1.0]) / np.linalg.norm([0.3, 0.4, 1.0])
    eye = centre + direction * radius * 2.2
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(forward, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ys, xs = np.meshgrid(np.arange(res), np.arange(res), indexing="ij")
    key = ((ys // tile) * (res // tile) + xs // tile) * tile * tile + (ys % tile) * tile + xs % tile
    order = np.argsort(key.ravel())
    px = (xs.ravel()[order] + 0.5) / res * 2 - 1
    py = 1 - (ys.ravel()[order] + 0.5) / res * 2
    fov = np.tan(np.radians(20))
    d = forward + (px[:, None] * right + py[:, None] * up) * fov
    return np.broadcast_to(eye, d.shape).astype(np.float32), d.astype(np.float32)


def bounce_rays(v, f, o, d, t, prim, seed=1):
    """Cosine-distributed rays leaving the primary hits (offset along the normal)."""
    hit = prim >= 0
    p = o[hit] + d[hit] * t[hit, None]
    tri = v[f[prim[hit]]].astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where((np.sum(n * d[hit], axis=1) > 0)[:, None], -n, n)
    u = np.random.default_rng(seed).random((len(p), 2))
    r, phi = np.sqrt(u[:, 0]), 2 * np.pi * u[:, 1]
    a = np.where(np.abs(n[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    b1 = np.cross(n, a)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(n, b1)
    w = b1 * (r * np.cos(phi))[:, None] + b2 * (r * np.sin(phi))[:, None] + n * np.sqrt(1 - u[:, :1])
    scale = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    return (p + n * 1e-4 * scale).astype(np.float32), w.astype(np.float32)


# -- Embree ------------------------------------------------------------------------------------
def _embree_worker(v, f, conn, barrier):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, v, f.astype(np.int32))
    scene.run(v[:1].astype(np.float32), np.ones((1, 3), np.float32))  # commit
    conn.send("ready")
    while True:
        job = conn.recv()
        if job is None:
            break
        o, d, query = job
        barrier.wait()
        start = time.perf_counter()
        out = scene.run(o, d, query=query, output=1 if query == "INTERSECT" else None)
        elapsed = time.perf_counter() - start
        conn.send((elapsed, out["primID"] if query == "INTERSECT" else out))


class EmbreeTracer:
    """One Embree scene per process, ``procs`` processes tracing shares of a ray set."""

    def __init__(self, v, f, procs):
        ctx = mp.get_context("spawn")
        self.barrier = ctx.Barrier(procs)
        self.conns, self.procs = [], []
        for _ in range(procs):
            mine, theirs = ctx.Pipe()
            p = ctx.Process(target=_embree_worker, args=(v, f, theirs, self.barrier), daemon=True)
            p.start()
            self.conns.append(mine)
            self.procs.append(p)
        for c in self.conns:
            assert c.recv() == "ready"

    def trace(self, o, d, query):
        parts = np.array_split(np.arange(len(o)), len(self.conns))
        for c, k in zip(self.conns, parts):
            c.send((o[k], d[k], query))
        replies = [c.recv() for c in self.conns]
        return max(r[0] for r in replies), np.concatenate([r[1] for r in replies])

    def close(self):
        for c in self.conns:
            c.send(None)
        for p in self.procs:
            p.join()


def embree_build_seconds(v, f):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    start = time.perf_counter()
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, v, f.astype(np.int32))
    scene.run(v[:1].astype(np.float32), np.ones((1, 3), np.float32))
    return time.perf_counter() - start


# -- glrender ----------------------------------------------------------------------------------
class GlslTracer:
    def __init__(self, ctx, bvh):
        from glrender.gpu.bvh_upload import GpuBvh
        from glrender.gl.shaders import compile_compute
        from glrender.render.params import shader_defines

        self.ctx, self.gl = ctx, ctx.gl
        self.gpu = GpuBvh(ctx, bvh)
        self.programs = {q: compile_compute(ctx, source=KERNEL, defines={**shader_defines(),
                                                                           "ANY_HIT": int(q == "OCCLUDED")})
                         for q in ("INTERSECT", "OCCLUDED")}

    def trace(self, o, d, query):
        gl, n = self.gl, len(o)
        bufs = [gl.buffer(np.concatenate([o, np.zeros((n, 1), np.float32)], 1).tobytes()),
                gl.buffer(np.concatenate([d, np.full((n, 1), np.inf, np.float32)], 1).tobytes()),
                gl.buffer(reserve=n * 16)]
        try:
            for unit, b in enumerate(bufs):
                b.bind_to_storage_buffer(unit)
            self.gpu.bind()
            program = self.programs[query]
            program["u_count"].value = n
            gl.finish()
            start = time.perf_counter()
            program.run(group_x=(n + 63) // 64)
            gl.finish()
            elapsed = time.perf_counter() - start
            hits = np.frombuffer(bufs[2].read(), np.float32).reshape(n, 4)
        finally:
            for b in bufs:
                b.release()
        return elapsed, hits


def run_mesh(name, v, f, ctx, repeats, procs, reference, threads):
    from glrender.accel import build_bvh

    row = {"mesh": name, "triangles": len(f)}
    builds = []
    for _ in range(repeats):
        start = time.perf_counter()
        bvh = build_bvh(v, f, threads=threads)
        builds.append(time.perf_counter() - start)
    row["build"] = min(builds)
    row["embree_build"] = min(embree_build_seconds(v, f) for _ in range(repeats))
    row["sah"] = bvh.sah_cost()
    row["sah_ref"] = build_bvh(v, f, method="binned_sah").sah_cost() if reference else float("nan")
    row["bytes_per_tri"] = bvh.nbytes / bvh.triangle_count
    row["depth"] = bvh.depth

    glsl = GlslTracer(ctx, bvh)
    embree = EmbreeTracer(v, f, procs)
    try:
        o, d = camera_rays(v)
        _, primary_ids = embree.trace(o, d, "INTERSECT")
        o2, d2 = bounce_rays(v, f, o, d, *_primary_hits(v, f, o, d, primary_ids))
        sets = {"primary": (o, d, "INTERSECT"), "bounce": (o2, d2, "INTERSECT"),
                "bounce_any": (o2, d2, "OCCLUDED")}
        for key, (oo, dd, query) in sets.items():
            glsl.trace(oo[:4096], dd[:4096], query)  # warm-up: llvmpipe compiles on first use
            embree.trace(oo[:4096], dd[:4096], query)
            ours, theirs = [], []
            for _ in range(repeats):  # alternate, so that both see the same machine load
                t, hits = glsl.trace(oo, dd, query)
                ours.append(t)
                t, ids = embree.trace(oo, dd, query)
                theirs.append(t)
            row[key] = len(oo) / min(ours) / 1e6
            row["embree_" + key] = len(oo) / min(theirs) / 1e6
            if query == "INTERSECT":
                prim = hits[:, 1].view(np.uint32)
                mine = np.where(prim < bvh.triangle_count, bvh.prim_order[np.minimum(prim, bvh.triangle_count - 1)], -1)
                row["agree_" + key] = float(np.mean(mine == ids))
        row["rays"] = (len(o), len(o2))
    finally:
        embree.close()
        glsl.gpu.release()
    return row


def _primary_hits(v, f, o, d, ids):
    """Distances of Embree's primary hits (recomputed in float64 from the hit triangle)."""
    hit = ids >= 0
    t = np.full(len(o), np.inf)
    tri = v[f[ids[hit]]].astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    t[hit] = np.sum((tri[:, 0] - o[hit]) * n, axis=1) / np.sum(d[hit] * n, axis=1)
    return t, np.where(hit, ids, -1)


def format_section(rows, device, threads, repeats, procs):
    lines = ["## BVH", "",
             f"`benchmarks/bvh.py` on {device}, {threads} llvmpipe threads vs Embree "
             f"({procs} processes), best of {repeats}; commit {commit()}, "
             f"{datetime.date.today().isoformat()}.", "",
             "| mesh | triangles | build s (Embree) | SAH (binned SAH) | bytes/tri | depth "
             "| primary Mrays/s (Embree) | bounce closest (Embree) | bounce any (Embree) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['mesh']} | {r['triangles']:,} | {r['build']:.2f} ({r['embree_build']:.2f}) "
            f"| {r['sah']:.1f} ({r['sah_ref']:.1f}) | {r['bytes_per_tri']:.0f} | {r['depth']} "
            f"| {r['primary']:.2f} ({r['embree_primary']:.2f}) "
            f"| {r['bounce']:.2f} ({r['embree_bounce']:.2f}) "
            f"| {r['bounce_any']:.2f} ({r['embree_bounce_any']:.2f}) |")
    lines += ["", "Ratios to Embree (glrender / Embree; targets: build <= 1.5, bounce closest >= 0.5):", "",
              "| mesh | build | primary | bounce closest | bounce any | same primitive as Embree (primary, bounce) |",
              "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['mesh']} | {r['build'] / r['embree_build']:.2f} | {r['primary'] / r['embree_primary']:.2f} "
            f"| {r['bounce'] / r['embree_bounce']:.2f} | {r['bounce_any'] / r['embree_bounce_any']:.2f} "
            f"| {100 * r['agree_primary']:.3f}%, {100 * r['agree_bounce']:.3f}% |")
    return "\n".join(lines) + "\n"


def write_section(section, notes=None):
    """Replace the "## BVH" section of RESULTS.md; its "### Notes" stay unless new ones are given."""
    text = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    start = text.find("\n## BVH")
    if start < 0:
        text = text.rstrip("\n") + "\n\n" + section + (notes or "")
    else:
        end = text.find("\n## ", start + 1)
        old = text[start + 1:end + 1 if end >= 0 else len(text)]
        if notes is None and "\n### Notes" in old:
            notes = old[old.find("\n### Notes") + 1:]
        text = text[:start + 1] + section + "\n" + (notes or "") + (text[end + 1:] if end >= 0 else "")
    RESULTS.write_text(text.rstrip("\n") + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10k,100k,1M")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=None, help="default: all usable cores")
    parser.add_argument("--no-reference", action="store_true", help="skip the binned-SAH reference builds")
    parser.add_argument("--notes", type=Path,
                        help='markdown for the "### Notes" after the tables (default: keep the old ones)')
    parser.add_argument("--dry-run", action="store_true", help="print the section, do not write it")
    args = parser.parse_args(argv)
    threads = args.threads or len(os.sched_getaffinity(0))
    os.environ["LP_NUM_THREADS"] = str(threads)  # before the first context
    sys.path.insert(0, str(ROOT))
    from glrender.gl.context import default_context

    ctx = default_context()
    device = f"{ctx.renderer}, {ctx.gl.info['GL_VERSION']}"
    rows = []
    for size in args.sizes.split(","):
        target = SIZES[size]
        for kind, make in (("bunny (scan)", scanned_mesh), ("displaced sphere", procedural_mesh)):
            v, f = make(target)
            print(f"{kind} {size}: {len(f):,} triangles", flush=True)
            row = run_mesh(f"{kind} {size}", v, f, ctx, args.repeats, threads, not args.no_reference, threads)
            print(row, flush=True)
            rows.append(row)
    section = format_section(rows, device, threads, args.repeats, threads)
    notes = args.notes.read_text() if args.notes else None
    print(section + (notes or ""))
    if not args.dry_run:
        write_section(section, notes)


if __name__ == "__main__":
    main()
