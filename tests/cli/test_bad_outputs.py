"""Outputs that cannot be written and checkpoints that cannot be trusted: one line naming the
file and what was expected, exit code 2, and no work lost (one row per case of the
hardening issue), and the rules behind them: every output path probed before any work, a
failed periodic checkpoint warned of once while the render goes on, a failed final write
that keeps the render in its checkpoint and leaves the old file as it was, a checkpoint
never replaced by a new render, a partial image never replacing a complete one."""
from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from cli_run import CORNELL, ROOT, Running, glrender, one_error_line
from glrender.errors import UsageError
from glrender.film.io import WriteError, atomic_write, check_writable
from glrender.render.checkpoint import load_checkpoint

SMALL = ["--width", 8, "--height", 8, "--spp", 2, "--seed", 3]

# faults planted in a glrender process before its command line runs (python -c PATCH ARGS)
FULL_DISK_EXR = '''
import OpenEXR
class _FullDisk:
    def __init__(self, *args, **kwargs): pass
    def __enter__(self): return self
    def __exit__(self, *exc): return False
    def write(self, name):
        open(name, "wb").write(b"half an image")
        raise RuntimeError(f'Cannot write image file "{name}". No space left on device')
OpenEXR.File = _FullDisk
'''
FULL_DISK_NPY = '''
import errno, numpy
def _full_disk(f, *args, **kwargs):
    f.write(b"half an image")
    raise OSError(errno.ENOSPC, "No space left on device")
numpy.save = _full_disk
'''
# the first three checkpoints meet a full disk, the later ones find space again
FLAKY_CHECKPOINTS = '''
import errno, numpy
_savez, _calls = numpy.savez, [0]
def _flaky(*args, **kwargs):
    _calls[0] += 1
    if _calls[0] <= 3:
        raise OSError(errno.ENOSPC, "No space left on device")
    return _savez(*args, **kwargs)
numpy.savez = _flaky
'''


