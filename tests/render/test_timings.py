"""Renderer.timings: "build" holds the scene's packing (pack_scene), the BVH build and the
uploads; "pack" the packing alone."""
import time
from pathlib import Path

import glrender
from glrender.gpu import device_scene as renderer_module

ROOT = Path(__file__).resolve().parents[2]
DELAY = 0.3


def test01_build_includes_pack_scene(gl_ctx, monkeypatch):
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film.width = scene.film.height = 8
    pack = renderer_module.pack_scene

    def slow_pack(s):
        time.sleep(DELAY)
        return pack(s)
    monkeypatch.setattr(renderer_module, "pack_scene", slow_pack)
    r = glrender.Renderer(scene, spp=1, ctx=gl_ctx)
    try:
        t = r.timings
        assert set(t) == {"pack", "build", "compile"}
        assert DELAY <= t["pack"] <= t["build"]
        assert t["compile"] >= 0
    finally:
        r.release()
