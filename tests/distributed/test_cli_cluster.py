"""glrender render --workers / --scheduler / --frames, run as users run it."""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.film.io import read_exr_layers
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.scene.animation import scene_at_frame

from dist_run import CORNELL, DaskProcesses, animated_cornell, free_port, glrender as run, \
    one_error_line

SMALL = ["--width", 48, "--height", 40, "--spp", 16, "--seed", 5]


def single(tmp_path, name="single.exr"):
    out = tmp_path / name
    r = run("render", CORNELL, *SMALL, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return out.read_bytes()


@pytest.mark.slow
def test01_local_cluster_writes_the_same_exr(tmp_path):
    out = tmp_path / "cluster.exr"
    r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 2, "--unit-size", 48 * 8 * 16 * 2,
            "--stats", tmp_path / "s.json")
    assert r.returncode == 0, r.stderr
    assert "3 units" in r.stderr and "local cluster of 2 worker processes" in r.stderr
    assert out.read_bytes() == single(tmp_path)
    import json

    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["unit_size"] == 48 * 8 * 16 * 2 and stats["plan"]["units"] == 3
    assert stats["scene_by"] == "value" and stats["workers"] == 2


@pytest.mark.slow
def test01b_split_sample_ranges_write_the_same_exr(tmp_path):
    """The smallest unit size: every band's 16 samples in two ranges of 8, merged on the
    workers; the EXR (with the variance and albedo layers) is the single process's,
    byte for byte."""
    out, ref = tmp_path / "cluster.exr", tmp_path / "single.exr"
    aovs = ["--aov", "variance,albedo"]
    r = run("render", CORNELL, *SMALL, *aovs, "-o", out, "--workers", 2, "--unit-size", 4096,
            "--stats", tmp_path / "s.json")
    assert r.returncode == 0, r.stderr
    import json

    plan = json.loads((tmp_path / "s.json").read_text())["plan"]
    assert plan["ranges"] == 2 and plan["bands"] == 5 and plan["units"] == 10
    assert run("render", CORNELL, *SMALL, *aovs, "-o", ref, "--quiet").returncode == 0
    assert out.read_bytes() == ref.read_bytes()


@pytest.mark.slow
def test01c_photon_integrator_writes_the_same_exr(tmp_path):
    """--integrator photon with its options on 2 workers, bands split into sample ranges:
    every worker traces the maps the options ask for, and the EXR is the single
    process's, byte for byte."""
    photon = ["--integrator", "photon", "--photons", 20000, "--knn", 8]
    out, ref = tmp_path / "cluster.exr", tmp_path / "single.exr"
    r = run("render", CORNELL, *SMALL, *photon, "-o", out, "--workers", 2, "--unit-size", 4096)
    assert r.returncode == 0, r.stderr
    assert run("render", CORNELL, *SMALL, *photon, "-o", ref, "--quiet").returncode == 0
    assert out.read_bytes() == ref.read_bytes()


@pytest.mark.slow
def test01d_vcm_writes_the_same_exr(tmp_path):
    """--integrator vcm on 2 workers: an iteration's light paths and radius depend on its
    index and the seed alone, so the workers' sample ranges (whole frames: vcm splats) add
    up to the single process's EXR, byte for byte."""
    vcm = ["--integrator", "vcm", "--alpha", 0.6]
    out, ref = tmp_path / "cluster.exr", tmp_path / "single.exr"
    r = run("render", CORNELL, *SMALL, *vcm, "-o", out, "--workers", 2, "--unit-size", 4096)
    assert r.returncode == 0, r.stderr
    assert run("render", CORNELL, *SMALL, *vcm, "-o", ref, "--quiet").returncode == 0
    assert out.read_bytes() == ref.read_bytes()


