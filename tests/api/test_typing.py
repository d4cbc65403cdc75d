"""The public API is fully annotated: ``mypy --strict`` passes on glrender/__init__.py, on
every module a public name comes from, and on a user's script that uses them all
(typed_client.py), and the package ships ``py.typed``."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import glrender

ROOT = Path(__file__).resolve().parents[2]


def public_modules() -> list[str]:
    """Source files of glrender/__init__.py and of every module a public name is defined in."""
    files = {ROOT / "glrender" / "__init__.py"}
    for name in glrender.__all__:
        module = getattr(getattr(glrender, name), "__module__", None)
        if module and module.startswith("glrender."):
            files.add(Path(sys.modules[module].__file__ or ""))
    return sorted(str(f.relative_to(ROOT)) for f in files)


def test_public_modules_listed():
    mods = public_modules()
    for expected in ("glrender/__init__.py", "glrender/film/film.py", "glrender/errors.py",
                     "glrender/render/renderer.py", "glrender/scene/model.py"):
        assert expected in mods


def test_py_typed_shipped():
    assert (ROOT / "glrender" / "py.typed").is_file()
    assert '"py.typed"' in (ROOT / "pyproject.toml").read_text()


@pytest.mark.slow
def test_mypy_strict(tmp_path):
    pytest.importorskip("mypy")
    cmd = [sys.executable, "-m", "mypy", "--strict", "--follow-imports=silent",
           "--cache-dir", str(tmp_path / "cache"), *public_modules(), "tests/api/typed_client.py"]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
