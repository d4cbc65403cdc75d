"""The depth caps: at an unbounded depth (-1) the path tracer and the light tracer stop a path
at 256 segments and bdpt at 16 (fixed loop bounds and vertex arrays), and each counts the
paths its cap cut short (Film.truncated, --stats truncated_paths, the summary line).

Inside a closed, diffuse enclosure (albedo 0.9: at 0.5 a path's throughput, 2^-k, underflows
to zero after about 130 segments) with Russian roulette off no path can end before its cap,
so the counts are exact: one per sample for path and lighttrace, two for bdpt (its camera
and its light subpath). With a bounded depth under the cap nothing is counted.
"""
import re
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender import integrators

from render_scenes import enclosure

ROOT = Path(__file__).resolve().parents[2]
SIZE, SPP = 16, 2


def render(integrator, max_depth, rr="off", **options):
    scene = enclosure(albedo=0.9, width=SIZE, height=SIZE, max_depth=max_depth)
    return glrender.render(scene, spp=SPP, integrator=integrator, seed=3, rr=rr,
                           sampler="independent", progress=False, **options)


def test01_the_table_states_the_shaders_caps():
    text = {name: (ROOT / "shaders" / "integrators" / name).read_text()
            for name in ("integrator_common.glsl", "bdpt_vertex.glsl")}
    unbounded = int(re.search(r"const int kUnboundedDepthCap = (\d+);", text["integrator_common.glsl"])[1])
    bdpt = int(re.search(r"const int kBdptDepthCap = (\d+);", text["bdpt_vertex.glsl"])[1])
    assert integrators.get("bdpt").depth_cap == bdpt == 16
    for name in ("path", "lighttrace", "photon", "sppm"):
        assert integrators.get(name).depth_cap == unbounded == 256, name
    for name in ("direct", "ao"):
        assert integrators.get(name).depth_cap is None
    spec = integrators.get("bdpt")
    assert spec.cap_binds(-1) and spec.cap_binds(17) and not spec.cap_binds(16)


@pytest.mark.parametrize("integrator, per_sample, cap", [("path", 1, 256), ("lighttrace", 1, 256),
                                                         ("bdpt", 2, 16)])
def test02_unbounded_without_roulette_every_path_is_cut(gl_ctx, integrator, per_sample, cap):
    film = render(integrator, -1)
    samples = SPP * SIZE * SIZE
    assert film.truncated.shape == (SIZE, SIZE)
    assert film.truncated_total == per_sample * samples
    # the counts sit with the pixels whose invocations traced the paths
    assert (film.truncated == per_sample * SPP).all()
    assert film.stats["truncated_paths"] == per_sample * samples
    assert film.stats["depth_cap"] == cap


@pytest.mark.parametrize("integrator", ["path", "lighttrace", "bdpt"])
def test03_a_depth_under_the_cap_cuts_nothing(gl_ctx, integrator):
    film = render(integrator, 6)
    assert film.truncated_total == 0
    assert film.stats["truncated_paths"] == 0 and film.stats["depth_cap"] is None


def test04_bdpt_beyond_its_cap(gl_ctx):
    """max_depth 20 asks for more than bdpt's 16 segments: the cap binds and says so."""
    film = render("bdpt", 20)
    assert film.stats["depth_cap"] == 16
    assert film.truncated_total == 2 * SPP * SIZE * SIZE


def test05_roulette_ends_most_paths_first(gl_ctx):
    """With the throughput rule (the default) roulette keeps a path at segment k >= 5 with
    q = min(0.9^k, 0.95): some subpaths reach bdpt's cap, not all."""
    film = render("bdpt", -1, rr="throughput")
    samples = SPP * SIZE * SIZE
    assert 0 < film.truncated_total < 2 * samples


def test06_the_summary_line_names_the_cap(tmp_path):
    import subprocess
    import sys

    scene = ROOT / "scenes" / "enclosure" / "scene.toml"
    out, stats = tmp_path / "e.npy", tmp_path / "s.json"
    p = subprocess.run([sys.executable, "-m", "glrender", "render", str(scene), "-o", str(out),
                        "--integrator", "bdpt", "--max-depth", "-1", "--rr", "off", "--spp", "1",
                        "--width", "8", "--height", "8", "--stats", str(stats)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "paths cut at the 16-segment cap" in p.stderr
    import json
    data = json.loads(stats.read_text())
    assert data["depth_cap"] == 16 and data["truncated_paths"] > 0
    assert np.isfinite(np.load(out)).all()
