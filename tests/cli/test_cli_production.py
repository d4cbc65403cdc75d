"""--crop, --clamp and --noise-threshold from the command line."""
from __future__ import annotations

import json

import numpy as np
import pytest

from cli_run import CORNELL, glrender, one_error_line

SIZE = ["--width", 40, "--height", 30, "--seed", 2]


def render(tmp_path, name, *args):
    out, stats = tmp_path / f"{name}.npy", tmp_path / f"{name}.json"
    r = glrender("render", CORNELL, "-o", out, *SIZE, "--stats", stats, *args)
    assert r.returncode == 0, r.stderr
    return np.load(out), json.loads(stats.read_text())


@pytest.mark.parametrize("crop", ["5,3,31,20", "0,0,40,30", "17,9,18,10"])
def test01_crop_equals_the_same_pixels_of_a_full_render(tmp_path, crop):
    full, _ = render(tmp_path, "full", "--spp", 8)
    part, stats = render(tmp_path, "part", "--spp", 8, "--crop", crop)
    x0, y0, x1, y1 = map(int, crop.split(","))
    assert part.shape == (y1 - y0, x1 - x0, 3) and stats["crop"] == [x0, y0, x1, y1]
    np.testing.assert_array_equal(part, full[y0:y1, x0:x1])


def test02_crop_resumes_from_its_checkpoint(tmp_path):
    ckpt = tmp_path / "c.ckpt"
    full, _ = render(tmp_path, "full", "--spp", 16)
    render(tmp_path, "part", "--spp", 8, "--crop", "4,10,30,22", "--checkpoint", ckpt)
    part, stats = render(tmp_path, "part", "--spp", 16, "--checkpoint", ckpt, "--resume")
    assert stats["resumed_from_spp"] == 8 and stats["crop"] == [4, 10, 30, 22]
    np.testing.assert_array_equal(part, full[10:22, 4:30])
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.npy", "--checkpoint",
                                   ckpt, "--resume", "--crop", "0,0,8,8"))
    assert "the checkpoint holds crop 4,10,30,22, this render crop 0,0,8,8" in line


def test02b_memory_is_reported(tmp_path):
    _, stats = render(tmp_path, "m", "--spp", 1, "--aov", "albedo")
    # sums with counts and squares (64 + 48 bytes), albedo/normal/depth/emission sums (160),
    # doubled by the undo copy
    assert stats["memory"] == {"device_bytes_per_pixel": 544,
                               "device_accumulation_bytes": 544 * 40 * 30, "slices": 1,
                               "texture_bytes": 0}


def test03_clamp_is_marked_biased(tmp_path):
    free, fstats = render(tmp_path, "free", "--spp", 8)
    clamped, cstats = render(tmp_path, "clamped", "--spp", 8, "--clamp", 0.5)
    assert fstats["biased"] is False and fstats["clamp"] is None
    assert cstats["biased"] is True and cstats["clamp"] == 0.5
    assert free.max() > 1 and clamped.max() <= 0.5 * (1 + 1e-6)


def test04_noise_threshold_plans_the_samples(tmp_path):
    image, stats = render(tmp_path, "n", "--noise-threshold", 0.1, "--sampler", "independent")
    plan = stats["noise_threshold"]
    assert plan["threshold"] == 0.1 and plan["pilot_spp"] == 32
    assert stats["spp"] == plan["planned_spp"] > 32
    assert plan["predicted_error"] <= 0.1
    # the image's own estimate agrees with the pilot's prediction (means over ~3600 values)
    assert abs(stats["mean_relative_stderr"] / 0.1 - 1) < 0.15
    capped, cstats = render(tmp_path, "c", "--noise-threshold", 0.01, "--spp", 40)
    assert cstats["spp"] == 40


@pytest.mark.parametrize("args, message", [
    (["--crop", "0,0,41,30"], "--crop 0,0,41,30: outside the 40x30 film"),
    (["--crop", "5,5,5,9"], "--crop 5,5,5,9: expected 0 <= X0 < X1 and 0 <= Y0 < Y1"),
    (["--crop", "1,2,3"], "--crop 1,2,3: expected X0,Y0,X1,Y1 in whole pixels"),
    (["--crop", "0,0,8,8", "--integrator", "lighttrace"], "--crop: not available with the lighttrace"),
    (["--clamp", "-1"], "--clamp -1.0: expected a positive number"),
    (["--noise-threshold", "0"], "--noise-threshold 0.0: expected a relative error in (0, 1)"),
    (["--noise-threshold", "2"], "--noise-threshold 2.0: expected a relative error in (0, 1)"),
])
def test05_bad_values_give_one_line(tmp_path, args, message):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.png", *SIZE, *args))
    assert message in line, line
