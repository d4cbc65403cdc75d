#!/usr/bin/env python3
"""Golden hashes: every integrator's image on four scenes, the images of the integrators that
render media (path, direct) on the two media scenes, and every output format decoded back to
floats, hashed so that a change meant to leave images alone can prove it did.

Each case is rendered through the command line (``glrender render``), the interface that stays
put when the code behind it moves, in one child process per tree. A case's hash is the SHA-256
of the decoded float32 array (file bytes would depend on the zlib and OpenEXR builds). SPPM
deposits its photons with float atomics, whose order the device may change between runs: its
photon counts and radii are hashed, its radiance is kept as numbers and compared to a relative
``SPPM_RTOL``.

Hashes hold only on the device that made them, so ``tests/data/golden.json`` keys them by
``GL_RENDERER`` and ``GL_VERSION`` (which names the Mesa version)::

    .venv/bin/python tools/golden.py --record          # this tree's hashes for this device
    .venv/bin/python tools/golden.py                    # this tree against the recorded hashes
    .venv/bin/python tools/golden.py --base COMMIT      # this tree against COMMIT, rendered now

``--base`` renders COMMIT from a temporary ``git worktree`` with the same Python and device, so
it works on any device; without it, a device the file does not know renders the file's own
``base`` commit the same way. Exit status: 0 when every case matches, 1 when one differs (each is
named), 2 on bad usage.
"""
from __future__ import annotations

import argparse
import base64
import contextlib
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "golden.json"
SPPM_RTOL = 1e-6

SCENES = {"cornell": "scenes/cornell-box/scene.toml",
          "bunny": "scenes/cornell-bunny/scene.toml",
          "caustic": "scenes/caustic/scene.toml",
          "door": "scenes/door/scene.toml"}
INTEGRATORS = ("path", "direct", "ao", "lighttrace", "bdpt", "photon", "sppm", "vcm")
# scenes with participating media, and the integrators that render them
MEDIA_SCENES = {"cornell-fog": "scenes/cornell-fog/scene.toml",
                "smoke": "scenes/smoke/scene.toml"}
MEDIA_INTEGRATORS = ("path", "direct")
SIZE = ("--width", "24", "--height", "24")
# photon: a small map; sppm: 4 iterations of a small photon count
PHOTON_ARGS = {"photon": ("--photons", "20000"), "sppm": ("--photons", "5000")}
FORMATS = (".npy", ".exr", ".pfm", ".hdr", ".png")


def cases() -> dict[str, tuple[list[str], list[str]]]:
    """Case name -> (``glrender render`` arguments without ``-o``, output suffixes)."""
    out = {}
    for scene_name, scene in SCENES.items():
        for integrator in INTEGRATORS:
            spp = "4" if integrator == "sppm" else "8"
            args = [scene, *SIZE, "--spp", spp, "--seed", "7", "--integrator", integrator,
                    *PHOTON_ARGS.get(integrator, ())]
            if integrator == "sppm":
                args += ["--aov", "radius,photons"]
            out[f"{scene_name}-{integrator}"] = (args, [".npy"])
    for scene_name, scene in MEDIA_SCENES.items():
        for integrator in MEDIA_INTEGRATORS:
            out[f"{scene_name}-{integrator}"] = ([scene, *SIZE, "--spp", "8", "--seed", "7",
                                                  "--integrator", integrator], [".npy"])
    out["cornell-formats"] = ([SCENES["cornell"], *SIZE, "--spp", "8", "--seed", "3",
                               "--integrator", "path"], list(FORMATS))
    return out


# The child: renders every case with the tree on its sys.path. It uses nothing but the
# command line's main(argv), found where either layout of the package keeps it.
CHILD = r"""
import importlib, json, sys
for name in ("glrender.commands.cli", "glrender.cli"):
    try:
        main = importlib.import_module(name).main
        break
    except ImportError:
        continue
import glrender
from glrender.gl.context import default_context
from glrender.gl.shaders import packaged_root
from pathlib import Path
tree = Path(sys.argv[2]).resolve()
for what, path in (("the package", Path(glrender.__file__)), ("the shaders", packaged_root())):
    if tree not in path.resolve().parents:
        sys.exit(f"golden: {what} came from {path}, not from {tree}")
info = default_context().gl.info
jobs = json.loads(sys.argv[1])
codes = {}
for name, (argv, outputs) in jobs.items():
    codes[name] = [main(["render", *argv, "-o", out, "--quiet"]) for out in outputs]
json.dump({"device": f"{info['GL_RENDERER']} | {info['GL_VERSION']}", "codes": codes},
          sys.stdout)
"""


def _sha(array: np.ndarray) -> str:
    a = np.ascontiguousarray(array, dtype=np.float32)
    return hashlib.sha256(repr(a.shape).encode() + a.tobytes()).hexdigest()


def _decode(path: Path) -> np.ndarray:
    sys.path.insert(0, str(ROOT))
    from glrender.film.io import read_image

    return np.load(path) if path.suffix == ".npy" else read_image(path)


