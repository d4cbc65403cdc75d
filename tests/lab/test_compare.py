"""`glrender compare A B --ref R --out DIR` on images whose errors are known."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from glrender.lab.compare import block_mean, compare_images


def noisy(ref, sigma, seed):
    return ref + np.random.default_rng(seed).normal(0.0, sigma, ref.shape)


@pytest.fixture
def images(tmp_path):
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.2, 1.0, (48, 64, 3))
    paths = {}
    for name, img in (("ref", ref), ("a", noisy(ref, 0.1, 1)), ("b", noisy(ref, 0.05, 2))):
        paths[name] = tmp_path / f"{name}.npy"
        np.save(paths[name], img.astype(np.float32))
    return ref, paths


def test01_numbers_match_the_known_noise(images):
    ref, _ = images
    a, b = noisy(ref, 0.1, 1), noisy(ref, 0.05, 2)
    r = compare_images(a, b, ref, time_a=1.0, time_b=2.0, block=8)
    n = ref.size
    # MSE of n squared normals: relative standard error sqrt(2/n); 5 sigma
    for key, sigma in (("a", 0.1), ("b", 0.05)):
        assert r["mse"][key] == pytest.approx(sigma ** 2, rel=5 * math.sqrt(2 / n))
    # B has a quarter of A's MSE at twice the time: efficiency ratio 2
    assert r["efficiency_ratio_b_over_a"] == pytest.approx(2.0, rel=10 * math.sqrt(2 / n))
    assert r["maps"]["efficiency_ratio"].shape == (6, 8)


def test02_block_mean():
    x = np.arange(16.0).reshape(4, 4)
    assert np.array_equal(block_mean(x, 2), [[2.5, 4.5], [10.5, 12.5]])


def test03_command_writes_json_markdown_and_heat_maps(images, tmp_path, capsys):
    from PIL import Image

    from glrender.commands.cli import main

    _, p = images
    out = tmp_path / "cmp"
    assert main(["compare", str(p["a"]), str(p["b"]), "--ref", str(p["ref"]), "--out", str(out),
                 "--time-a", "1", "--time-b", "2"]) == 0
    summary = json.loads((out / "compare.json").read_text())
    assert summary["times_given"] and summary["efficiency_ratio_b_over_a"] == pytest.approx(2.0, rel=0.1)
    assert "compare.png" in (out / "compare.md").read_text()
    with Image.open(out / "compare.png") as im:
        assert im.format == "PNG" and im.size[0] > 600


def test04_stats_files_and_errors(images, tmp_path, capsys):
    from glrender.commands.cli import main

    _, p = images
    stats = tmp_path / "a.json"
    stats.write_text(json.dumps({"seconds": {"render": 3.0}}))
    out = tmp_path / "cmp"
    assert main(["compare", str(p["a"]), str(p["b"]), "--ref", str(p["ref"]), "--out", str(out),
                 "--stats-a", str(stats), "--time-b", "3"]) == 0
    assert json.loads((out / "compare.json").read_text())["time"] == {"a": 3.0, "b": 3.0}
    small = tmp_path / "small.npy"
    np.save(small, np.zeros((8, 8, 3), np.float32))
    assert main(["compare", str(p["a"]), str(small), "--ref", str(p["ref"]), "--out", str(out)]) == 2
    assert "differ in size" in capsys.readouterr().err
