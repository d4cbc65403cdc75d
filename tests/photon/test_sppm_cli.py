"""``glrender render --integrator sppm`` (and photon, vcm): options, one-line errors,
checkpoints."""
import sys
from pathlib import Path

import numpy as np
import pytest

from glrender.film.io import read_exr

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from cli_run import CORNELL, glrender, one_error_line  # noqa: E402

SMALL = ("--width", 32, "--height", 32)


@pytest.mark.parametrize("args, message", [
    (("--photons", 0), "photons per iteration"),
    (("--initial-radius", -0.1), "initial radius"),
    (("--alpha", 1.0), "alpha"),
    (("--alpha", 0.0), "alpha"),
    (("--iterations", 0), "--iterations"),
])
def test01_bad_parameters_one_line_exit_2(tmp_path, args, message):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--integrator", "sppm",
                                   *SMALL, *args))
    assert message in line


def test02_photon_options_need_sppm(tmp_path):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--alpha", 0.5, *SMALL))
    assert "--alpha" in line and "sppm" in line


@pytest.mark.slow
def test03_resume_continues_the_sppm_state(tmp_path):
    """4 iterations, a checkpoint, 4 more on resume: the image of 8 iterations in one run
    (deposits are float atomics: equal up to their summation order, 1e-5 relative)."""
    common = ("--integrator", "sppm", "--photons", 4096, *SMALL)
    ckpt = tmp_path / "a.ckpt"
    first = glrender("render", CORNELL, "-o", tmp_path / "a.exr", "--iterations", 4, "--checkpoint", ckpt,
                     *common)
    assert first.returncode == 0, first.stderr
    second = glrender("render", CORNELL, "-o", tmp_path / "a.exr", "--iterations", 8, "--checkpoint", ckpt,
                      "--resume", *common)
    assert second.returncode == 0, second.stderr
    whole = glrender("render", CORNELL, "-o", tmp_path / "b.exr", "--iterations", 8, *common)
    assert whole.returncode == 0, whole.stderr
    a, b = read_exr(tmp_path / "a.exr"), read_exr(tmp_path / "b.exr")
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    assert a.mean() > 0.1


def test03b_crop_renders_the_whole_image_s_pixels(tmp_path):
    """--crop with sppm: only the crop's rows are rendered, with the same photons, so the
    crop is the whole render's pixels there (deposits are float atomics: 1e-5 relative);
    a checkpoint of the crop resumes."""
    common = ("--integrator", "sppm", "--photons", 4096, "--iterations", 3, *SMALL)
    r = glrender("render", CORNELL, "-o", tmp_path / "whole.exr", *common)
    assert r.returncode == 0, r.stderr
    r = glrender("render", CORNELL, "-o", tmp_path / "crop.exr", "--crop", "5,9,27,20", *common)
    assert r.returncode == 0, r.stderr
    whole, crop = read_exr(tmp_path / "whole.exr"), read_exr(tmp_path / "crop.exr")
    assert crop.shape[:2] == (11, 22)
    np.testing.assert_allclose(crop, whole[9:20, 5:27], rtol=1e-5, atol=1e-6)
    assert crop.mean() > 0.1
    ckpt, out = tmp_path / "c.ckpt", tmp_path / "resumed.exr"
    for iterations, extra in ((2, ()), (3, ("--resume",))):
        r = glrender("render", CORNELL, "-o", out, "--crop", "5,9,27,20", *common, "--iterations", iterations,
                     "--checkpoint", ckpt, *extra)
        assert r.returncode == 0, r.stderr
    assert "resuming" in r.stderr and "at 2 spp" in r.stderr
    np.testing.assert_allclose(read_exr(out), crop, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("args, message", [
    (("--photons", 0), "--photons"),
    (("--caustic-photons", 0), "--caustic-photons"),
    (("--radius", -0.1), "--radius"),
    (("--knn", 0), "--knn"),
    (("--radius", 0.1, "--knn", 8), "--radius and --knn"),
    (("--alpha", 0.5), "--alpha"),
    (("--aov", "radius"), "--aov radius"),
])
def test04_photon_integrator_bad_parameters_one_line_exit_2(tmp_path, args, message):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--integrator", "photon",
                                   *SMALL, *args))
    assert message in line


