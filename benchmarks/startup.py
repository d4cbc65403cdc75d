"""Start-up: seconds from the command to the first finished pass, cold and warm shader cache.

Runs ``glrender render SCENE --spp 8`` (one pass) in a fresh process per measurement and
reads the phases from its ``--stats`` file: load (parse scene and meshes), context (EGL),
build (BVH, packing, upload), compile (GLSL compile and link plus llvmpipe's code
generation at the first dispatch), render (the pass) and the process's wall time.

- cold: ``MESA_SHADER_CACHE_DIR`` points at a new, empty folder, so every kernel is
  compiled from source, and so does ``GLRENDER_CACHE_DIR`` (the mesh cache: a mesh's
  normals and BVH computed, not read from the user's cache);
- warm: the same folders again, so Mesa finds the compiled kernels on disk and glrender the
  meshes large enough to be cached.

The cache location is Mesa's: ``MESA_SHADER_CACHE_DIR`` (default ``~/.cache/mesa_shader_cache``;
``MESA_SHADER_CACHE_DISABLE=true`` turns it off). Mitsuba 3 (``llvm_ad_rgb``) is timed in
the same run for the Cornell box from the shared scene (process start to its first
1-spp image, its own kernel cache warm), when it is installed.

The 1M-triangle case (``--no-mesh`` skips it) writes benchmarks/loading.py's displaced
sphere (999,698 triangles, binary PLY) and a Mitsuba XML scene around it (the sphere in a
constant environment, diffuse, path tracer of 8 segments, 512x512, box filter) into a
temporary folder; both renderers read that one file. Each round gives glrender
(``--spp 1``: one pass of 1 spp) a new, empty mesh cache folder (``GLRENDER_CACHE_DIR``:
normals and BVH computed and written; "cold mesh cache"), then the same folder again (both
read back; "warm mesh cache"), then Mitsuba 3 ``load_file`` plus ``render(spp=1)``, all in
fresh processes, the shader caches of both warm (one run of each first, not counted).
Ratios are glrender / Mitsuba of the medians; the 1-minute load average is read before each
round's processes.

    .venv/bin/python benchmarks/startup.py [--repeats 3] [--scenes cornell-box,cornell-bunny,caustic] [--no-mesh]

Writes its run into the "## Start-up" section of benchmarks/RESULTS.md (results_md.py: the
notes after the run and the other sections are kept).
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from results_md import END_OF_RUN, commit, put_run  # noqa: E402
SHARED = Path(os.environ.get("GLRENDER_SHARED", ROOT.parent / "shared"))
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
PHASES = ("load", "context", "build", "compile", "render")

MITSUBA_SCRIPT = r"""
import sys, time
t0 = time.perf_counter()
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
t1 = time.perf_counter()
scene = mi.load_file(sys.argv[1])
t2 = time.perf_counter()
img = mi.render(scene, spp=1)
img.numpy()
print(t1 - t0, t2 - t1, time.perf_counter() - t2)
"""

# the 1M-triangle scene: {eye} and {target} from the mesh's bounds (benchmarks/bvh.py's view)
MESH_XML = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="8"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <string name="fov_axis" value="x"/>
    <transform name="to_world"><lookat origin="{eye}" target="{target}" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="1"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="512"/>
      <integer name="height" value="512"/>
      <rfilter type="box"/>
    </film>
  </sensor>
  <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
  <shape type="ply"><string name="filename" value="sphere.ply"/><ref id="grey"/></shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"""


def run_glrender(scene: Path, cache: Path, spp: int = 8, **env_vars: str) -> dict:
    env = dict(os.environ, MESA_SHADER_CACHE_DIR=str(cache), **env_vars)
    env.pop("MESA_SHADER_CACHE_DISABLE", None)
    with tempfile.TemporaryDirectory() as tmp:
        stats = Path(tmp) / "stats.json"
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "glrender", "render", str(scene), "--spp", str(spp),
                            "-o", str(Path(tmp) / "out.exr"), "--stats", str(stats), "--quiet"],
                           env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if r.returncode != 0:
            raise SystemExit(f"glrender failed on {scene}: {r.stderr.strip()}")
        data = json.loads(stats.read_text())
    seconds = {k: data["seconds"][k] for k in PHASES}
    seconds["wall"] = wall
    return {"seconds": seconds, "bvh_cache": data.get("bvh_cache", "?"),
            "device": f'{data["device"]["GL_RENDERER"]}, {data["device"]["GL_VERSION"]}'}


