"""The layers of glrender (pyproject.toml [tool.importlinter], drawn in docs/architecture.md):
``lint-imports`` keeps every contract, and breaks one when a lower layer imports a higher one."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def lint(package_parent: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(package_parent))
    return subprocess.run([str(LINT), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
                          cwd=package_parent, env=env, capture_output=True, text=True)


def test01_every_contract_is_kept():
    result = lint(ROOT)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert "0 broken" in result.stdout


def test02_an_import_from_a_lower_layer_up_breaks_the_layers(tmp_path):
    shutil.copytree(ROOT / "glrender", tmp_path / "glrender",
                    ignore=shutil.ignore_patterns("__pycache__", "shaders"))
    # the BVH builder asking the command line for something: accel sits far below commands
    (tmp_path / "glrender" / "accel" / "reaches_up.py").write_text(
        "from ..commands.options import parse_crop\n")
    result = lint(tmp_path)
    assert result.returncode != 0
    assert "Layers: commands" in result.stdout and "BROKEN" in result.stdout
    assert "glrender.accel.reaches_up -> glrender.commands.options" in result.stdout