@pytest.mark.slow
def test02_dask_scheduler_and_workers(tmp_path):
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1: the same file."""
    cluster = DaskProcesses(tmp_path)
    try:
        cluster.wait_for_workers(2)
        out = tmp_path / "remote.exr"
        r = run("render", CORNELL, *SMALL, "-o", out, "--scheduler", cluster.address,
                "--unit-size", 4096)      # 5 bands of 2 sample ranges
        assert r.returncode == 0, r.stderr
        assert "10 units" in r.stderr and cluster.address in r.stderr
    finally:
        cluster.close()
    assert out.read_bytes() == single(tmp_path)


@pytest.mark.slow
def test03_two_frames_of_an_animation_in_tiles(tmp_path, gl_ctx):
    scene_path = animated_cornell(tmp_path)
    r = run("render", scene_path, *SMALL, "--frames", "0:1", "-o", tmp_path / "f{frame:02d}.exr",
            "--workers", 2, "--unit-size", 48 * 8 * 16)
    assert r.returncode == 0, r.stderr
    assert "10 units" in r.stderr
    scene = glrender.load(scene_path)
    scene.film.width, scene.film.height = 48, 40
    images = []
    for frame in (0, 1):
        s = scene_at_frame(scene, frame)
        rr = Renderer(s, settings_from_scene(s, spp=16, seed=5))
        rr.step(16)
        ref = rr.film()
        rr.release()
        got = read_exr_layers(tmp_path / f"f{frame:02d}.exr")
        rgb = got["RGB"]
        np.testing.assert_array_equal(rgb, ref.mean)
        images.append(ref.mean)
    assert np.mean(images[0] != images[1]) > 0.5      # the frames differ: the motion is there


@pytest.mark.slow
def test04_bad_input_is_one_line(tmp_path):
    out = tmp_path / "out.exr"
    r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 0)
    assert "--workers 0" in one_error_line(r)
    port = free_port()
    r = run("render", CORNELL, *SMALL, "-o", out, "--scheduler", f"tcp://127.0.0.1:{port}")
    assert "cannot reach the scheduler" in one_error_line(r)
    r = run("render", CORNELL, *SMALL, "-o", tmp_path / "f.exr", "--frames", "0:1")
    assert "has no [animation]" in one_error_line(r)
    r = run("render", animated_cornell(tmp_path), *SMALL, "-o", out, "--frames", "0:1")
    assert "{frame}" in one_error_line(r)
    r = run("render", CORNELL, *SMALL, "-o", out, "--scheduler", "tls://127.0.0.1:1")
    assert "--tls-ca" in one_error_line(r)
    r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 2, "--integrator", "sppm")
    assert "sppm does not run on a cluster" in one_error_line(r)
    r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 2, "--integrator", "photon",
            "--aov", "photons")
    assert "--aov photons does not run on a cluster" in one_error_line(r)
    assert list(tmp_path.glob("*.exr")) == [] and list(tmp_path.glob("*.ckpt")) == []


@pytest.mark.slow
def test05_a_scene_the_workers_cannot_read(tmp_path):
    out = tmp_path / "out.exr"
    r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 1,
            "--scene-on-workers", tmp_path / "missing" / "scene.toml")
    # the error happens on a worker, after the render began: exit 2, no traceback, the
    # error on one line at the end (after the line that announced the render)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    errors = [line for line in r.stderr.splitlines() if "error" in line.lower()]
    assert len(errors) == 1 and errors[0] == r.stderr.strip().splitlines()[-1], r.stderr
    assert "a worker cannot read the scene" in errors[0] and "missing" in errors[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test06_ctrl_c_writes_a_checkpoint_that_resume_finishes(tmp_path):
    """On a terminal (a pty) the progress line counts units; Ctrl-C once some are done
    writes the finished bands to OUT.ckpt and exits 130; --resume renders the rest, and
    the image is bitwise the single-process one."""
    import os
    import pty
    import signal
    import subprocess
    import sys
    import threading
    import time

    out = tmp_path / "big.exr"
    size = ["--width", 128, "--height", 128, "--spp", 64, "--seed", 5]
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "glrender", "render", str(CORNELL),
                             *map(str, size), "-o", str(out), "--workers", "2",
                             "--unit-size", str(128 * 8 * 64)],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    text = []

    def read():
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:
                return
            if not data:
                return
            text.append(data.decode(errors="replace"))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    import re

    end = time.monotonic() + 120
    while not re.search(r"\] ([1-9]|1[0-5])/16 units", "".join(text)):   # some, not all
        assert proc.poll() is None and time.monotonic() < end, "".join(text)
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) == 130, "".join(text)
    reader.join(timeout=5)
    os.close(master)
    log = "".join(text)
    assert "stopped by SIGINT" in log and "continue with --resume" in log, log
    assert not out.exists() and (tmp_path / "big.exr.ckpt").is_file()
    # without --unit-size: the checkpoint's (the calibrated one would plan other units)
    r = run("render", CORNELL, *size, "-o", out, "--workers", 2, "--resume")
    assert r.returncode == 0, r.stderr
    assert "bands done" in r.stderr and "16 units" in r.stderr
    single = tmp_path / "single.exr"
    assert run("render", CORNELL, *size, "-o", single, "--quiet").returncode == 0
    assert out.read_bytes() == single.read_bytes()


@pytest.mark.slow
def test07_the_unit_size_is_calibrated_once_then_reused_and_recorded(tmp_path):
    """Without --unit-size the first render calibrates on a worker and writes the cache;
    the next one reads it (no calibration); both record the unit size in --stats; a render
    given the recorded size plans the same units; every image is the single process's."""
    import json
    import os

    env = {**os.environ, "GLRENDER_CACHE_DIR": str(tmp_path / "cache")}
    cache = tmp_path / "cache" / "unit-size.json"
    outs, stats = [], []
    for i, extra in enumerate([[], [], None]):
        if extra is None:     # the recorded unit size, given back
            extra = ["--unit-size", stats[0]["unit_size"]]
        out = tmp_path / f"run{i}.exr"
        r = run("render", CORNELL, *SMALL, "-o", out, "--workers", 1, "--stats",
                tmp_path / f"s{i}.json", *extra, env=env)
        assert r.returncode == 0, r.stderr
        outs.append(out.read_bytes())
        stats.append(json.loads((tmp_path / f"s{i}.json").read_text()))
        if i == 0:
            assert "unit size" in r.stderr and "calibrated for" in r.stderr, r.stderr
            entries = json.loads(cache.read_text())["entries"]
            assert len(entries) == 1 and cache.stat().st_size > 0
            written = cache.read_bytes()
        elif i == 1:
            assert "from the calibration" in r.stderr and "calibrated for" not in r.stderr
            assert cache.read_bytes() == written            # read, not measured again
    assert [s["unit_size_from"] for s in stats] == ["calibrated", "cache", "option"]
    (entry,) = json.loads(written)["entries"].values()
    assert stats[0]["calibration"]["rate"] == entry["rate"] > 0
    assert stats[0]["unit_size"] == stats[1]["unit_size"] == stats[2]["unit_size"]
    assert stats[0]["plan"] == stats[1]["plan"] == stats[2]["plan"]
    assert outs[0] == outs[1] == outs[2] == single(tmp_path)
    # an unreadable cache: one line naming the file
    cache.write_text("{")
    r = run("render", CORNELL, *SMALL, "-o", tmp_path / "x.exr", "--workers", 1, env=env)
    assert "unit-size.json" in one_error_line(r)


