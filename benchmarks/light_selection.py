"""Which light selection to use by default: the efficiency of ``uniform``, ``power`` and ``bvh``
selection (next-event estimation of the path tracer) on scenes from one light to a thousand.

Scenes: a street between two walls (as tests/render/test_light_bvh.py's) lit by N lights, half
of them small one-sided emitters on the walls (two triangles each) (one in five turned to the wall), a quarter
point lights and a quarter spots, intensities log-uniform over three decades, under a dim
sky, for N = 1 .. 1024; and the bundled cornell-box, veach-mis and caustic. For each scene
and selection, in alternating rounds: ``--seeds`` renders of ``--spp`` samples per pixel
(independent sampler, max depth 4, 160 x 90 for the streets), the passes alone timed.
The renders' per-pixel variance across seeds is each pixel's expected squared error in one
render; efficiency is 1 / (variance x seconds), reported relative to uniform selection in two
ways: from the image's mean variance (its MSE, which the few pixels that see an emitter or its
mirror image directly dominate, whatever the selection) and the median over pixels of the
variance ratio (what most pixels gain). The load average stands beside the figures.

    .venv/bin/python benchmarks/light_selection.py [--rounds 2] [--seeds 4] [--spp 16]

Writes the "## Light selection by scene" section of benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import datetime
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
sys.path.insert(0, str(ROOT / "benchmarks"))
SELECTIONS = ("uniform", "power", "bvh")
STREET_LIGHTS = (1, 4, 16, 64, 256, 1024)
BUNDLED = ("cornell-box", "veach-mis", "caustic")
QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)


def street(n: int):
    """A street 40 long and 8 wide between walls, seen along its length, lit by n lights."""
    from glrender.scene import model as m
    from glrender.lab.scenes import street as furnish, street_lamp

    rng = np.random.default_rng(n)
    scene = m.Scene(film=m.Film(width=160, height=90, filter="box"), integrator=m.Integrator(max_depth=4),
                    source=f"<street, {n} lights>")
    black = furnish(scene)
    emitters = (n + 1) // 2
    for k in range(emitters):
        side = 1 if k % 2 else -1
        centre = (3.95 * side, rng.uniform(-19, 19), rng.uniform(0.5, 5.5))
        normal = (-side if k % 5 else side, rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3))
        radiance = 10 ** rng.uniform(0, 3) * rng.uniform(0.5, 1.0, 3) * 0.2
        frame = m.look_at(centre, np.add(centre, normal), (0, 0, 1))
        # a mesh quad: past the compiled primitives' budget, meshes go to the BVH
        scene.shapes.append(m.Shape("mesh", material=black, world_from_object=frame @ m.scale(0.1),
                                    vertices=QUAD, triangles=np.array([[0, 1, 2], [0, 2, 3]]),
                                    emission=m.Emission(tuple(radiance))))
    for k in range(n - emitters):
        scene.lights.append(street_lamp(rng, spot=k % 2 == 1))
    scene.lights.append(m.Light("constant", radiance=(0.01, 0.015, 0.03)))
    return scene


def scenes():
    import glrender
    from glrender.gpu.pack import pack_scene

    out = [(f"street, {n} lights", street(n)) for n in STREET_LIGHTS]
    for name in BUNDLED:
        scene = glrender.load(ROOT / "scenes" / name / "scene.toml")
        scene.film.width, scene.film.height = 96, 96
        out.append((name, scene))
    return [(name, scene, len(pack_scene(scene).lights)) for name, scene in out]


def measure(ctx, scene, selection: str, seeds: int, spp: int) -> tuple[float, np.ndarray]:
    """(seconds of a render's passes, per-pixel variance across the seeds' renders (H, W)):
    the passes alone are timed (the kernels are compiled and the light table built before)."""
    from glrender.render.renderer import Renderer, settings_from_scene

    images, seconds = [], []
    for seed in range(seeds):
        settings = settings_from_scene(scene, spp=spp, seed=seed, integrator="path",
                                       sampler="independent", light_selection=selection)
        with Renderer(scene, settings, ctx=ctx) as r:
            ctx.gl.finish()
            t0 = time.perf_counter()
            r.step(spp)
            ctx.gl.finish()
            seconds.append(time.perf_counter() - t0)
            images.append(r.film().mean)
    return statistics.median(seconds), np.stack(images).mean(axis=-1).var(axis=0, ddof=1)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--spp", type=int, default=16)
    args = parser.parse_args(argv)
    import results_md
    from glrender.gl.context import default_context

    ctx = default_context()
    cases = scenes()
    loads = [os.getloadavg()[0]]
    runs: dict[tuple[str, str], list[tuple[float, np.ndarray]]] = {}
    for _ in range(args.rounds):
        for name, scene, _ in cases:
            for selection in SELECTIONS:
                runs.setdefault((name, selection), []).append(measure(ctx, scene, selection, args.seeds, args.spp))
                loads.append(os.getloadavg()[0])
                seconds, variance = runs[name, selection][-1]
                print(name, selection, seconds, variance.mean(), flush=True)
    info = ctx.gl.info
    lines = [
        "## Light selection by scene", "",
        f"`benchmarks/light_selection.py --rounds {args.rounds} --seeds {args.seeds} --spp {args.spp}`, "
        f"commit {results_md.commit()}, {datetime.date.today()}, device `{info['GL_RENDERER']}`, load "
        f"average {min(loads):.1f}-{max(loads):.1f}. Path tracer, max depth 4, independent sampler. "
        f"Efficiency 1 / (variance x seconds), variances from the spread of {args.seeds} seeds' "
        f"renders (pooled over rounds), seconds the median render; relative to uniform selection, "
        f"by the image's MSE and by the median pixel's variance. Lights: the light records (an "
        f"emitting mesh's triangles each, the sky one).", "",
        "| scene | lights | uniform: ms per spp | power vs uniform (MSE, median pixel) | "
        "bvh vs uniform (MSE, median pixel) | bvh vs power (MSE, median pixel) |",
        "|---|---|---|---|---|---|",
    ]
    for name, scene, lights in cases:
        seconds = {sel: statistics.median(r[0] for r in runs[name, sel]) for sel in SELECTIONS}
        var = {sel: np.mean([r[1] for r in runs[name, sel]], axis=0) for sel in SELECTIONS}

        def ratio(a, b):
            mse = (var[b].mean() * seconds[b]) / max(var[a].mean() * seconds[a], 1e-300)
            lit = (var[a] > 0) & (var[b] > 0)
            pixel = float(np.median(var[b][lit] / var[a][lit])) * seconds[b] / seconds[a] if lit.any() else 1.0
            return f"{mse:.2f}, {pixel:.2f}"

        lines.append(f"| {name} | {lights} | {1e3 * seconds['uniform'] / args.spp:.1f} | "
                     f"{ratio('power', 'uniform')} | {ratio('bvh', 'uniform')} | {ratio('bvh', 'power')} |")
    text = "\n".join(lines)
    print(text)
    results_md.put_run(RESULTS, "## Light selection by scene", text + "\n")


if __name__ == "__main__":
    main()