def run_mitsuba(xml: Path) -> dict | None:
    llvm = os.environ.get("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
    if not xml.exists() or not Path(llvm).exists():
        return None
    env = dict(os.environ, DRJIT_LIBLLVM_PATH=llvm)
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml)], env=env,
                       capture_output=True, text=True, cwd=xml.parent)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        return None
    imports, load_file, first = map(float, r.stdout.split()[-3:])
    return {"load": imports + load_file, "imports": imports, "load_file": load_file,
            "first_image": first, "wall": wall}


def median(values):
    values = sorted(values)
    return values[len(values) // 2]


def write_mesh_scene(folder: Path) -> Path:
    """The 1M-triangle sphere as PLY and the Mitsuba XML scene around it (see the module doc)."""
    from loading import sphere_mesh, write_ply

    v, f = sphere_mesh()
    write_ply(folder / "sphere.ply", v, f)
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre, radius = (lo + hi) / 2, float(((hi - lo) ** 2).sum() ** 0.5 / 2)
    direction = [0.3, 0.4, 1.0]
    norm = sum(d * d for d in direction) ** 0.5
    eye = [c + d / norm * radius * 2.2 for c, d in zip(centre, direction)]
    xml = folder / "sphere.xml"
    xml.write_text(MESH_XML.format(eye=", ".join(f"{x:.6f}" for x in eye),
                                   target=", ".join(f"{x:.6f}" for x in centre)))
    return xml


def run_mesh(repeats: int, shader_cache: Path) -> dict:
    """The 1M-triangle scene: glrender with a cold and a warm mesh cache against Mitsuba 3,
    alternating round by round (see the module doc)."""
    runs: dict[str, list[dict]] = {"cold": [], "warm": [], "mitsuba": []}
    loads = []
    with tempfile.TemporaryDirectory(prefix="glrender-startup-") as tmp:
        xml = write_mesh_scene(Path(tmp))
        with tempfile.TemporaryDirectory() as bvh:      # warm-up: the shader caches of both
            run_glrender(xml, shader_cache, spp=1, GLRENDER_CACHE="on", GLRENDER_CACHE_DIR=bvh)
        if run_mitsuba(xml) is None:
            raise SystemExit(f"Mitsuba 3 failed on {xml} (or is not installed): --no-mesh skips it")
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as bvh:
                for label in ("cold", "warm"):
                    loads.append(os.getloadavg()[0])
                    r = run_glrender(xml, shader_cache, spp=1, GLRENDER_CACHE="on",
                                     GLRENDER_CACHE_DIR=bvh)
                    runs[label].append({**r["seconds"], "bvh_cache": r["bvh_cache"]})
            loads.append(os.getloadavg()[0])
            m = run_mitsuba(xml)
            if m is None:
                raise SystemExit(f"Mitsuba 3 failed on {xml}")
            runs["mitsuba"].append(m)
            print("1M triangles round:", {k: round(v[-1]["wall"], 2) for k, v in runs.items()},
                  f"load average {loads[-1]:.2f}", flush=True)
    loads.append(os.getloadavg()[0])
    out = {label: {k: median([r[k] for r in rs]) for k in (*PHASES, "wall")}
           for label, rs in runs.items() if label != "mitsuba"}
    for label in ("cold", "warm"):
        out[label]["to_image"] = median([sum(r[k] for k in PHASES) for r in runs[label]])
        out[label]["bvh_cache"] = "/".join(sorted({r["bvh_cache"] for r in runs[label]}))
    out["mitsuba"] = {k: median([r[k] for r in runs["mitsuba"]])
                      for k in ("imports", "load_file", "first_image", "wall")}
    out["mitsuba"]["to_image"] = median([r["load_file"] + r["first_image"] for r in runs["mitsuba"]])
    out["loadavg"] = (min(loads), max(loads))
    return out


def mesh_lines(mesh: dict, repeats: int) -> list[str]:
    """The 1M-triangle table of the Start-up section."""
    cold, warm, mit = mesh["cold"], mesh["warm"], mesh["mitsuba"]
    lines = [
        "",
        "1M triangles (999,698: `benchmarks/loading.py`'s displaced sphere as binary PLY, in a "
        "Mitsuba XML scene both renderers read: diffuse, a constant environment, path tracer "
        "of 8 segments, 512x512, box filter, 1 spp; glrender `--spp 1`, one pass). Medians of "
        f"{repeats} rounds of fresh processes, each round glrender with an empty mesh cache "
        "folder (cold mesh cache: normals and BVH computed and written), glrender with the same "
        "folder again (warm mesh cache: both read back), then Mitsuba 3 `llvm_ad_rgb` "
        "`load_file` and `render(spp=1)`; the shader caches of both warm (one run of each "
        f"before, not counted). 1-minute load average {mesh['loadavg'][0]:.2f}-"
        f"{mesh['loadavg'][1]:.2f} over the rounds. `to image`: scene load to the finished "
        "pass inside the process (glrender: load + context + build + compile + pass; Mitsuba: "
        "`load_file` + `render`); `wall`: the command to its exit (Python's start, imports "
        "and glrender's writing of the image included).",
        "",
        "| renderer | load | context | build | compile | first pass | to image | wall |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, med in (("cold", cold), ("warm", warm)):
        lines.append(f"| glrender, {label} mesh cache ({med['bvh_cache']}) | "
                     + " | ".join(f"{med[k]:.2f}" for k in PHASES)
                     + f" | {med['to_image']:.2f} | {med['wall']:.2f} |")
    lines.append(f"| Mitsuba 3 (imports {mit['imports']:.2f}) | {mit['load_file']:.2f} | | | | "
                 f"{mit['first_image']:.2f} | {mit['to_image']:.2f} | {mit['wall']:.2f} |")
    lines += ["",
              "glrender / Mitsuba 3: warm mesh cache "
              f"{warm['wall'] / mit['wall']:.2f}x wall, {warm['to_image'] / mit['to_image']:.2f}x "
              f"to image; cold mesh cache {cold['wall'] / mit['wall']:.2f}x wall, "
              f"{cold['to_image'] / mit['to_image']:.2f}x to image."]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default="cornell-box,cornell-bunny,caustic")
    ap.add_argument("--no-mesh", action="store_true",
                    help="skip the 1M-triangle scene against Mitsuba 3")
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    args = ap.parse_args()

    loads = [os.getloadavg()[0]]
    rows, device = [], None
    for name in args.scenes.split(","):
        scene = ROOT / "scenes" / name / "scene.toml"
        cold, warm = [], []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as meshes:
                c, w = (run_glrender(scene, Path(cache), GLRENDER_CACHE="on", GLRENDER_CACHE_DIR=meshes)
                        for _ in range(2))
            device = c["device"]
            cold.append(c["seconds"])
            warm.append(w["seconds"])
        for label, runs in (("cold", cold), ("warm", warm)):
            med = {k: median([r[k] for r in runs]) for k in (*PHASES, "wall")}
            rows.append((name, label, med))
            print(name, label, {k: round(v, 2) for k, v in med.items()}, flush=True)

    loads.append(os.getloadavg()[0])
    mitsuba = [m for m in (run_mitsuba(SHARED / "refs" / "cornell-box.xml")
                           for _ in range(args.repeats)) if m]
    mesh = None
    if not args.no_mesh:
        with tempfile.TemporaryDirectory() as cache:
            mesh = run_mesh(args.repeats, Path(cache))
    loads.append(os.getloadavg()[0])
    lines = [
        "## Start-up",
        "",
        f"`benchmarks/startup.py --repeats {args.repeats}`, commit {commit()}, "
        f"{datetime.date.today().isoformat()}, device `{device}`, 1-minute load average "
        f"{min(loads):.2f}-{max(loads):.2f} (at the start, after the scenes' table and at the "
        "end). Seconds from the command to "
        "the end of the first pass (8 spp at the scene's resolution), medians of "
        f"{args.repeats} fresh processes; cold: an empty `MESA_SHADER_CACHE_DIR` and an empty "
        "mesh cache folder (`GLRENDER_CACHE_DIR`), warm: the same folders again. `compile` is GLSL compile and link plus llvmpipe's code generation "
        "at the first dispatch; `wall` includes Python's start and imports.",
        "",
        "| scene | cache | load | context | build | compile | first pass | wall |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, label, med in rows:
        lines.append(f"| {name} | {label} | " + " | ".join(f"{med[k]:.2f}" for k in PHASES)
                     + f" | {med['wall']:.2f} |")
    if mitsuba:
        m = {k: median([r[k] for r in mitsuba]) for k in ("load", "first_image", "wall")}
        lines += ["", f"Mitsuba 3 `llvm_ad_rgb`, Cornell box (shared XML), its kernel cache warm: "
                      f"import + load {m['load']:.2f} s, first 1-spp image {m['first_image']:.2f} s, "
                      f"wall {m['wall']:.2f} s."]
    if mesh is not None:
        lines += mesh_lines(mesh, args.repeats)
    text = "\n".join(lines + ["", END_OF_RUN]) + "\n"
    print(text)
    if not args.no_write:
        put_run(RESULTS, "## Start-up", text)


if __name__ == "__main__":
    main()
