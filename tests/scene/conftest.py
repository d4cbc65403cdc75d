"""Helpers for the scene loader tests: data folders and a warning recorder."""
from __future__ import annotations

import warnings
from pathlib import Path

import pytest

DATA = Path(__file__).parents[1] / "data"
SCENES = DATA / "scenes"


@pytest.fixture
def write(tmp_path):
    """write("name.ext", text or bytes) -> the path of a new file in a temporary folder."""
    def _write(name: str, content) -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
        return path
    return _write


def glrender_warnings(record) -> list[str]:
    from glrender.scene import GlrenderWarning

    return [str(w.message) for w in record if issubclass(w.category, GlrenderWarning)]


@pytest.fixture
def caught():
    """Collects GlrenderWarning messages: `with caught as messages:` ... after the block."""
    class Catch:
        def __enter__(self):
            self._cm = warnings.catch_warnings(record=True)
            self.record = self._cm.__enter__()
            warnings.simplefilter("always")
            self.messages = []
            return self.messages

        def __exit__(self, *exc):
            self.messages.extend(glrender_warnings(self.record))
            return self._cm.__exit__(*exc)
    return Catch()
