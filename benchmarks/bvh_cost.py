"""CPU cost of a BVH query, this tree against another commit's traversal, alternately.

Rays on two meshes: the scanned bunny (69k triangles, the Cornell + bunny scene's) and
the caustic scene's glass icosphere (20k triangles): primary rays, cosine-distributed
bounce rays leaving the primary hits (closest and any hit), and for the icosphere rays
leaving the hits into the sphere (the refracted rays of the glass). Rays are made once
with Embree (as in benchmarks/bvh.py) and traced by each tree in a fresh process with
LP_NUM_THREADS=0: llvmpipe runs the kernel in the calling thread, so the process's CPU
seconds are the kernel's and other work on the machine slows them less than wall time.
Prints CPU Mrays/s per tree (median over the rounds of each process's best of 3), their
ratio, and how many closest hits name the same triangle as the base's (and the largest
relative difference of their distances).

    .venv/bin/python benchmarks/bvh_cost.py [--base 6af1346] [--rounds 3]
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

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
import bvh as bench  # noqa: E402  (benchmarks/bvh.py: meshes, rays, the kernel)

SPHERE = ROOT / "scenes" / "caustic" / "caustic-sphere.obj"

CHILD = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[3])
from bvh import KERNEL
from glrender.accel import build_bvh
from glrender.gpu.bvh_upload import GpuBvh
from glrender.gl.context import create_context
from glrender.gl.shaders import compile_compute
data = np.load(sys.argv[1])
ctx = create_context()
gl = ctx.gl
bvh = build_bvh(data["v"], data["f"])
gpu = GpuBvh(ctx, bvh)
gpu.bind()
out = {}
hits_all = {}
for name in data["sets"]:
    o, d, any_hit = data[name + "_o"], data[name + "_d"], name.endswith("any")
    n = len(o)
    program = compile_compute(ctx, source=KERNEL, defines={"ANY_HIT": int(any_hit)})
    bufs = [gl.buffer(np.concatenate([o, np.zeros((n, 1), np.float32)], 1).tobytes()),
            gl.buffer(np.concatenate([d, np.full((n, 1), np.inf, np.float32)], 1).tobytes()),
            gl.buffer(reserve=n * 16)]
    for unit, b in enumerate(bufs):
        b.bind_to_storage_buffer(unit)
    gpu.bind()
    program["u_count"].value = n
    program.run(group_x=(n + 63) // 64)  # warm-up (llvmpipe compiles on first use)
    gl.finish()
    best = float("inf")
    for _ in range(3):
        cpu = time.process_time()
        program.run(group_x=(n + 63) // 64)
        gl.finish()
        best = min(best, time.process_time() - cpu)
    hits = np.frombuffer(bufs[2].read(), np.float32).reshape(n, 4).copy()
    for b in bufs:
        b.release()
    out[name] = n / best / 1e6
    if not any_hit:
        prim = hits[:, 1].view(np.uint32)
        ok = prim < bvh.triangle_count
        hits_all[name + "_prim"] = np.where(ok, bvh.prim_order[np.minimum(prim, bvh.triangle_count - 1)], -1)
        hits_all[name + "_t"] = hits[:, 0]
    else:
        hits_all[name + "_hit"] = hits[:, 0]
np.savez(sys.argv[2], **hits_all)
print(json.dumps(out))
"""


def load_sphere():
    import trimesh

    mesh = trimesh.load(SPHERE, process=False, force="mesh")
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.int64)


def ray_sets(v, f, inside: bool) -> dict[str, np.ndarray]:
    """Primary, bounce (closest, any) and, if asked, inward rays, made with Embree."""
    embree = bench.EmbreeTracer(v, f, 1)
    try:
        o, d = bench.camera_rays(v, res=384)
        _, ids = embree.trace(o, d, "INTERSECT")
    finally:
        embree.close()
    t, prim = bench._primary_hits(v, f, o, d, ids)
    o2, d2 = bench.bounce_rays(v, f, o, d, t, prim)
    sets = {"primary": (o, d), "bounce": (o2, d2), "bounce_any": (o2, d2)}
    if inside:
        # the same hits, the cosine lobe turned into the surface: start inside, exit the sphere
        hit = prim >= 0
        p = (o[hit] + d[hit] * t[hit, None]).astype(np.float64)
        tri = v[f[prim[hit]]].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        n = np.where((np.sum(n * d[hit], axis=1) > 0)[:, None], -n, n)  # facing the camera
        w = d2.astype(np.float64)
        w = w - 2 * np.sum(w * n, axis=1, keepdims=True) * n  # mirrored through the tangent plane
        scale = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
        sets["inside"] = ((p - n * 1e-4 * scale).astype(np.float32), w.astype(np.float32))
    out = {"v": v, "f": f, "sets": np.array(list(sets))}
    for name, (oo, dd) in sets.items():
        out[name + "_o"], out[name + "_d"] = oo, dd
    return out


def measure(tree: Path, rays: Path, hits: Path) -> dict:
    env = {**os.environ, "LP_NUM_THREADS": "0", "PYTHONPATH": str(tree)}
    res = subprocess.run([sys.executable, "-c", CHILD, str(rays), str(hits), str(ROOT / "benchmarks")],
                         capture_output=True, text=True, env=env, cwd=tree)
    if res.returncode:
        sys.exit(f"bvh_cost: the run in {tree} failed:\n{res.stderr.strip()}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="6af1346", help="commit to compare against")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--meshes", default="bunny,sphere")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="glrender-bvh-cost-") as tmp:
        tmp = Path(tmp)
        base = tmp / "base"
        base.mkdir()
        archive = subprocess.run(["git", "archive", args.base], cwd=ROOT, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
        (base / "glrender" / "shaders").symlink_to("../shaders")
        meshes = {"bunny": lambda: (lambda v, f: (v.astype(np.float32), f))(*bench.load_bunny()),
                  "sphere": load_sphere}
        for mesh in args.meshes.split(","):
            v, f = meshes[mesh]()
            rays = tmp / f"{mesh}.npz"
            data = ray_sets(v, f, inside=mesh == "sphere")
            np.savez(rays, **data)
            runs = {"base": [], "this": []}
            for _ in range(args.rounds):
                for label, tree in (("base", base), ("this", ROOT)):
                    runs[label].append(measure(tree, rays, tmp / f"{label}.npz"))
            a, b = np.load(tmp / "base.npz"), np.load(tmp / "this.npz")
            for name in data["sets"]:
                m = {label: statistics.median(r[name] for r in rs) for label, rs in runs.items()}
                line = (f"{mesh:6s} {name:10s} base {m['base']:6.3f}  this {m['this']:6.3f} CPU Mrays/s  "
                        f"this/base {m['this'] / m['base']:.3f}  "
                        f"(this: {sorted(round(r[name], 3) for r in runs['this'])}, "
                        f"base: {sorted(round(r[name], 3) for r in runs['base'])})")
                if name + "_prim" in a:
                    same = np.mean(a[name + "_prim"] == b[name + "_prim"])
                    both = (a[name + "_prim"] >= 0) & (a[name + "_prim"] == b[name + "_prim"])
                    rel = np.max(np.abs(a[name + "_t"][both] - b[name + "_t"][both]) /
                                 np.maximum(a[name + "_t"][both], 1e-30), initial=0.0)
                    line += f"  same triangle {100 * same:.3f}%, t rel. diff <= {rel:.1e}"
                else:
                    line += f"  same answer {100 * np.mean(a[name + '_hit'] == b[name + '_hit']):.3f}%"
                print(line, flush=True)


if __name__ == "__main__":
    main()
