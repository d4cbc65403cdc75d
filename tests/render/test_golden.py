"""Golden hashes (tools/golden.py): every integrator on the Cornell box, bunny, caustic and door
scenes, path and direct on the media scenes (cornell-fog, smoke), and every output format
decoded back to floats, bitwise the same as recorded.

On a device tests/data/golden.json does not know, the recorded base commit is rendered now in
a temporary git worktree and compared instead: the check never skips."""
from __future__ import annotations

import base64
import copy
import importlib.util
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _golden():
    spec = importlib.util.spec_from_file_location("golden", ROOT / "tools" / "golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test01_compare_names_each_difference():
    golden = _golden()
    data = json.loads(golden.GOLDEN.read_text())
    want = next(iter(data["devices"].values()))
    assert golden.compare(want, want) == []
    got = copy.deepcopy(want)
    got["cornell-path"]["sha256"][".npy"] = "0" * 64
    radiance = np.frombuffer(base64.b64decode(got["caustic-sppm"]["radiance"]), np.float32).copy()
    radiance[radiance.argmax()] *= 1 + 4 * golden.SPPM_RTOL
    got["caustic-sppm"]["radiance"] = base64.b64encode(radiance.tobytes()).decode()
    del got["door-ao"]
    problems = golden.compare(want, got)
    assert len(problems) == 3, problems
    assert any(p.startswith("cornell-path.npy") for p in problems)
    assert any(p.startswith("caustic-sppm: radiance") for p in problems)
    assert any(p.startswith("door-ao") for p in problems)


def test02_images_are_the_golden_ones():
    problems = _golden().check(log=print)
    assert not problems, "\n".join(problems)
