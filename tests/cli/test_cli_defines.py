"""-D KEY=VALUE reaches the scene loader's $parameters."""
from __future__ import annotations

import json

from cli_run import CORNELL, glrender, one_error_line


def scene_with_params(tmp_path):
    """The Cornell box whose film width and seed are parameters."""
    text = CORNELL.read_text()
    text = text.replace("[film]\nwidth = 256", '[params]\nwidth = 16\nseed = 2\n\n[film]\nwidth = "$width"')
    text = text.replace("height = 256", "height = 8").replace('spp = 64', 'spp = 2\nseed = "$seed"')
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test01_defines_fill_parameters(tmp_path):
    scene = scene_with_params(tmp_path)
    stats = tmp_path / "s.json"
    r = glrender("render", scene, "-o", tmp_path / "a.pfm", "-D", "width=24", "-D", "seed=7",
                 "--stats", stats)
    assert r.returncode == 0, r.stderr
    s = json.loads(stats.read_text())
    assert (s["width"], s["height"], s["seed"]) == (24, 8, 7)
    assert s["params"] == {"width": "24", "seed": "7"}
    r = glrender("render", scene, "-o", tmp_path / "b.pfm", "--stats", stats)
    s = json.loads(stats.read_text())
    assert (s["width"], s["seed"]) == (16, 2)           # the scene's defaults


def test02_unused_define_warns_on_one_line(tmp_path):
    r = glrender("render", scene_with_params(tmp_path), "-o", tmp_path / "a.pfm", "-D", "nosuch=1")
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and warnings[0].startswith("glrender: warning:") and "nosuch" in warnings[0]
    quiet = glrender("render", scene_with_params(tmp_path), "-o", tmp_path / "a.pfm", "-D",
                     "nosuch=1", "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == ""


def test03_bad_value_is_an_error(tmp_path):
    line = one_error_line(glrender("render", scene_with_params(tmp_path), "-o", tmp_path / "a.pfm",
                                   "-D", "width=wide"))
    assert "width" in line and "wide" in line
