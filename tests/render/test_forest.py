"""The forest (scenes/forest): 10,000 copies of a tree of 104,448 triangles, over a
billion triangles placed, render through the two-level BVH within a few tens of MB of
device memory, as users run it (``glrender render --stats`` in its own process); and the
trees nearest the camera, instanced, equal their flattened copies per 6-pixel block at a
Šidák-corrected alpha of 0.01, sigma from the seeds."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.gpu import pack
from glrender.testing.images import compare_images

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "forest" / "scene.toml"
SEEDS_FLAT, SEEDS_INSTANCED = tuple(range(1, 5)), tuple(range(11, 15))
NEAREST = 8


def test01_the_forest_renders_in_little_memory(tmp_path):
    scene = glrender.load(SCENE)
    crown, trunk = (s for s in scene.shapes if s.instances is not None)
    assert len(crown.triangles) >= 100_000 and len(crown.instances) >= 10_000
    out, stats = tmp_path / "forest.npy", tmp_path / "stats.json"
    subprocess.run([sys.executable, "-m", "glrender", "render", str(SCENE), "--spp", "4", "--width", "48",
                    "--height", "27", "-o", str(out), "--stats", str(stats), "--quiet"],
                   check=True, timeout=600)
    mesh = json.loads(stats.read_text())["mesh"]
    assert mesh["placed_triangles"] >= 1_000_000_000 and mesh["instances"] == 20_000
    assert mesh["triangles"] == len(crown.triangles) + len(trunk.triangles)   # one tree stored
    # flattened, the copies would take ~170 bytes per triangle: 170 GB
    assert mesh["device_bytes"] < 64 << 20
    image = np.load(out)
    sky = [light.radiance for light in scene.lights if light.kind == "constant"][0]
    # the top rows see the sky alone (each pixel to the spread of its 4 filter-weighted
    # samples' weights); the lower third the crowns, green
    np.testing.assert_allclose(image[:3].reshape(-1, 3).mean(axis=0), sky, rtol=1e-2)
    np.testing.assert_allclose(image[:3], np.broadcast_to(sky, image[:3].shape), rtol=0.1)
    low = image[-9:].reshape(-1, 3)
    assert np.median(low[:, 1] / low[:, 0]) > 1.5 and np.median(low[:, 1] / low[:, 2]) > 1.5


def renders(scene, seeds):
    return np.stack([glrender.render(scene, spp=8, seed=seed, progress=False, sampler="independent").mean
                     for seed in seeds])


def nearest_trees(scene, count):
    """tools/make_forest.py's nearest_trees (the forest's own generator)."""
    spec = importlib.util.spec_from_file_location("make_forest", ROOT / "tools" / "make_forest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.nearest_trees(scene, count)


def test02_the_nearest_trees_equal_their_flattened_copies(gl_ctx, monkeypatch):
    scene = nearest_trees(glrender.load(SCENE), NEAREST)
    scene.film.width, scene.film.height = 36, 20
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 0)     # the small trunk, instanced too
    assert len(pack.pack_scene(scene).instanced_meshes) == 2
    instanced = renders(scene, SEEDS_INSTANCED)
    monkeypatch.setattr(pack, "INSTANCE_MIN_TRIANGLES", 1 << 62)
    assert not pack.pack_scene(scene).instanced_meshes
    flat = renders(scene, SEEDS_FLAT)
    ref, ref_se = flat.mean(axis=0), flat.std(axis=0, ddof=1) / np.sqrt(len(SEEDS_FLAT))
    c = compare_images(instanced, ref, ref_se, block=6)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    assert c.detectable_bias < 0.05, c.summary()
