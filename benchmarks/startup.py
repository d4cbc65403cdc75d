"""Start-up: seconds from the command to the first finished pass, cold and warm shader cache.

Runs ``glrender render SCENE --spp 8`` (one pass) in a fresh process per measurement and
reads the phases from its ``--stats`` file: load (parse scene and meshes), context (EGL),
build (BVH, packing, upload), compile (GLSL compile and link plus llvmpipe's code
generation at the first dispatch), render (the pass) and the process's wall time.

- cold: ``MESA_SHADER_CACHE_DIR`` points at a new, empty folder, so every kernel is
  compiled from source;
- warm: the same folder again, so Mesa finds the compiled kernels on disk.

The cache location is Mesa's: ``MESA_SHADER_CACHE_DIR`` (default ``~/.cache/mesa_shader_cache``;
``MESA_SHADER_CACHE_DISABLE=true`` turns it off). Mitsuba 3 (``llvm_ad_rgb``) is timed in
the same run for the Cornell box from the shared scene (process start to its first
1-spp image, its own kernel cache warm), when it is installed.

    .venv/bin/python benchmarks/startup.py [--repeats 3] [--scenes cornell-box,cornell-bunny,caustic]

Writes the "## Start-up" section of benchmarks/RESULTS.md (other sections are kept).
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
SHARED = Path(os.environ.get("GLRENDER_SHARED", ROOT.parent / "shared"))
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
PHASES = ("load", "context", "build", "compile", "render")

MITSUBA_SCRIPT = r"""
import sys, time
t0 = time.perf_counter()
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_file(sys.argv[1])
t1 = time.perf_counter()
img = mi.render(scene, spp=1)
img.numpy()
print(t1 - t0, time.perf_counter() - t1)
"""


def run_glrender(scene: Path, cache: Path) -> dict:
    env = dict(os.environ, MESA_SHADER_CACHE_DIR=str(cache))
    env.pop("MESA_SHADER_CACHE_DISABLE", None)
    with tempfile.TemporaryDirectory() as tmp:
        stats = Path(tmp) / "stats.json"
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "glrender", "render", str(scene), "--spp", "8",
                            "-o", str(Path(tmp) / "out.exr"), "--stats", str(stats), "--quiet"],
                           env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if r.returncode != 0:
            raise SystemExit(f"glrender failed on {scene}: {r.stderr.strip()}")
        data = json.loads(stats.read_text())
    seconds = {k: data["seconds"][k] for k in PHASES}
    seconds["wall"] = wall
    return {"seconds": seconds,
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
    load, first = map(float, r.stdout.split())
    return {"load": load, "first_image": first, "wall": wall}


def median(values):
    values = sorted(values)
    return values[len(values) // 2]


def commit() -> str:
    r = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                       text=True)
    return r.stdout.strip() or "unknown"


def write_section(text: str) -> None:
    """Replace the "## Start-up" section of RESULTS.md."""
    old = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    head, sep, rest = old.partition("\n## Start-up\n")
    if sep:
        nxt = rest.find("\n## ")
        rest = rest[nxt + 1:] if nxt >= 0 else ""
        old = head.rstrip("\n") + "\n\n" + text.rstrip("\n") + "\n\n" + rest
    else:
        old = old.rstrip("\n") + "\n\n" + text.rstrip("\n") + "\n"
    RESULTS.write_text(old.rstrip("\n") + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default="cornell-box,cornell-bunny,caustic")
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    args = ap.parse_args()

    rows, device = [], None
    for name in args.scenes.split(","):
        scene = ROOT / "scenes" / name / "scene.toml"
        cold, warm = [], []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as cache:
                c = run_glrender(scene, Path(cache))
                w = run_glrender(scene, Path(cache))
            device = c["device"]
            cold.append(c["seconds"])
            warm.append(w["seconds"])
        for label, runs in (("cold", cold), ("warm", warm)):
            med = {k: median([r[k] for r in runs]) for k in (*PHASES, "wall")}
            rows.append((name, label, med))
            print(name, label, {k: round(v, 2) for k, v in med.items()}, flush=True)

    mitsuba = [m for m in (run_mitsuba(SHARED / "refs" / "cornell-box.xml")
                           for _ in range(args.repeats)) if m]
    lines = [
        "## Start-up",
        "",
        f"`benchmarks/startup.py --repeats {args.repeats}`, commit {commit()}, "
        f"{datetime.date.today().isoformat()}, device `{device}`. Seconds from the command to "
        "the end of the first pass (8 spp at the scene's resolution), medians of "
        f"{args.repeats} fresh processes; cold: an empty `MESA_SHADER_CACHE_DIR`, warm: the "
        "same folder again. `compile` is GLSL compile and link plus llvmpipe's code generation "
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
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section(text)


if __name__ == "__main__":
    main()
