"""Scenes past one buffer texture: a displaced sphere of ``--triangles`` triangles (benchmarks/bvh.py
procedural_mesh; 50M by default) rendered at a few spp, with the seconds and memory of each
step, how many buffer textures each kind of geometry spans, and GL_RENDERER.

    .venv/bin/python benchmarks/large_meshes.py [--triangles 50e6] [--spp 4] [--size 256]
        [--texel-limit N]

A buffer texture holds GL_MAX_TEXTURE_BUFFER_SIZE texels (2^27 on llvmpipe): past 44.7M
triangles their corners and normals span several textures (shaders/geometry/bvh_layout.glsl).
``--texel-limit`` forces a smaller limit (glrender.gpu.bvh_upload.TEXEL_LIMIT, meant for tests)
so that a mesh the machine holds spans several textures too, to time the parts' fetches.

Memory is the limit on a CPU device: the mesh, the BVH build's work arrays, the packed
textures and the driver's copy of them peak near 830 bytes per triangle (``peak RSS`` below),
so 50M triangles want about 39 GiB. The script refuses up front a count whose estimate exceeds
the memory available (``--force`` runs it anyway).
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
# peak resident bytes per triangle, from runs of this script on llvmpipe (1M triangles: 0.90
# GiB, 5M: 3.99 GiB)
BYTES_PER_TRIANGLE = 830


def available_bytes() -> int:
    """MemAvailable of /proc/meminfo: what the machine can give without swapping."""
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemAvailable:"):
            return int(line.split()[1]) * 1024
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20   # kB -> GiB


def scene_of(v, f, size: int):
    from glrender.scene import model as m

    scene = m.Scene(film=m.Film(width=size, height=size, filter="box"), integrator=m.Integrator(max_depth=3),
                    source=f"<displaced sphere, {len(f):,} triangles>")
    scene.camera = m.Camera(world_from_camera=m.look_at((0.0, 0.5, 3.5), (0, 0, 0), (0, 1, 0)), fov=40)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.6, 0.6, 0.6)))
    scene.shapes.append(m.Shape("mesh", material=grey, vertices=v, triangles=f))
    scene.lights += [m.Light("point", position=(2.0, 3.0, 3.0), intensity=(20.0,) * 3),
                     m.Light("constant", radiance=(0.3, 0.3, 0.3))]
    return scene


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=float, default=50e6)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--texel-limit", type=int, default=None)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args(argv)
    want = BYTES_PER_TRIANGLE * args.triangles
    have = available_bytes()
    if want > have and not args.force:
        sys.exit(f"large_meshes: {args.triangles:,.0f} triangles want about {want / 2 ** 30:.1f} GiB, "
                 f"{have / 2 ** 30:.1f} GiB are available (--force runs it anyway)")

    import bvh as meshes
    from glrender.gl.context import default_context
    from glrender.gpu import bvh_upload
    from glrender.render.renderer import Renderer, settings_from_scene

    bvh_upload.TEXEL_LIMIT = args.texel_limit
    ctx = default_context()
    t0 = time.perf_counter()
    v, f = meshes.procedural_mesh(args.triangles)
    scene = scene_of(v, f, args.size)
    del v, f
    t_mesh = time.perf_counter() - t0
    settings = settings_from_scene(scene, spp=args.spp, seed=1, integrator="path")
    with Renderer(scene, settings, ctx=ctx) as r:
        parts = r.device_scene.defines()
        t1 = time.perf_counter()
        r.step(1)               # the first pass: kernel code generation and one spp
        ctx.gl.finish()
        t2 = time.perf_counter()
        r.step(args.spp - 1)
        ctx.gl.finish()
        t3 = time.perf_counter()
        mean = float(r.film().mean.mean())
        timings = r.timings
    info = ctx.gl.info
    print(f"device: {info['GL_RENDERER']} | {info['GL_VERSION']}")
    print(f"triangles: {len(scene.shapes[0].triangles):,}; texel limit "
          f"{bvh_upload.texel_limit(ctx.gl):,}; parts: {parts or 'one texture of each kind'}")
    print(f"mesh {t_mesh:.1f} s, pack {timings['pack']:.1f} s, "
          f"BVH build + upload {timings['build'] - timings['pack']:.1f} s, "
          f"compile {timings['compile']:.1f} s, first pass {t2 - t1:.1f} s, "
          f"{args.spp - 1} more spp at {args.size}x{args.size} {t3 - t2:.2f} s "
          f"({(args.spp - 1) * args.size ** 2 / max(t3 - t2, 1e-9) / 1e6:.3f} Mpaths/s)")
    print(f"peak RSS {peak_gb():.2f} GiB ({peak_gb() * 2 ** 30 / len(scene.shapes[0].triangles):.0f} "
          f"bytes/triangle); image mean {mean:.6f}")


if __name__ == "__main__":
    main()
