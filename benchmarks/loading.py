"""Loading speed: a 1M-triangle mesh from ``glrender.load`` to the first finished pass.

The mesh is benchmarks/bvh.py's displaced UV sphere (999,698 triangles, 501,264 vertices),
written once as binary PLY (positions only) and as OBJ with ``v``/``vt``/``vn`` and
``f v/vt/vn`` faces. Every measurement is a fresh process that loads the file, makes a
``Renderer`` at 512x512 (a constant environment light added) and renders one pass of
8 spp; it reports wall seconds for load, packing, BVH build plus upload, kernel compile
and the pass, the process's CPU seconds, the 1-minute load average, and the uploaded
tree (a hash of its packed buffers and its SAH cost: equal hashes, the same tree).

``--baseline DIR`` (a checkout of another commit, e.g. ``git worktree add /tmp/base
<commit>``) is measured alternately with this checkout, round by round, so both see
the same machine load; medians over ``--repeats`` rounds are printed.

``--cache`` measures the BVH cache (glrender/accel/disk_cache.py) instead: each round
gives a fresh process an empty cache folder (the first load: normals and BVH computed,
then written) and then another fresh process the same folder (the second load: both read
back), and times ``glrender.load`` plus the device scene (packing, BVH, uploads; no
kernel compile, no pass). It prints the medians, the ratio second / first, the load
average over the run, and a hash of the uploaded buffers (the tree's and the triangle
texels': one hash per row, the same for both rows, or the cache changed a bit).

    .venv/bin/python benchmarks/loading.py [--repeats 5] [--baseline DIR] [--formats ply,obj]
    .venv/bin/python benchmarks/loading.py --cache [--repeats 5] [--formats ply,obj]
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

ROOT = Path(__file__).resolve().parents[1]

MEASURE = r"""
import json, os, sys, time, warnings
warnings.simplefilter("ignore")
import glrender
from glrender.scene import model as m
c0, t0 = time.process_time(), time.perf_counter()
scene = glrender.load(sys.argv[1])
c1, t1 = time.process_time(), time.perf_counter()
scene.film.width = scene.film.height = 512
scene.lights.append(m.Light("constant", radiance=(1, 1, 1)))
r = glrender.Renderer(scene, spp=8)
c2, t2 = time.process_time(), time.perf_counter()
r.step(8)
r.film()
t3 = time.perf_counter()
import hashlib
bvh = r.device_scene.bvh.bvh     # the tree as uploaded: its buffers' hash and SAH cost
tree = hashlib.sha256(b"".join(a.tobytes() for _, a in sorted(bvh.pack().items())))
print(json.dumps({"load": t1 - t0, "pack": r.timings["pack"],
                  "bvh_upload": r.timings["build"] - r.timings["pack"], "compile": r.timings["compile"],
                  "pass": t3 - t2, "cpu_to_dispatch": c2 - c0, "loadavg": os.getloadavg()[0],
                  "tree": f"{tree.hexdigest()[:12]} SAH {bvh.build_stats['sah_cost']:.4f}"}))
"""

MEASURE_CACHE = r"""
import hashlib, json, os, sys, time, warnings
warnings.simplefilter("ignore")
import glrender
from glrender.gl.context import default_context
from glrender.gpu.device_scene import DeviceScene
ctx = default_context()
t0 = time.perf_counter()
scene = glrender.load(sys.argv[1])
t1 = time.perf_counter()
device = DeviceScene(ctx, scene)
t2 = time.perf_counter()
bvh = device.bvh.bvh
tree = hashlib.sha256(b"".join(a.tobytes() for _, a in sorted(bvh.pack().items())))
for texels in device.mesh_texels:      # and the triangle data in the tree's order
    tree.update(texels.tobytes())
print(json.dumps({"load": t1 - t0, "pack": device.timings["pack"],
                  "bvh_upload": device.timings["build"] - device.timings["pack"],
                  "to_device": t2 - t0, "cache": device.bvh_cache, "loadavg": os.getloadavg()[0],
                  "tree": tree.hexdigest()[:12]}))
"""


def sphere_mesh():
    """benchmarks/bvh.py's displaced sphere of 999,698 triangles: (vertices, triangles)."""
    import numpy as np

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bvh import procedural_mesh

    v, f = procedural_mesh(1_000_000)
    return v.astype(np.float64), f


def write_ply(path: Path, v, f) -> Path:
    """Binary little-endian PLY of positions and triangles."""
    import numpy as np

    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(f), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    faces["n"], faces["i"] = 3, f
    path.write_bytes(header.encode() + v.astype("<f4").tobytes() + faces.tobytes())
    return path


