"""glrender against Mitsuba 3 on the same CPU, in the same run, at equal time.

Scenes: the Cornell box (shared reference), the Cornell box with the Stanford bunny
(a BVH scene; its reference is rendered once by Mitsuba and cached), the same with the
bunny split into 1.1M triangles (each triangle into 16 at its edges' midpoints, twice: the
same surface, a BVH 16 times larger; made in the temporary folder, reference cached), and
the caustic scene (shared reference). Peers: Mitsuba 3 ``llvm_ad_rgb`` path tracer with its default
independent sampler and with multijitter (its best here). Every renderer runs in its
own process, rounds alternate, and each config renders for the same wall time after a
warm-up (kernel compilation excluded for everyone).

Reported per scene and config: Mpaths/s, MSE against the reference (minus the
reference's own noise where it is known), efficiency 1 / (MSE * time) and its ratio to
each Mitsuba config, and the time to reach the MSE Mitsuba-multijitter reached
(t * MSE / MSE_target, from MSE ~ 1/t). The table goes to benchmarks/RESULTS.md with
GL_RENDERER and the commit.

Needs: the bench extra (``pip install -e .[bench]``: mitsuba), Debian's ``libllvm19``
for Mitsuba's LLVM variant, and ../shared (refs, peers). Usage:

    .venv/bin/python benchmarks/cornell_vs_mitsuba.py [--seconds 10] [--rounds 2] [--scenes cornell,bunny,bunny1m,caustic]
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

from results_md import put_run

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("GLRENDER_SHARED", ROOT.parent / "shared"))
REFS = SHARED / "refs"
CACHE = ROOT / "benchmarks" / "refs"
LLVM = os.environ.get("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")

BUNNY_SHAPE = """  <shape type="ply" id="bunny">
    <string name="filename" value="{ply}"/>
    <transform name="to_world"><matrix value="7 0 0 -0.21 0 7 0 -1.23 0 0 7 -0.27 0 0 0 1"/></transform>
    <ref id="white"/>
  </shape>
"""

MITSUBA_SCRIPT = r"""
import json, sys, time, numpy as np, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
xml, sampler, seconds, spp_pass, seed, out = sys.argv[1:7]
seconds, spp_pass, seed = float(seconds), int(spp_pass), int(seed)
text = open(xml).read().replace('<sampler type="independent">', f'<sampler type="{sampler}">')
scene = mi.load_string(text)
def render(k):
    return np.array(mi.render(scene, spp=spp_pass, seed=k), dtype=np.float64)
render(2**31 - 1)  # warm-up: JIT compilation
acc, n, t0 = None, 0, time.perf_counter()
while True:
    img = render(seed * 100000 + n)
    acc = img if acc is None else acc + img
    n += 1
    if time.perf_counter() - t0 >= seconds:
        break
t = time.perf_counter() - t0
np.save(out, (acc / n)[..., :3].astype(np.float32))
print(json.dumps({"seconds": t, "spp": n * spp_pass, "version": mi.__version__}))
"""

GLRENDER_SCRIPT = r"""
import json, sys, time, numpy as np, glrender
from glrender.render.renderer import Renderer, settings_from_scene
toml, sampler, seconds, seed, out = sys.argv[1:6]
seconds, seed = float(seconds), int(seed)
scene = glrender.load(toml)
r = Renderer(scene, settings_from_scene(scene, sampler=sampler, seed=seed, spp=1 << 20))
t0 = time.perf_counter()
while time.perf_counter() - t0 < seconds:
    r.step(r.samples_per_pass)
t = time.perf_counter() - t0
f = r.film()
np.save(out, f.mean)
print(json.dumps({"seconds": t, "spp": f.spp, "device": r.ctx.renderer,
                  "gl_version": r.ctx.gl.info["GL_VERSION"], "nonfinite": f.nonfinite_total}))
