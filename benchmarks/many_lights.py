"""Many lights: glrender's light selections for next-event estimation against Cycles' light
tree and Mitsuba 3's emitter sampling, at equal time, on scenes/many-lights (a street at
night: 5,000 lit windows, 250 spot and 250 point lights, powers over three decades).

Configs, each in its own process for the same time after its warm-up, alternated in rounds
(medians reported): glrender's path tracer with each light selection of SELECTIONS that the
scene model accepts (one it does not yet accept is skipped with a note); Mitsuba 3's path
tracer (llvm_ad_rgb, independent sampler, on the scene's XML twin) with its default emitter
sampling and with emitters weighted by power; Blender Cycles with its light tree on and off
(the same triangles, materials and lights as glrender packs them, built through bpy by
benchmarks/many_lights_cycles.py). Mitsuba 3.9 picks an emitter in proportion to its
``sampling_weight`` (default 1: uniform over the scene's 5,501 emitters, each window's mesh
being one; a point within a mesh by area): "by power" sets those weights to the weights of
glrender's power selection. All render max depth 6 at 160 x 90 (box filter).

Reported: spp/s, RMSE and mean against the reference (benchmarks/many_lights_reference.py:
glrender's power selection at long time, checked against Mitsuba's renders of the XML twin;
its own noise subtracted), efficiency 1 / (MSE x time) and its ratios to glrender's power
selection and to Cycles with its light tree, the load average beside each figure. Targets (the light BVH's): bvh at least 5x the efficiency of power
selection, and ahead of Cycles' light tree. Writes the "## Many lights" section of
benchmarks/RESULTS.md (the notes after its run stay).

Needs: Mitsuba (the bench extra) with Debian's libllvm19; for Cycles, Blender's module in a
Python 3.11 environment of its own (``python3.11 -m venv bpy && bpy/bin/pip install bpy==5.0.1
numpy``) named by ``--bpy-python`` or $GLRENDER_BPY_PYTHON (without it the Cycles rows are
skipped, with a note).

    .venv/bin/python benchmarks/many_lights.py [--seconds 5] [--rounds 3] [--bpy-python PATH]
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cornell_vs_mitsuba import LLVM, ROOT, run  # noqa: E402
from results_md import commit, put_run_with_targets  # noqa: E402

SCENE = ROOT / "scenes" / "many-lights" / "scene.toml"
XML = SCENE.with_suffix(".xml")
REFERENCE = ROOT / "benchmarks" / "refs" / "many-lights-ref.npy"
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MARKER = "## Many lights"
CYCLES_SCRIPT = ROOT / "benchmarks" / "many_lights_cycles.py"
# every light selection the benchmark measures once the scene model accepts it
SELECTIONS = ("uniform", "power", "bvh")
WIDTH, HEIGHT = 160, 90
BASELINE, PEER = "glrender power", "Cycles, light tree"
TARGET_VS_POWER, TARGET_VS_PEER = 5.0, 1.0

GLRENDER_SCRIPT = r"""
import json, sys, time, numpy as np, glrender
from glrender.render.renderer import Renderer, settings_from_scene
toml, selection, width, height, seconds, seed, out = sys.argv[1:8]
scene = glrender.load(toml)
scene.film = scene.film.resized(int(width), int(height))
r = Renderer(scene, settings_from_scene(scene, light_selection=selection, seed=int(seed), spp=1 << 20))
r.step(r.samples_per_pass)   # warm-up: the first pass's dispatches
r.reset()
t0 = time.perf_counter()
while time.perf_counter() - t0 < float(seconds):
    r.step(r.samples_per_pass)
t = time.perf_counter() - t0
f = r.film()
np.save(out, f.mean)
print(json.dumps({"seconds": t, "spp": f.spp, "device": r.ctx.renderer}))
"""

# Mitsuba's side: the XML at the given size, with each emitter's sampling_weight (in the
# order the emitters appear in the file) from a .npy when one is given ("-": Mitsuba's own)
MITSUBA_SCRIPT = r"""
import json, re, sys, time, numpy as np, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
xml, weights, width, height, seconds, seed, out = sys.argv[1:8]
text = open(xml).read()
text = re.sub(r'name="width" value="\d+"', f'name="width" value="{width}"', text)
text = re.sub(r'name="height" value="\d+"', f'name="height" value="{height}"', text)
if weights != "-":
    w = iter(np.load(weights))
    text = re.sub(r'(<emitter type="[a-z]+">)', lambda m: m.group(1) +
                  f'<float name="sampling_weight" value="{next(w):.9g}"/>', text)