def write_meshes(folder: Path) -> dict[str, Path]:
    import numpy as np

    v, f = sphere_mesh()
    ply = write_ply(folder / "sphere.ply", v, f)
    from glrender.scene.loaders.meshes import vertex_normals

    n = vertex_normals(v, f)
    uv = np.random.default_rng(0).random((len(v), 2))
    obj = folder / "sphere.obj"
    with open(obj, "w") as out:
        out.write("# displaced sphere\n")
        out.write("".join("v %.6f %.6f %.6f\n" % tuple(p) for p in v))
        out.write("".join("vn %.6f %.6f %.6f\n" % tuple(p) for p in n))
        out.write("".join("vt %.6f %.6f\n" % tuple(p) for p in uv))
        g = f + 1
        out.write("".join(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n" for a, b, c in g))
    return {"ply": ply, "obj": obj}


def measure(checkout: Path, mesh: Path, script: str = MEASURE, **env_vars: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(checkout), **env_vars)
    out = subprocess.run([sys.executable, "-c", script, str(mesh)], env=env, cwd=checkout,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure_cache(meshes: dict[str, Path], formats: list[str], repeats: int) -> None:
    """First load (empty cache) against second load (the same cache), alternating."""
    rows: dict[tuple[str, str], list[dict]] = {}
    loads = []
    for _ in range(repeats):
        for fmt in formats:
            with tempfile.TemporaryDirectory() as cache:
                for run in ("first", "second"):
                    loads.append(os.getloadavg()[0])
                    rows.setdefault((fmt, run), []).append(
                        measure(ROOT, meshes[fmt], MEASURE_CACHE, GLRENDER_CACHE="on",
                                GLRENDER_CACHE_DIR=cache))
    loads.append(os.getloadavg()[0])
    print(f"medians of {repeats} fresh processes per row (seconds, glrender.load to the mesh "
          f"on the device; load average {min(loads):.1f}-{max(loads):.1f})")
    for fmt in formats:
        medians = {}
        for run in ("first", "second"):
            rs = rows[(fmt, run)]
            med = {k: statistics.median(r[k] for r in rs) for k in ("load", "pack", "bvh_upload",
                                                                     "to_device")}
            medians[run] = med["to_device"]
            print(f"{fmt:4} {run:6} load {med['load']:5.2f}  pack {med['pack']:5.2f}  "
                  f"BVH+upload {med['bvh_upload']:5.2f}  to device {med['to_device']:5.2f}  "
                  f"BVH cache {'/'.join(sorted({r['cache'] for r in rs}))}  "
                  f"tree {' / '.join(sorted({r['tree'] for r in rs}))}")
        print(f"{fmt:4} second / first: {medians['second'] / medians['first']:.3f}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--baseline", type=Path, default=None)
    parser.add_argument("--formats", default="ply,obj")
    parser.add_argument("--cache", action="store_true",
                        help="first load (empty BVH cache) against second load (cached)")
    args = parser.parse_args(argv)
    if args.cache:
        with tempfile.TemporaryDirectory() as tmp:
            measure_cache(write_meshes(Path(tmp)), args.formats.split(","), args.repeats)
        return
    checkouts = {"this": ROOT}
    if args.baseline is not None:
        checkouts = {"baseline": args.baseline.resolve(), "this": ROOT}
    with tempfile.TemporaryDirectory() as tmp:
        meshes = write_meshes(Path(tmp))
        rows: dict[tuple[str, str], list[dict]] = {}
        for _ in range(args.repeats):
            for fmt in args.formats.split(","):
                for name, checkout in checkouts.items():   # alternately: the same load for both
                    rows.setdefault((fmt, name), []).append(measure(checkout, meshes[fmt]))
    print(f"medians of {args.repeats} fresh processes per row (seconds; 512x512, 8 spp pass)")
    for (fmt, name), rs in rows.items():
        def med(key):
            return statistics.median(r[key] for r in rs)
        to_pass = [r["load"] + r["pack"] + r["bvh_upload"] for r in rs]
        print(f"{fmt:4} {name:9} load {med('load'):6.2f}  pack {med('pack'):5.2f}  "
              f"BVH+upload {med('bvh_upload'):5.2f}  load+pack+BVH {statistics.median(to_pass):6.2f}  "
              f"compile {med('compile'):5.2f}  pass {med('pass'):5.2f}  "
              f"CPU to dispatch {med('cpu_to_dispatch'):6.2f}  "
              f"load average {min(r['loadavg'] for r in rs):.1f}-{max(r['loadavg'] for r in rs):.1f}  "
              f"tree {' / '.join(sorted({r['tree'] for r in rs}))}")


if __name__ == "__main__":
    main()
