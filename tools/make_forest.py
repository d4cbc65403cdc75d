#!/usr/bin/env python3
"""Write scenes/forest/: 10,000 trees of 104,448 triangles each (over a billion triangles
placed), the scene of two-level instancing (one tree's triangles, shared by every copy).

A tree is a trunk (a tapered cylinder, ``trunk.ply``) and a crown of five lumpy blobs
(icospheres of 20,480 triangles each, pushed in and out by a sum of sines, ``crown.ply``):
102,400 crown triangles, 2,048 trunk triangles. The 10,000 copies stand on a jittered
100 x 100 grid (3 units apart) over a 300 x 300 ground, each turned about the vertical and
scaled by 0.7 to 1.3 (``instances.npy``: float32 (10000, 4, 4) row-major world_from_object
matrices, which both shapes of scene.toml name). The sun is low and a blue sky fills the
shadows; the camera stands at the edge and looks across the wood.

Everything comes from one seeded generator, so the files are made again byte for byte.

    .venv/bin/python tools/make_forest.py
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "scenes" / "forest"
SEED = 1996
GRID = 100
SPACING = 3.0


def crown(rng: np.random.Generator) -> trimesh.Trimesh:
    parts = []
    centres = [(0, 0, 3.2), (0.55, 0.2, 2.6), (-0.5, 0.35, 2.7), (0.1, -0.55, 2.5), (0.0, 0.1, 3.9)]
    radii = [1.0, 0.75, 0.75, 0.7, 0.6]
    for centre, radius in zip(centres, radii):
        ball = trimesh.creation.icosphere(subdivisions=5)
        v = np.asarray(ball.vertices, np.float64)
        freq = rng.uniform(3, 7, (4, 3))
        phase = rng.uniform(0, 2 * np.pi, 4)
        bump = sum(np.sin(v @ f + p) for f, p in zip(freq, phase)) / 4
        v = v * (radius * (1 + 0.12 * bump))[:, None] + np.asarray(centre)
        parts.append(trimesh.Trimesh(v, ball.faces, process=False))
    return trimesh.util.concatenate(parts)


def trunk() -> trimesh.Trimesh:
    sections, rings = 64, 16
    z = np.linspace(0, 2.8, rings + 1)
    radius = 0.18 - 0.08 * z / 2.8
    a = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    v = np.stack([np.cos(a)[None, :] * radius[:, None], np.sin(a)[None, :] * radius[:, None],
                  np.broadcast_to(z[:, None], (rings + 1, sections))], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings), np.arange(sections), indexing="ij")
    p0, p1 = i * sections + j, i * sections + (j + 1) % sections
    q0, q1 = p0 + sections, p1 + sections
    faces = np.concatenate([np.stack([p0, p1, q1], -1).reshape(-1, 3), np.stack([p0, q1, q0], -1).reshape(-1, 3)])
    return trimesh.Trimesh(v, faces, process=False)


def placements(rng: np.random.Generator) -> np.ndarray:
    gx, gy = np.meshgrid(np.arange(GRID), np.arange(GRID), indexing="ij")
    x = (gx.ravel() - (GRID - 1) / 2) * SPACING + rng.uniform(-0.6, 0.6, GRID * GRID)
    y = (gy.ravel() - (GRID - 1) / 2) * SPACING + rng.uniform(-0.6, 0.6, GRID * GRID)
    turn = rng.uniform(0, 2 * np.pi, GRID * GRID)
    scale = rng.uniform(0.7, 1.3, GRID * GRID)
    t = np.zeros((GRID * GRID, 4, 4))
    c, s = np.cos(turn) * scale, np.sin(turn) * scale
    t[:, 0, 0], t[:, 0, 1], t[:, 1, 0], t[:, 1, 1] = c, -s, s, c
    t[:, 2, 2] = scale
    t[:, 0, 3], t[:, 1, 3], t[:, 3, 3] = x, y, 1.0
    return t.astype(np.float32)


SCENE = """\
# A wood of 10,000 trees (each 104,448 triangles: 1.04 billion placed) on a 300 x 300
# ground: one tree's meshes (crown.ply, trunk.ply) placed by the 10,000 transforms of
# instances.npy, which share its trees (two-level BVH). Made by tools/make_forest.py (seeded).
[film]
width = 320
height = 180
filter = "gaussian"

[camera]
fov = 55
look_at = {{ origin = [-153, -156, 6], target = [-120, -128, 1.5], up = [0, 0, 1] }}

[integrator]
type = "path"
max_depth = 5

[sampler]
type = "sobol"
spp = 64

[materials.leaves]
reflectance = [0.09, 0.22, 0.06]
[materials.bark]
reflectance = [0.22, 0.15, 0.1]
[materials.ground]
reflectance = [0.25, 0.2, 0.13]

[[shapes]]
type = "mesh"
file = "crown.ply"
material = "leaves"
instances = "instances.npy"

[[shapes]]
type = "mesh"
file = "trunk.ply"
material = "bark"
instances = "instances.npy"

[[shapes]]
type = "rectangle"
material = "ground"
transform = {{ scale = [{half}, {half}, 1] }}

[[lights]]
type = "directional"
direction = [0.55, 0.45, -0.35]
irradiance = [3.2, 2.9, 2.4]

[[lights]]
type = "constant"
radiance = [0.25, 0.35, 0.55]
"""


def nearest_trees(scene, count: int):
    """``scene`` (the forest, loaded) with only the ``count`` trees nearest its camera: the
    instanced scene of tests/render/test_forest.py and benchmarks/instancing.py."""
    crown = next(s for s in scene.shapes if s.instances is not None)
    eye = scene.camera.world_from_camera[:3, 3]
    keep = np.argsort(np.linalg.norm(crown.instances[:, :3, 3] - eye, axis=1))[:count]
    for shape in scene.shapes:
        if shape.instances is not None:
            shape.instances = shape.instances[keep]
    return scene


def main() -> None:
    rng = np.random.default_rng(SEED)
    OUT.mkdir(parents=True, exist_ok=True)
    c = crown(rng)
    c.export(OUT / "crown.ply")
    trunk().export(OUT / "trunk.ply")
    np.save(OUT / "instances.npy", placements(rng))
    (OUT / "scene.toml").write_text(SCENE.format(half=GRID * SPACING / 2 + 2))
    print(f"crown {len(c.faces)} triangles, {GRID * GRID} copies -> {OUT}")


if __name__ == "__main__":
    main()