scene = mi.load_string(text)
def render(k):
    return np.array(mi.render(scene, spp=16, seed=k), dtype=np.float64)
render(2**31 - 1)  # warm-up: JIT compilation
acc, n, t0 = 0.0, 0, time.perf_counter()
while n == 0 or time.perf_counter() - t0 < float(seconds):
    acc = acc + render(int(seed) * 100000 + n)
    n += 1
t = time.perf_counter() - t0
np.save(out, (acc / n)[..., :3].astype(np.float32))
print(json.dumps({"seconds": t, "spp": 16 * n, "version": mi.__version__}))
"""


def selections() -> tuple[list[str], list[str]]:
    """SELECTIONS split into those the scene model accepts and those it does not yet."""
    from glrender.errors import SceneError
    from glrender.scene.model import Integrator

    accepted, missing = [], []
    for name in SELECTIONS:
        try:
            Integrator(light_selection=name)
            accepted.append(name)
        except SceneError:
            missing.append(name)
    return accepted, missing


def _emitters_per_shape(shape) -> int:
    """The area lights glrender packs for one emissive shape (lights in pack order)."""
    return {"rectangle": 1, "sphere": 1, "cube": 6}.get(shape.kind) or len(shape.triangles)


def mitsuba_weights(path: Path) -> np.ndarray:
    """Each emitter of the XML scene ``path``, in the order of the file, weighted as glrender's
    power selection weights it (a mesh emitter: the sum over its triangles). The file must
    give its lights before its emitting shapes (Mitsuba's order is the file's; glrender packs
    area lights first)."""
    import glrender
    from glrender.gpu.pack import pack_scene

    scene = glrender.load(path)
    text = path.read_text()
    if text.count("<emitter", 0, text.find("<shape")) != len(scene.lights):
        raise SystemExit(f"{path}: lights must come before the emitting shapes")
    weights = pack_scene(scene).light_weights
    counts = [_emitters_per_shape(s) for s in scene.shapes if s.emission is not None]
    n_area = sum(counts)
    per_shape = np.add.reduceat(weights[:n_area], np.cumsum([0] + counts[:-1])) if counts else []
    return np.concatenate([weights[n_area:], per_shape])


def cycles_scene(path: Path, out: Path, threads: int) -> None:
    """The scene as many_lights_cycles.py reads it (.npz): glrender's packed world-space
    triangles with their materials and emission, its point and spot lights, background and
    camera at the benchmark's size."""
    import glrender
    from glrender.gpu import bindings
    from glrender.gpu.pack import pack_scene

    scene = glrender.load(path)
    if any(mat.kind != "diffuse" for mat in scene.materials):
        raise SystemExit(f"{path}: the Cycles build knows diffuse materials only")
    packed = pack_scene(scene)
    if packed.spheres or packed.moving_meshes:
        raise SystemExit(f"{path}: the Cycles build knows triangles and parallelograms only")
    tris, material, light = [], [], []
    for q in packed.quads:
        c = q.corner
        faces = [(c, c + q.e1, c + q.e2)] if q.triangle else [(c, c + q.e1, c + q.e1 + q.e2),
                                                              (c, c + q.e1 + q.e2, c + q.e2)]
        for f in faces:
            tris.append(f[::-1] if q.flip else f)   # the front faces e1 x e2 unless flipped
            material.append(q.material)
            light.append(q.light)
    if packed.mesh is not None:
        positions, _, _, mesh_material, mesh_light = packed.mesh
        tris += list(positions)
        material += list(mesh_material)
        light += list(mesh_light)
    light = np.asarray(light, np.int64)
    records = packed.lights
    emission = np.where(light[:, None] > 0, records["radiance"][np.maximum(light - 1, 0), :3], 0.0)
    two_sided = (light > 0) & ((records["info"][np.maximum(light - 1, 0), 1] &
                                bindings.LIGHT_FLAG_TWO_SIDED) != 0)
    points = [lt for lt in scene.lights if lt.kind == "point"]
    spots = [lt for lt in scene.lights if lt.kind == "spot"]
    if len({(s.cutoff_angle, s.beam_width) for s in spots}) > 1:
        raise SystemExit(f"{path}: the Cycles build takes one spot cone for all spots")
    background = next((lt.radiance for lt in scene.lights if lt.kind == "constant"), (0.0, 0.0, 0.0))
    intensity = lambda lt: np.asarray(lt.power) / (4 * np.pi) if lt.power is not None \
        else np.asarray(lt.intensity)  # noqa: E731
    meta = {"width": WIDTH, "height": HEIGHT, "fov": scene.camera.fov, "fov_axis": scene.camera.fov_axis,
            "max_depth": scene.integrator.max_depth, "background": list(background), "threads": threads}
    np.savez(out, meta=json.dumps(meta), positions=np.asarray(tris, np.float64),
             material=np.asarray(material, np.int64), emission=emission, two_sided=two_sided,
             reflectance=np.array([mat.reflectance for mat in scene.materials], np.float64),
             point_position=np.array([lt.position for lt in points], np.float64).reshape(-1, 3),
             point_intensity=np.array([intensity(lt) for lt in points], np.float64).reshape(-1, 3),
             spot_world=np.array([lt.world_from_light for lt in spots], np.float64).reshape(-1, 4, 4),
             spot_intensity=np.array([intensity(lt) for lt in spots], np.float64).reshape(-1, 3),
             spot_angles=np.array([spots[0].cutoff_angle, spots[0].beam_width] if spots else [0.0, 0.0]),
             camera=scene.camera.world_from_camera)