"""


def run(cmd, env=None, cwd=None) -> dict:
    """Run a benchmark step; its JSON summary (the last line it prints). ``cwd``: where it
    runs (a Mitsuba scene loaded from a string finds its files there)."""
    result = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **(env or {})},
                            cwd=cwd)
    if result.returncode != 0:
        raise SystemExit(f"benchmark step failed: {' '.join(map(str, cmd[:3]))}...\n{result.stderr[-2000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def scenes(tmp: Path) -> dict:
    """name -> (Mitsuba XML, glrender TOML, reference .npy or None, reference MSE)."""
    xml = (REFS / "cornell-box.xml").read_text()
    large = xml.index('<shape type="cube" id="large-box">')
    end = xml.index("</shape>", large) + len("</shape>\n")
    bunny_xml = tmp / "cornell-bunny.xml"
    bunny_xml.write_text(xml[:large] + BUNNY_SHAPE.format(ply=ROOT / "scenes/cornell-bunny/bunny.ply") +
                         xml[end:])
    ply_1m = bunny_1m(tmp)
    bunny_1m_xml = tmp / "cornell-bunny-1m.xml"
    bunny_1m_xml.write_text(xml[:large] + BUNNY_SHAPE.format(ply=ply_1m) + xml[end:])
    bunny_1m_toml = tmp / "cornell-bunny-1m.toml"
    bunny_1m_toml.write_text((ROOT / "scenes/cornell-bunny/scene.toml").read_text().replace(
        'file = "bunny.ply"', f'file = "{ply_1m}"'))
    caustic_xml = tmp / "caustic.xml"
    caustic_xml.write_text((REFS / "caustic" / "caustic.xml").read_text().replace(
        "caustic-sphere.obj", str(REFS / "caustic" / "caustic-sphere.obj")))
    return {
        "cornell": (REFS / "cornell-box.xml", ROOT / "scenes/cornell-box/scene.toml",
                    REFS / "cornell-box-ref.npy", 7.8e-8),
        "bunny": (bunny_xml, ROOT / "scenes/cornell-bunny/scene.toml", CACHE / "cornell-bunny-ref.npy", None),
        "bunny1m": (bunny_1m_xml, bunny_1m_toml, CACHE / "cornell-bunny-1m-ref.npy", None),
        "caustic": (caustic_xml, ROOT / "scenes/caustic/scene.toml", REFS / "caustic" / "caustic-ref.npy", None),
    }


def bunny_1m(tmp: Path) -> Path:
    """scenes/cornell-bunny/bunny.ply with every triangle split into 16 (binary PLY in tmp)."""
    import trimesh

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bvh import subdivide

    mesh = trimesh.load(ROOT / "scenes/cornell-bunny/bunny.ply", process=False)
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    for _ in range(2):
        v, f = subdivide(v, f)
    out = tmp / "bunny-1m.ply"
    trimesh.Trimesh(v.astype(np.float32), f, process=False).export(out)
    return out


def ensure_reference(name, xml, ref_path, tmp, seconds=600.0):
    if ref_path.exists():
        return
    print(f"[{name}] rendering a Mitsuba reference ({seconds:.0f} s, multijitter)...", flush=True)
    out = tmp / f"{name}-ref.npy"
    info = run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml), "multijitter", str(seconds), "256", "7",
                str(out)], env={"DRJIT_LIBLLVM_PATH": LLVM})
    ref_path.parent.mkdir(parents=True, exist_ok=True)
    np.save(ref_path, np.load(out))
    (ref_path.with_suffix(".json")).write_text(json.dumps({**info, "sampler": "multijitter"}, indent=1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="render time per config")
    ap.add_argument("--rounds", type=int, default=2, help="alternating rounds (medians reported)")
    ap.add_argument("--scenes", default="cornell,bunny,bunny1m,caustic")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "RESULTS.md"))
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="glrender-bench-"))
    table = scenes(tmp)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip()
    rows, device = [], None
    for name in args.scenes.split(","):
        xml, toml, ref_path, ref_mse = table[name]
        ensure_reference(name, xml, ref_path, tmp)
        ref = np.load(ref_path).astype(np.float64)[..., :3]
        results = {}
        configs = [("Mitsuba independent", "mitsuba", "independent"),
                   ("Mitsuba multijitter", "mitsuba", "multijitter"),
                   ("glrender sobol", "glrender", "sobol"),
                   ("glrender independent", "glrender", "independent")]
        for rnd in range(args.rounds):
            for label, who, sampler in configs:
                out = tmp / f"{name}-{who}-{sampler}-{rnd}.npy"
                if who == "mitsuba":
                    info = run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml), sampler, str(args.seconds),
                                "16", str(rnd + 1), str(out)], env={"DRJIT_LIBLLVM_PATH": LLVM})
                else:
                    info = run([sys.executable, "-c", GLRENDER_SCRIPT, str(toml), sampler, str(args.seconds),
                                str(rnd + 1), str(out)])
                    device = f"{info['device']}, {info['gl_version']}"
                img = np.load(out).astype(np.float64)
                mse = max(float(((img - ref) ** 2).mean()) - (ref_mse or 0.0), 1e-30)
                paths = img.shape[0] * img.shape[1] * info["spp"]
                results.setdefault(label, []).append({
                    "seconds": info["seconds"], "spp": info["spp"], "mse": mse,
                    "mpaths": paths / info["seconds"] / 1e6, "eff": 1.0 / (mse * info["seconds"]),
                    "mean": float(img.mean() / ref.mean() - 1)})
                print(f"[{name}] round {rnd + 1} {label:22s} {info['spp']:6d} spp "
                      f"{paths / info['seconds'] / 1e6:6.2f} Mpaths/s  MSE {mse:.3e}  "
                      f"mean {img.mean() / ref.mean() - 1:+.3%}", flush=True)
        med = {label: {k: float(np.median([r[k] for r in rs])) for k in rs[0]} for label, rs in results.items()}
        base_ind, base_mj = med["Mitsuba independent"], med["Mitsuba multijitter"]
        for label, m in med.items():
            rows.append((name, label, m, m["eff"] / base_ind["eff"], m["eff"] / base_mj["eff"],
                         m["mpaths"] / base_ind["mpaths"],
                         m["seconds"] * m["mse"] / base_mj["mse"]))
    write_results(Path(args.out), rows, device, commit, args)


def write_results(path: Path, rows, device, commit, args):
    lines = [f"## Cornell box, Cornell + bunny, caustic: glrender vs Mitsuba 3 (equal time)", "",
             "Scenes: cornell (compiled quads), bunny (69k triangles), bunny1m (the same bunny in "
             "1.1M triangles), caustic (glass icosphere).", "",
             f"{datetime.date.today()}, commit `{commit}`, glrender on `{device}`; Mitsuba 3 `llvm_ad_rgb` "
             f"(path tracer, max depth 8) on the same CPU, {os.cpu_count()} cores. Each config renders "
             f"{args.seconds:.0f} s after a warm-up, {args.rounds} alternating rounds, medians. Efficiency = "
             f"1/(MSE x time) against the scene's reference; 'time to MJ MSE' = time to reach the MSE "
             f"Mitsuba-multijitter reached (from MSE ~ 1/t). Rerun: "
             f"`.venv/bin/python benchmarks/cornell_vs_mitsuba.py`.", "",
             "| scene | renderer | spp | Mpaths/s | MSE | mean vs ref | efficiency | vs Mitsuba indep. | "
             "vs Mitsuba multijitter | Mpaths/s vs Mitsuba | time to MJ MSE |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, label, m, r_ind, r_mj, r_speed, t_mj in rows:
        lines.append(f"| {name} | {label} | {m['spp']:.0f} | {m['mpaths']:.2f} | {m['mse']:.3e} | "
                     f"{m['mean']:+.2%} | {m['eff']:.3g} | {r_ind:.2f}x | {r_mj:.2f}x | {r_speed:.2f}x | "
                     f"{t_mj:.1f} s |")
    section = "\n".join(lines) + "\n"
    put_run(path, "## Cornell box, Cornell + bunny, caustic", section)
    print(section)


if __name__ == "__main__":
    main()
