"""The scripts in examples/ run as a user runs them (a subprocess from the repository root)
at small sizes, and write what they say they write."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def run(script: str, *args: str) -> str:
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / script), *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_examples_listed():
    assert sorted(p.name for p in (ROOT / "examples").glob("*.py")) == [
        "compare_integrators.py", "render_file.py", "scene_in_code.py"]


def test_render_file(tmp_path):
    from glrender.film import read_image

    out = tmp_path / "cornell.pfm"
    text = run("render_file.py", "scenes/cornell-box/scene.toml", "-o", str(out), "--spp", "4",
               "--width", "24", "--height", "16")
    image = read_image(out)
    assert image.shape == (16, 24, 3) and image.mean() > 0
    assert "24x16, 4 spp" in text and f"image -> {out}" in text


def test_scene_in_code_sweep(tmp_path):
    from glrender.film import read_image

    out = tmp_path / "sweep.npy"
    text = run("scene_in_code.py", "-o", str(out), "--spp", "4", "--size", "16",
               "--alphas", "0.05", "0.5")
    strip = read_image(out)
    assert strip.shape == (16, 32, 3)
    assert not np.array_equal(strip[:, :16], strip[:, 16:])   # the parameter changed the image
    assert f"2 images side by side -> {out}" in text
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.npy"]  # as its docstring says


def test_compare_integrators():
    """NEE + MIS has ~4.6x less variance than BSDF sampling here (timings are noisy, the
    ratio is not); the two images agree within 4 standard errors (a two-sided test at
    alpha = 6e-5: the example's estimators are unbiased)."""
    text = run("compare_integrators.py", "--spp", "16", "--size", "32")
    ratio = float(text.rsplit("BSDF sampling: ", 1)[1].split()[0])
    z = float(text.split(" standard errors")[0].rsplit("(", 1)[1])
    assert ratio > 1.0 and abs(z) < 4.0