def bpy_python(given: str | None) -> str | None:
    """The Python that has Blender's module: ``--bpy-python``, $GLRENDER_BPY_PYTHON, or this
    one if it has bpy."""
    path = given or os.environ.get("GLRENDER_BPY_PYTHON")
    if path:
        return path
    import importlib.util
    return sys.executable if importlib.util.find_spec("bpy") else None


def configs(tmp: Path, bpy: str | None) -> list[tuple[str, list[str], dict]]:
    """(label, command that takes SECONDS SEED OUT, environment) of every config."""
    accepted, missing = selections()
    for name in missing:
        print(f"note: light selection {name!r} is not accepted by the scene model yet: skipped", flush=True)
    out = [(f"glrender {s}", [sys.executable, "-c", GLRENDER_SCRIPT, str(SCENE), s, str(WIDTH), str(HEIGHT)], {})
           for s in accepted]
    weights = tmp / "mitsuba-weights.npy"
    np.save(weights, mitsuba_weights(XML))
    mitsuba = {"DRJIT_LIBLLVM_PATH": LLVM}
    out += [("Mitsuba, uniform (its default)", [sys.executable, "-c", MITSUBA_SCRIPT, str(XML), "-",
                                                 str(WIDTH), str(HEIGHT)], mitsuba),
            ("Mitsuba, by power", [sys.executable, "-c", MITSUBA_SCRIPT, str(XML), str(weights),
                                   str(WIDTH), str(HEIGHT)], mitsuba)]
    if bpy is None:
        print("note: no Python with Blender's bpy (--bpy-python, $GLRENDER_BPY_PYTHON): Cycles skipped",
              flush=True)
        return out
    description = tmp / "cycles-scene.npz"
    cycles_scene(SCENE, description, os.cpu_count() or 1)
    for label, tree in ((PEER, "1"), ("Cycles, no light tree", "0")):
        out.append((label, [bpy, str(CYCLES_SCRIPT), str(description), tree], {}))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="render time per config")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds (medians reported)")
    ap.add_argument("--bpy-python", default=None, help="a Python with Blender's bpy module (Cycles)")
    args = ap.parse_args()
    if not REFERENCE.exists():
        raise SystemExit(f"{REFERENCE}: no reference (run benchmarks/many_lights_reference.py first)")
    ref = np.load(REFERENCE).astype(np.float64)
    # the reference's own noise, subtracted from every MSE
    ref_noise = float((np.load(REFERENCE.with_name("many-lights-ref-stderr.npy")).astype(np.float64) ** 2).mean())
    load_start = os.getloadavg()[0]
    results: dict[str, list[dict]] = {}
    device = None
    with tempfile.TemporaryDirectory(prefix="glrender-many-lights-") as tmp:
        tmp = Path(tmp)
        table = configs(tmp, bpy_python(args.bpy_python))
        for rnd in range(args.rounds):
            for label, command, env in table:
                out = tmp / f"{label.replace(' ', '_').replace(',', '')}-{rnd}.npy"
                info = run(command + [str(args.seconds), str(rnd + 1), str(out)], env=env, cwd=XML.parent)
                device = info.get("device", device)
                img = np.load(out).astype(np.float64)[..., :3]
                mse = max(float(((img - ref) ** 2).mean()) - ref_noise, 1e-30)
                load = os.getloadavg()[0]
                results.setdefault(label, []).append({
                    "seconds": info["seconds"], "spp": info["spp"], "mse": mse, "load": load,
                    "spp_s": info["spp"] / info["seconds"], "mean": float(img.mean() / ref.mean() - 1)})
                print(f"round {rnd + 1} {label:30s} {info['spp']:6d} spp  RMSE {mse ** 0.5:.4g}  "
                      f"mean {img.mean() / ref.mean() - 1:+.2%}  efficiency {1 / (mse * info['seconds']):.4g}  "
                      f"(load average {load:.2f})", flush=True)
    med = {label: {k: float(np.median([r[k] for r in rs])) for k in rs[0]} for label, rs in results.items()}
    for m in med.values():
        m["eff"] = 1.0 / (m["mse"] * m["seconds"])
    write_results(med, device, args, (load_start, os.getloadavg()[0]))