@pytest.mark.slow
def test08_search_path_reaches_the_workers(tmp_path):
    """A texture beside the scene's folder, allowed with --search-path: the workers resolve
    it as the client does, by value and from a path (the same image as one process);
    without --search-path the cluster render refuses it in the local render's one line."""
    from PIL import Image

    (tmp_path / "scene").mkdir()
    (tmp_path / "textures").mkdir()
    Image.new("RGB", (4, 4), (200, 100, 50)).save(tmp_path / "textures" / "t.png")
    scene = tmp_path / "scene" / "s.toml"
    scene.write_text(CORNELL.read_text().replace(
        'reflectance = [0.885809, 0.698859, 0.666422]', 'reflectance = "wood"', 1)
        + '\n[textures.wood]\nfile = "../textures/t.png"\n')
    assert 'reflectance = "wood"' in scene.read_text()
    allow = ["--search-path", tmp_path / "textures"]
    small = ["--width", 16, "--height", 16, "--spp", 4, "--quiet"]
    assert run("render", scene, *small, *allow, "-o", tmp_path / "one.npy").returncode == 0
    by_value = run("render", scene, *small, *allow, "-o", tmp_path / "value.npy", "--workers", 1)
    assert by_value.returncode == 0, by_value.stderr
    from_path = run("render", scene, *small, *allow, "-o", tmp_path / "path.npy", "--workers", 1,
                    "--scene-on-workers", scene)
    assert from_path.returncode == 0, from_path.stderr
    one = np.load(tmp_path / "one.npy")
    assert np.array_equal(np.load(tmp_path / "value.npy"), one)
    assert np.array_equal(np.load(tmp_path / "path.npy"), one)
    local = one_error_line(run("render", scene, *small, "-o", tmp_path / "r.npy"))
    cluster = one_error_line(run("render", scene, *small, "-o", tmp_path / "r.npy", "--workers", 1))
    assert cluster == local and "'../textures/t.png'" in local and "--search-path" in local
