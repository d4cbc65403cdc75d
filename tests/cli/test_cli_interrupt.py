"""SIGINT / SIGTERM during a render: the image so far and a checkpoint, exit 130 / 143, and a
resume that ends bitwise where an uninterrupted render ends."""
from __future__ import annotations

import json
import signal
import time

import numpy as np
import pytest

from cli_run import CORNELL, Running, glrender
from glrender.film.io import read_exr_layers
from glrender.render.checkpoint import load_checkpoint

# 12.6 M paths: 1.6-3 s on 2 llvmpipe threads, long enough to interrupt in the middle
ARGS = ["--width", 64, "--height", 48, "--spp", 4096, "--seed", 11]
# The splatting integrators (their light paths land anywhere on the film, in 64-bit
# fixed-point sums): 1-3 s each at these sizes, so the signal comes in the middle too
# (lighttrace draws ~4 M paths/s here: 2048 spp, 0.39 s, ended before the signal)
SPLATTING = {"bdpt": ["--width", 32, "--height", 24, "--spp", 1024, "--seed", 11, "--integrator", "bdpt"],
             "lighttrace": ["--width", 32, "--height", 24, "--spp", 8192, "--seed", 11,
                            "--integrator", "lighttrace"]}
RUNS = {"path": ARGS, **SPLATTING}


@pytest.fixture(scope="module", params=list(RUNS))
def uninterrupted(request, tmp_path_factory):
    """(integrator, its arguments, the image of the whole render)."""
    args = RUNS[request.param]
    out = tmp_path_factory.mktemp("ref") / "ref.exr"
    r = glrender("render", CORNELL, "-o", out, *args, "--quiet")
    assert r.returncode == 0, r.stderr
    return request.param, args, read_exr_layers(out)


def interrupt(tmp_path, signum, *extra, after=0.4, args=ARGS):
    """Start a render, signal it ``after`` seconds into the render (after its first
    checkpoint where it writes them periodically), return (process, seconds from the
    signal to the exit, stats)."""
    out, stats = tmp_path / "i.exr", tmp_path / "i.json"
    run = Running("render", CORNELL, "-o", out, *args, "--stats", stats, *extra)
    run.wait_for("glrender: rendering")
    if "--checkpoint-every" in extra:
        ckpt, end = tmp_path / "i.exr.ckpt", time.monotonic() + 60
        while not ckpt.exists() and run.proc.poll() is None and time.monotonic() < end:
            time.sleep(0.005)
    time.sleep(after)
    t0 = time.monotonic()
    run.proc.send_signal(signum)
    rc = run.wait()
    return run, rc, time.monotonic() - t0, json.loads(stats.read_text()), out


@pytest.mark.slow
def test01_sigint_then_resume_equals_uninterrupted(tmp_path, uninterrupted):
    """Every integrator that renders in the kernel's passes: the path tracer, and bdpt and
    lighttrace, whose splats the checkpoint keeps too."""
    integrator, args, reference = uninterrupted
    spp = args[args.index("--spp") + 1]
    run, rc, seconds, stats, out = interrupt(tmp_path, signal.SIGINT, args=args)
    assert rc == 130, run.stderr
    # the current dispatch (~0.1 s) finishes, then image + checkpoint are written
    assert seconds < 1.0
    ckpt = tmp_path / "i.exr.ckpt"
    assert f"stopped by SIGINT at {stats['spp']} spp" in run.stderr
    assert str(out) in run.stderr and str(ckpt) in run.stderr and "--resume" in run.stderr
    assert stats["stopped"] == "interrupted" and stats["signal"] == "SIGINT"
    assert stats["integrator"] == integrator
    assert 0 < stats["spp"] < spp and stats["spp"] % stats["samples_per_pass"] == 0
    assert load_checkpoint(ckpt).spp_done == stats["spp"]
    partial = read_exr_layers(out)["RGB"]
    assert partial.max() > 0.1 and not np.array_equal(partial, reference["RGB"])

    resumed = glrender("render", CORNELL, "-o", out, "--resume", "--stats", tmp_path / "r.json")
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {ckpt} at {stats['spp']} spp" in resumed.stderr
    rstats = json.loads((tmp_path / "r.json").read_text())
    assert rstats["resumed_from_spp"] == stats["spp"] and rstats["spp"] == spp
    assert rstats["integrator"] == integrator
    final = read_exr_layers(out)
    np.testing.assert_array_equal(final["RGB"], reference["RGB"])
    np.testing.assert_array_equal(final["variance"], reference["variance"])


def test02_sigterm_with_periodic_checkpoints(tmp_path):
    # 4x the samples of ARGS: no reference image is needed, and the render cannot end first
    args = ARGS[:-3] + [ARGS[-3] * 4, "--seed", 11]
    run, rc, seconds, stats, out = interrupt(tmp_path, signal.SIGTERM, "--checkpoint-every", "0.2",
                                             after=0.5, args=args)
    assert rc == 143, run.stderr
    assert seconds < 1.0
    assert "stopped by SIGTERM" in run.stderr and stats["signal"] == "SIGTERM"
    assert stats["checkpoints_written"] >= 2          # every 0.2 s, signalled 0.5 s after the first
    assert load_checkpoint(tmp_path / "i.exr.ckpt").spp_done == stats["spp"] > 0
    assert out.exists()


def test03_stop_hook_keeps_whole_passes(gl_ctx):
    """A stop between the dispatches of a pass undoes that pass: every pixel holds the same
    number of samples, and continuing gives the uninterrupted image bitwise."""
    from dataclasses import replace

    import glrender
    from glrender.render.renderer import Renderer, settings_from_scene

    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=72, height=56)      # 63 tiles
    # one tile per dispatch, 4 samples per pass: a pass is 63 dispatches
    settings = settings_from_scene(scene, spp=12, seed=5, samples_per_pass=4, time_target=1e-9)
    whole = Renderer(scene, settings)
    whole.step(12)
    expected = whole.film()
    whole.release()

    r = Renderer(scene, settings)
    asked = 0

    def stop():
        nonlocal asked
        asked += 1
        return asked > 100          # in the middle of the second pass

    assert r.step(12, should_stop=stop) == 4
    film = r.film()
    assert r.spp_done == 4 and (film.count == 4).all()
    assert r.step(8, should_stop=lambda: False) == 8
    got = r.film()
    r.release()
    np.testing.assert_array_equal(got.mean, expected.mean)
    np.testing.assert_array_equal(got.m2, expected.m2)
    np.testing.assert_array_equal(got.count, expected.count)