def render(tree: Path, workdir: Path) -> tuple[str, dict]:
    """Render every case with the package in ``tree``; returns the device key and, per case,
    its record: ``{"sha256": {file: hash}}``, SPPM's ``radiance`` (base64 float32) besides."""
    jobs = {}
    for name, (argv, suffixes) in cases().items():
        argv = [str(tree / argv[0]), *argv[1:]]
        jobs[name] = (argv, [str(workdir / f"{name}{s}") for s in suffixes])
    env = dict(os.environ, PYTHONPATH=str(tree))
    proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(jobs), str(tree)],
                          cwd=workdir, env=env,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"rendering the golden cases from {tree} failed "
                           f"(exit {proc.returncode}):\n{proc.stderr[-4000:]}")
    answer = json.loads(proc.stdout)
    records = {}
    for name, (_, outputs) in jobs.items():
        if any(code != 0 for code in answer["codes"][name]):
            raise RuntimeError(f"{name}: glrender render exited {answer['codes'][name]}")
        files = sorted(p for p in workdir.iterdir() if p.name.startswith(name + ".")
                       or p.name.startswith(name + "-"))
        record: dict = {"sha256": {}}
        for path in files:
            if path.suffix not in FORMATS or path.name.endswith(".ckpt"):
                continue
            image = _decode(path)
            key = path.name[len(name):]
            if name.endswith("-sppm") and key == ".npy":
                record["radiance"] = base64.b64encode(
                    np.ascontiguousarray(image, np.float32).tobytes()).decode()
                record["shape"] = list(image.shape)
            else:
                record["sha256"][key] = _sha(image)
        records[name] = record
    return answer["device"], records


def compare(want: dict, got: dict) -> list[str]:
    """The cases whose images differ, one line each (empty when all match)."""
    problems = []
    for name in sorted(set(want) | set(got)):
        if name not in want or name not in got:
            problems.append(f"{name}: only in {'the new' if name in got else 'the recorded'} set")
            continue
        w, g = want[name], got[name]
        for key in sorted(set(w["sha256"]) | set(g["sha256"])):
            if w["sha256"].get(key) != g["sha256"].get(key):
                problems.append(f"{name}{key}: hash differs")
        if "radiance" in w or "radiance" in g:
            a, b = (np.frombuffer(base64.b64decode(r.get("radiance", "")), np.float32)
                    for r in (w, g))
            if a.shape != b.shape:
                problems.append(f"{name}: radiance has {b.size} values, recorded {a.size}")
            else:
                scale = max(float(np.abs(a).max(initial=0.0)), 1e-30)
                worst = float(np.abs(a - b).max(initial=0.0)) / scale
                if worst > SPPM_RTOL:
                    problems.append(f"{name}: radiance differs by {worst:.3g} relative "
                                    f"(allowed {SPPM_RTOL:g})")
    return problems


@contextlib.contextmanager
def worktree(commit: str):
    """A temporary checkout of ``commit`` (``git worktree``), removed afterwards."""
    tmp = Path(tempfile.mkdtemp(prefix="glrender-golden-"))
    path = tmp / "tree"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(path), commit],
                   check=True, capture_output=True, text=True)
    # the package's shaders are glrender.shaders (setup.py maps the top-level folder there):
    # in the checkout, a link puts them where the import finds them before any installed copy
    (path / "glrender" / "shaders").symlink_to(Path("..") / "shaders")
    try:
        yield path
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(path)],
                       capture_output=True)
        subprocess.run(["rm", "-rf", str(tmp)])


def render_tree(tree: Path) -> tuple[str, dict]:
    with tempfile.TemporaryDirectory(prefix="glrender-golden-out-") as out:
        return render(tree, Path(out))


def check(base: str | None = None, record: bool = False, log=print) -> list[str]:
    """Render this tree and compare it (see the module's doc); returns the differences."""
    data = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {"devices": {}}
    device, got = render_tree(ROOT)
    if record:
        data.setdefault("devices", {})[device] = got
        if "base" not in data:
            data["base"] = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"],
                                          capture_output=True, text=True, check=True).stdout.strip()
        GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        log(f"recorded {len(got)} cases for {device} in {GOLDEN.relative_to(ROOT)}")
        return []
    if base is None and device in data.get("devices", {}):
        log(f"comparing {len(got)} cases with the hashes recorded for {device}")
        return compare(data["devices"][device], got)
    commit = base or data.get("base")
    if not commit:
        raise RuntimeError(f"{GOLDEN}: no base commit to render for a device it does not know")
    log(f"rendering {commit} on {device} to compare with")
    with worktree(commit) as tree:
        _, want = render_tree(tree)
    return compare(want, got)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", help="compare with this commit, rendered now")
    parser.add_argument("--record", action="store_true",
                        help="write this tree's hashes for this device to tests/data/golden.json")
    args = parser.parse_args(argv)
    if args.base and args.record:
        print("golden.py: --base and --record exclude each other", file=sys.stderr)
        return 2
    problems = check(args.base, args.record)
    for line in problems:
        print(line)
    print(f"golden: {'all cases match' if not problems else f'{len(problems)} differences'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