def run(args, patch: str | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    """``glrender ARGS`` in a process of its own, with ``patch`` run first."""
    if patch is None:
        return glrender(*args, timeout=timeout)
    code = patch + ("\nimport sys\nfrom glrender.commands.cli import main\n"
                    "sys.exit(main(sys.argv[1:]))\n")
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A finished small render (the image as .npy and .exr) and its checkpoint."""
    folder = tmp_path_factory.mktemp("made")
    for name, extra in (("a.npy", ["--checkpoint", folder / "a.ckpt"]), ("a.exr", [])):
        r = glrender("render", CORNELL, "-o", folder / name, *SMALL, "--quiet", *extra)
        assert r.returncode == 0, r.stderr
    return folder


def crafted(made: Path, target: Path, **fields) -> None:
    """``made``'s checkpoint with ``fields`` of its record replaced (None: removed)."""
    with np.load(made / "a.ckpt") as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"][()]))
    for key, value in fields.items():
        if value is None:
            meta.pop(key, None)
        else:
            meta[key] = value
    arrays["meta"] = np.array(json.dumps(meta))
    with open(target, "wb") as f:
        np.savez(f, **arrays)


def band_checkpoint(made: Path, target: Path) -> None:
    from glrender.distributed.merge import Partial
    from glrender.render.checkpoint import save_band_checkpoint

    n = 64
    part = Partial(np.zeros((n, 4, 4), np.uint32), np.zeros((n, 3, 4), np.uint32), None, (0, 2))
    save_band_checkpoint(target, {"job": "0123456789abcdef", "plan": {"unit_size": 4096}},
                         {(None, 0): part})


SETUPS = {
    "old exr": lambda made, tmp: (tmp / "out.exr").write_bytes((made / "a.exr").read_bytes()),
    "old npy": lambda made, tmp: (tmp / "out.npy").write_bytes((made / "a.npy").read_bytes()),
    "old checkpoint": lambda made, tmp: (tmp / "out.npy.ckpt").write_bytes(
        (made / "a.ckpt").read_bytes()),
    "named checkpoint": lambda made, tmp: (tmp / "c.ckpt").write_bytes(
        (made / "a.ckpt").read_bytes()),
    "spp_done -5": lambda made, tmp: crafted(made, tmp / "c.ckpt", spp_done=-5),
    "spp_done 1e30": lambda made, tmp: crafted(made, tmp / "c.ckpt", spp_done=1e30),
    "spp_start > spp_done": lambda made, tmp: crafted(made, tmp / "c.ckpt", spp_start=3),
    "fingerprint": lambda made, tmp: crafted(made, tmp / "c.ckpt", fingerprint=12),
    "rows": lambda made, tmp: crafted(made, tmp / "c.ckpt", rows=[0, 9]),
    "width": lambda made, tmp: crafted(made, tmp / "c.ckpt",
                                       settings={"width": -8, "height": 8}),
    "option": lambda made, tmp: crafted(made, tmp / "c.ckpt", options={"spp": "many"}),
    "option range": lambda made, tmp: crafted(made, tmp / "c.ckpt", options={"max_depth": 0}),
    "photon option range": lambda made, tmp: crafted(made, tmp / "c.ckpt",
                                                      options={"integrator": "photon", "knn": 100}),
    "record": lambda made, tmp: crafted(made, tmp / "c.ckpt", params=["roughness"]),
    "band checkpoint": lambda made, tmp: band_checkpoint(made, tmp / "out.npy.ckpt"),
    "not an image": lambda made, tmp: (tmp / "n.png").write_text("hello"),
    "not an image array": lambda made, tmp: np.save(tmp / "n.npy", np.arange(5.0)),
    "images": lambda made, tmp: [np.save(tmp / f"{n}.npy", np.full((8, 8, 3), v, np.float32))
                                 for n, v in (("a", 0.5), ("b", 0.25), ("r", 0.4))],
    "a file": lambda made, tmp: (tmp / "afile").write_text(""),
}


@dataclass
class Row:
    args: list                  # the command line; "{tmp}" is the test's folder
    line: str                   # a regex the one error line must match
    setup: tuple = ()           # SETUPS to run first
    patch: str | None = None    # a fault planted before the command line runs
    kept: list = field(default_factory=list)     # files there afterwards, unchanged if
                                                 # they were there before
    absent: list = field(default_factory=list)   # files (or folders) not there afterwards


R = ["render", CORNELL]
RESUME = R + ["-o", "{tmp}/out.npy", "--checkpoint", "{tmp}/c.ckpt", "--resume"]
ROWS = {
    # 1: outputs that are not writable, found before the render (the image is not written)
    "--stats in /proc": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--stats", "/proc/x.json"],
                            r"--stats /proc/x\.json: cannot write to the folder /proc \(.+\); "
                            r"choose another --stats$", absent=["out.npy"]),
    "--checkpoint in /proc": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--checkpoint",
                                      "/proc/x.ckpt"],
                                 r"--checkpoint /proc/x\.ckpt: cannot write to the folder /proc",
                                 absent=["out.npy"]),
    # 2: the periodic checkpoint of the issue: found before the render, not a second into it
    "--checkpoint-every in /proc": Row(
        R + ["-o", "{tmp}/out.npy", *SMALL, "--checkpoint", "/proc/x.ckpt",
             "--checkpoint-every", 1],
        r"--checkpoint /proc/x\.ckpt: cannot write to the folder /proc", absent=["out.npy"]),
    "--stats is a folder": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--stats", "{tmp}"],
                               r"--stats .+: is a folder, expected a file name for the statistics",
                               absent=["out.npy"]),
    "--stats is a device": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--stats", "/dev/null"],
                               r"--stats /dev/null: is not a regular file", absent=["out.npy"]),
    "--strategy-images in /proc": Row(
        R + ["-o", "{tmp}/out.npy", *SMALL, "--integrator", "bdpt", "--strategy-images", "/proc/x"],
        r"--strategy-images /proc/x: cannot create the folder for the strategy images",
        absent=["out.npy"]),
    "cluster --stats in /proc": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--workers", 1,
                                         "--stats", "/proc/x.json"],
                                    r"--stats /proc/x\.json: cannot write to the folder /proc",
                                    absent=["out.npy"]),
    # 3: a full disk at the end: the old image intact, the render kept in the checkpoint
    "exr on a full disk": Row(R + ["-o", "{tmp}/out.exr", *SMALL, "--quiet"],
                              r"out\.exr: cannot write \(OpenEXR: Cannot write image file .*No "
                              r"space left on device\); the render is kept in .*out\.exr\.ckpt: "
                              r".*--resume", setup=("old exr",), patch=FULL_DISK_EXR,
                              kept=["out.exr", "out.exr.ckpt"]),
    "npy on a full disk": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--quiet"],
                              r"out\.npy: cannot write \(No space left on device\); the render "
                              r"is kept in .*out\.npy\.ckpt", setup=("old npy",),
                              patch=FULL_DISK_NPY, kept=["out.npy", "out.npy.ckpt"]),
    # 4: checkpoints that cannot be trusted, refused before the render
    "spp_done -5": Row(RESUME,
                       r"c\.ckpt: the checkpoint's spp_done is -5, expected a whole number of "
                       r"samples per pixel in 0\.\.2147483648: render without --resume",
                       setup=("spp_done -5",), kept=["c.ckpt"], absent=["out.npy"]),
    "spp_done 1e30": Row(RESUME,
                         r"c\.ckpt: the checkpoint's spp_done is 1e\+30, expected a whole number",
                         setup=("spp_done 1e30",), kept=["c.ckpt"], absent=["out.npy"]),
    "spp_start": Row(RESUME,
                     r"c\.ckpt: the checkpoint's spp_start is 3, expected a whole number of "
                     r"samples in 0\.\.2", setup=("spp_start > spp_done",), absent=["out.npy"]),
    "fingerprint": Row(RESUME,
                       r"c\.ckpt: the checkpoint's fingerprint is 12, expected 64 hexadecimal",
                       setup=("fingerprint",), absent=["out.npy"]),
    "rows": Row(RESUME,
                r"c\.ckpt: the checkpoint's rows is \[0, 9\], expected \[first, count\] tile rows "
                r"within the image's 1", setup=("rows",), absent=["out.npy"]),
    "width": Row(RESUME,
                 r"c\.ckpt: the checkpoint's settings\.width is -8, expected pixels in 1\.\.65536",
                 setup=("width",), absent=["out.npy"]),
    "saved option type": Row(RESUME,
                             r"c\.ckpt: the checkpoint's option spp is \"many\", expected an "
                             r"integer", setup=("option",), absent=["out.npy"]),
    "saved option range": Row(RESUME,
                              r"c\.ckpt: the checkpoint's option --max-depth 0: expected -1",
                              setup=("option range",), absent=["out.npy"]),
    "saved photon option range": Row(RESUME, r"c\.ckpt: the checkpoint's option --knn 100: "
                                     r"expected an integer in \[1, 64\]",
                                     setup=("photon option range",), absent=["out.npy"]),
    "record": Row(RESUME,
                  r"c\.ckpt: the checkpoint's params is \[\"roughness\"\], expected an object",
                  setup=("record",), absent=["out.npy"]),
    # lost work: a new render does not replace a checkpoint that is there
    "new render over OUT.ckpt": Row(R + ["-o", "{tmp}/out.npy", *SMALL],
                                    r"out\.npy\.ckpt: a checkpoint of 2 spp \(of 2\) is there: "
                                    r"continue it with --resume, or start afresh with --overwrite",
                                    setup=("old checkpoint",), kept=["out.npy.ckpt"],
                                    absent=["out.npy"]),
    "new render over --checkpoint": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--checkpoint",
                                             "{tmp}/c.ckpt", "--checkpoint-every", 1],
                                        r"c\.ckpt: a checkpoint of 2 spp \(of 2\) is there",
                                        setup=("named checkpoint",), kept=["c.ckpt"],
                                        absent=["out.npy"]),
    "--resume and --overwrite": Row(R + ["-o", "{tmp}/out.npy", "--resume", "--overwrite"],
                                    r"--resume and --overwrite: give one",
                                    setup=("old checkpoint",), kept=["out.npy.ckpt"],
                                    absent=["out.npy"]),
    "new cluster render over OUT.ckpt": Row(R + ["-o", "{tmp}/out.npy", *SMALL, "--workers", 1],
                                            r"out\.npy\.ckpt: a checkpoint of 1 finished band "
                                            r"is there: continue it with --resume",
                                            setup=("band checkpoint",), kept=["out.npy.ckpt"],
                                            absent=["out.npy"]),
    # 5: the other commands
    "sampling --out in /proc": Row(["sampling", "--out", "/proc/x", "--samples", 1000],
                                   r"--out /proc/x: cannot create the folder for the sampling "
                                   r"plots \(.+\); choose another --out$"),
    "sampling --out is a file": Row(["sampling", "--out", "{tmp}/afile", "--samples", 1000],
                                    r"--out .+afile: is a file, expected a folder",
                                    setup=("a file",), kept=["afile"]),
    "compare, not an image": Row(["compare", "{tmp}/n.png", "{tmp}/n.png", "--ref", "{tmp}/n.png",
                                  "--out", "{tmp}/cmp"],
                                 r"n\.png: A is not a readable image \(cannot identify image "
                                 r"file .*\); expected EXR", setup=("not an image",),
                                 absent=["cmp"]),
    "compare, not an image array": Row(["compare", "{tmp}/n.npy", "{tmp}/n.npy", "--ref",
                                        "{tmp}/n.npy", "--out", "{tmp}/cmp"],
                                       r"n\.npy: A holds an array of shape \(5,\), expected an "
                                       r"image", setup=("not an image array",),
                                       absent=["cmp"]),
    "compare --out in /proc": Row(["compare", "{tmp}/a.npy", "{tmp}/b.npy", "--ref", "{tmp}/r.npy",
                                   "--out", "/proc/x"],
                                  r"--out /proc/x: cannot create the folder for the comparison",
                                  setup=("images",)),
    "lab --out in /proc": Row(["lab", "--quick", "--out", "/proc/x"],
                              r"--out /proc/x: cannot create the folder for the lab report"),
    "preview --screenshot-dir in /proc": Row(["preview", CORNELL, "--screenshot-dir", "/proc/x"],
                                             r"--screenshot-dir /proc/x: cannot create the folder "
                                             r"for the screenshots"),
    "preview --record in /proc": Row(["preview", CORNELL, "--record", "/proc/x"],
                                     r"--record /proc/x: cannot create the folder for the "
                                     r"recorded frames"),
}