def test05_photon_map_options_need_photon(tmp_path):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--integrator", "sppm",
                                   "--final-gather", *SMALL))
    assert "--final-gather" in line and "photon" in line


@pytest.mark.slow
@pytest.mark.parametrize("integrator, options", [
    ("photon", ("--photons", 20000, "--knn", 16, "--kernel", "cone", "--final-gather")),
    ("sppm", ("--photons", 4096, "--alpha", 0.5, "--initial-radius", 0.04)),
    ("vcm", ("--vcm-mode", "vm", "--alpha", 0.6, "--initial-radius", 0.05)),
    ("vcm", ("--light-vertex-cache", 2, "--light-paths", 500)),
])
def test06_resume_keeps_the_photon_options(tmp_path, integrator, options):
    """A checkpoint saves the photon options: --resume without them continues the same
    render (the fingerprint would refuse other options), equal to one uninterrupted run."""
    ckpt = tmp_path / "a.ckpt"
    first = glrender("render", CORNELL, "-o", tmp_path / "a.exr", "--spp", 4, "--checkpoint", ckpt,
                     "--integrator", integrator, *options, *SMALL)
    assert first.returncode == 0, first.stderr
    second = glrender("render", CORNELL, "-o", tmp_path / "a.exr", "--spp", 8, "--resume",
                      "--checkpoint", ckpt)
    assert second.returncode == 0, second.stderr
    whole = glrender("render", CORNELL, "-o", tmp_path / "b.exr", "--spp", 8, "--integrator", integrator,
                     *options, *SMALL)
    assert whole.returncode == 0, whole.stderr
    a, b = read_exr(tmp_path / "a.exr"), read_exr(tmp_path / "b.exr")
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    assert a.mean() > 0.1


def test07_photon_integrator_writes_the_photon_view(tmp_path):
    """--integrator photon --aov photons: the image and the photon-map view, both lit;
    --stats names the maps (photons emitted and stored, radii, lookups, bytes)."""
    import json

    out = tmp_path / "p.exr"
    run = glrender("render", CORNELL, "-o", out, "--integrator", "photon", "--photons", 20000,
                   "--spp", 2, "--aov", "photons", "--stats", tmp_path / "s.json", *SMALL)
    assert run.returncode == 0, run.stderr
    stats = json.loads((tmp_path / "s.json").read_text())
    ph = stats["photon"]
    assert stats["biased"] and ph["photons_emitted"] == [20000, 20000]
    assert ph["photons_stored"][0] > 20000 and ph["radius"][0] > 0 and ph["lookups"]["visited"] > 0
    assert ph["memory"]["bytes_per_photon"] == 48
    from glrender.film.io import read_exr_layers

    layers = read_exr_layers(out)
    assert layers["RGB"].mean() > 0.1 and layers["photons"].mean() > 0


@pytest.mark.parametrize("args, message", [
    (("--vcm-mode", "both"), "--vcm-mode: invalid choice"),
    (("--initial-radius", 0), "--initial-radius 0.0: expected a positive number"),
    (("--alpha", 1.5), "--alpha 1.5: expected a number in (0, 1)"),
    (("--iterations", -2), "--iterations -2"),
    (("--photons", 100), "--photons-per-iteration: only with --integrator sppm or photon"),
    (("--knn", 4), "--knn: only with --integrator photon"),
    (("--light-paths", 0), "--light-paths 0: expected an integer in [1, 67108864]"),
    (("--light-vertex-cache", 0), "--light-vertex-cache 0: expected an integer in [1, 16]"),
    (("--light-vertex-cache", 2, "--vcm-mode", "vm"), "--light-vertex-cache: only with --vcm-mode vcm"),
])
def test08_vcm_bad_parameters_one_line_exit_2(tmp_path, args, message):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--integrator", "vcm",
                                   *SMALL, *args))
    assert message in line


def test09_vcm_mode_needs_vcm(tmp_path):
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "x.exr", "--vcm-mode", "vm", *SMALL))
    assert "--vcm-mode: only with --integrator vcm" in line