def targets(med: dict) -> list[str]:
    """The light BVH's two targets, met or missed (or why they cannot be judged yet)."""
    if "glrender bvh" not in med:
        return ["- bvh selection: not accepted by the scene model yet; the targets (at least "
                f"{TARGET_VS_POWER:g}x power selection's efficiency, ahead of Cycles' light tree) wait for it."]
    bvh = med["glrender bvh"]["eff"]
    lines = []
    for base, target in ((BASELINE, TARGET_VS_POWER), (PEER, TARGET_VS_PEER)):
        if base not in med:
            lines.append(f"- bvh vs {base}: not measured in this run.")
            continue
        r = bvh / med[base]["eff"]
        lines.append(f"- bvh selection's efficiency is {r:.3g}x {base}'s; target at least {target:g}x: "
                     f"{'met' if r >= target else 'missed'}.")
    return lines


def write_results(med: dict, device, args, load) -> None:
    lines = [f"{MARKER}: light selection for next-event estimation vs Cycles and Mitsuba 3 (equal time)", "",
             f"{datetime.date.today()}, commit `{commit()}`, glrender on `{device}`; Mitsuba 3 `llvm_ad_rgb` and "
             f"Cycles on the same CPU ({os.cpu_count()} cores, shared with other work: timings are noisy; load "
             f"average {load[0]:.2f} at the start, {load[1]:.2f} at the end). scenes/many-lights at {WIDTH} x "
             f"{HEIGHT}, max depth 6; each config renders {args.seconds:g} s after its warm-up, {args.rounds} "
             f"alternating round(s), medians. MSE against benchmarks/refs/many-lights-ref.npy (glrender, power "
             f"selection, long time; checked against Mitsuba: many-lights-ref.json) minus the reference's own "
             f"noise; efficiency = 1/(MSE x time). Mitsuba 3.9 picks an "
             f"emitter in proportion to its `sampling_weight` (default 1: uniform over its 5,501 emitters, a "
             f"window's mesh being one); 'by power' sets the weights to glrender's power weights. Rerun: "
             f"`.venv/bin/python benchmarks/many_lights.py --bpy-python PATH` (reference: "
             f"`benchmarks/many_lights_reference.py`).", "",
             "| renderer, light selection | spp/s | RMSE | mean vs ref | efficiency | vs glrender power | "
             "vs Cycles light tree | load average |",
             "|---|---|---|---|---|---|---|---|"]
    for label, m in med.items():
        vs = [f"{m['eff'] / med[b]['eff']:.3g}x" if b in med else "—" for b in (BASELINE, PEER)]
        lines.append(f"| {label} | {m['spp_s']:.1f} | {m['mse'] ** 0.5:.4g} | {m['mean']:+.2%} | "
                     f"{m['eff']:.4g} | {vs[0]} | {vs[1]} | {m['load']:.2f} |")
    print(put_run_with_targets(RESULTS, MARKER, lines, targets(med)))


if __name__ == "__main__":
    main()