@pytest.mark.parametrize("name", list(ROWS))
def test01_one_line_exit_2_and_nothing_lost(tmp_path, made, name):
    row = ROWS[name]
    for setup in row.setup:
        SETUPS[setup](made, tmp_path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    args = [str(a).replace("{tmp}", str(tmp_path)) for a in row.args]
    line = one_error_line(run(args, row.patch))
    assert re.search(row.line, line), line
    for kept in row.kept:
        path = tmp_path / kept
        assert path.is_file(), (kept, line)
        if kept in before:
            assert path.read_bytes() == before[kept], kept
    for absent in row.absent:
        assert not (tmp_path / absent).exists(), absent
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert leftovers == []          # no temporary file or probe left behind


def test02_a_write_that_failed_is_written_by_resume(tmp_path, made):
    """After a full disk at the end, --resume renders nothing and writes the image: the
    samples were kept."""
    out = tmp_path / "out.npy"
    one_error_line(run(["render", CORNELL, "-o", out, *SMALL, "--quiet"], FULL_DISK_NPY))
    assert load_checkpoint(tmp_path / "out.npy.ckpt").spp_done == 2
    r = glrender("render", CORNELL, "-o", out, "--resume")
    assert r.returncode == 0, r.stderr
    assert "no new samples" in r.stderr
    np.testing.assert_array_equal(np.load(out), np.load(made / "a.npy"))


def test03_failed_periodic_checkpoints_warn_once_and_the_render_goes_on(tmp_path):
    out, stats = tmp_path / "out.npy", tmp_path / "s.json"
    r = run(["render", CORNELL, "-o", out, "--width", 16, "--height", 16, "--spp", 64,
             "--checkpoint-every", 1e-6, "--stats", stats], FLAKY_CHECKPOINTS)
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1, r.stderr
    assert re.search(r"out\.npy\.ckpt: cannot write \(No space left on device\): the render goes "
                     r"on, trying again every 1e-06 s", warnings[0]), warnings[0]
    record = json.loads(stats.read_text())
    assert record["spp"] == 64 and record["passes"] > 4
    assert record["checkpoints_written"] == record["passes"] - 1 - 3   # 3 met the full disk
    assert load_checkpoint(tmp_path / "out.npy.ckpt").spp_done == 64   # the last one, at exit
    assert out.is_file()


def test04_a_partial_image_never_replaces_a_complete_one(tmp_path):
    out = tmp_path / "out.npy"
    first = glrender("render", CORNELL, "-o", out, "--width", 16, "--height", 16, "--spp", 4,
                     "--quiet")
    assert first.returncode == 0, first.stderr
    complete = out.read_bytes()
    # a rerun interrupted: 2^20 spp cannot end before the signal
    running = Running("render", CORNELL, "-o", out, "--width", 16, "--height", 16,
                      "--spp", 1 << 20, "--seed", 9)
    running.wait_for("glrender: rendering")
    time.sleep(0.5)
    running.proc.send_signal(signal.SIGINT)
    assert running.wait() == 130, running.stderr
    partial = tmp_path / "out.partial.npy"
    assert out.read_bytes() == complete and partial.is_file()
    assert f"partial image -> {partial} ({out}, already there, is kept)" in running.stderr
    assert load_checkpoint(tmp_path / "out.npy.ckpt").spp_done > 0
    assert np.load(partial).shape == (16, 16, 3)


def test05_atomic_write_turns_system_errors_only_into_one_line(tmp_path):
    """atomic_write names the file for an OSError (and writers' library errors made into
    one); a programming error passes through as itself; the old file stays either way."""
    path = tmp_path / "x.txt"
    path.write_text("old")

    def full(tmp):
        tmp.write_text("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(WriteError, match=r"x\.txt: cannot write \(No space left on device\)$"):
        atomic_write(path, full)
    for error in (ZeroDivisionError, RuntimeError, KeyError):
        def bug(tmp, error=error):
            raise error("a bug")
        with pytest.raises(error):
            atomic_write(path, bug)
    with pytest.raises(WriteError, match="cannot write"):
        atomic_write(tmp_path / "gone" / "x.txt", lambda tmp: tmp.write_text("new"))
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["x.txt"]


def test06_check_writable_probes(tmp_path):
    assert check_writable(tmp_path / "a.json", "statistics", "--stats") == tmp_path / "a.json"
    folder = check_writable(tmp_path / "new" / "deeper", "plots", "--out", folder=True)
    assert folder.is_dir() and list(folder.iterdir()) == []     # created, the probe gone
    for path, kwargs, message in (
            ("/proc/x.json", {}, r"--stats /proc/x\.json: cannot write to the folder /proc"),
            ("/proc/x", {"folder": True}, r"--stats /proc/x: cannot create the folder"),
            (tmp_path, {}, "is a folder, expected a file name"),
            (tmp_path / "no" / "x.json", {}, "does not exist"),
    ):
        with pytest.raises(UsageError, match=message):
            check_writable(path, "statistics", "--stats", **kwargs)


def test07_the_saved_options_are_checked_as_the_command_line_parses_them():
    """Every option a checkpoint saves has its kind in the resume's check, the one argparse
    gives it (a type, the choices, a flag)."""
    import argparse

    from glrender.commands.cli import build_parser
    from glrender.commands.options import RESUMABLE
    from glrender.commands.photon_options import OPTIONS as PHOTON_OPTIONS
    from glrender.commands.render import _saved_kinds

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    actions = {a.dest: a for a in sub.choices["render"]._actions}
    kinds = _saved_kinds()
    for name in RESUMABLE + PHOTON_OPTIONS:
        action, kind = actions[name], kinds[name]
        if action.choices is not None:
            assert kind == tuple(action.choices), name
        elif action.const is True:
            assert kind is bool, name
        elif name != "crop":
            assert kind is (action.type or str), name


def test08_overwrite_starts_afresh(tmp_path, made):
    """--overwrite replaces the checkpoint that stopped a new render; --help says so."""
    ckpt = tmp_path / "c.ckpt"
    ckpt.write_bytes((made / "a.ckpt").read_bytes())
    r = glrender("render", CORNELL, "-o", tmp_path / "out.npy", "--width", 8, "--height", 8,
                 "--spp", 3, "--checkpoint", ckpt, "--overwrite", "--quiet")
    assert r.returncode == 0, r.stderr
    assert load_checkpoint(ckpt).spp_done == 3
    assert "--overwrite" in glrender("render", "--help").stdout


def test09_a_complete_image_removes_an_earlier_partial_one(tmp_path):
    out, stale = tmp_path / "out.npy", tmp_path / "out.partial.npy"
    np.save(stale, np.zeros((8, 8, 3), np.float32))
    r = glrender("render", CORNELL, "-o", out, *SMALL, "--quiet")
    assert r.returncode == 0, r.stderr
    assert out.is_file() and not stale.exists()


def test10_partial_strategy_images_never_replace_complete_ones(tmp_path):
    out, folder = tmp_path / "out.npy", tmp_path / "strategies"
    size = ["--width", 16, "--height", 16, "--integrator", "bdpt", "--strategy-images", folder,
            "--strategy-depth", 3]
    first = glrender("render", CORNELL, "-o", out, *size, "--spp", 2, "--quiet")
    assert first.returncode == 0, first.stderr
    complete = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert "strategies.npz" in complete
    (tmp_path / "out.npy.ckpt").unlink(missing_ok=True)
    running = Running("render", CORNELL, "-o", out, *size, "--spp", 1 << 20, "--seed", 9)
    running.wait_for("glrender: rendering")
    time.sleep(0.5)
    running.proc.send_signal(signal.SIGINT)
    assert running.wait() == 130, running.stderr
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == complete
    partial = tmp_path / "strategies.partial"
    assert sorted(p.name for p in partial.iterdir()) == sorted(complete)
