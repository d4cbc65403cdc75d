"""The exception hierarchy of glrender.

Every error a user can cause (a bad scene file, a missing device, a shader that
does not compile, a wrong argument) is a :class:`GlrenderError`. The command line
prints its message on one line and exits with :attr:`GlrenderError.exit_code`;
anything else escaping is a bug in glrender.
"""
from __future__ import annotations


class GlrenderError(Exception):
    """Base class of every error glrender reports to its users."""

    exit_code = 2


class DeviceError(GlrenderError):
    """No usable OpenGL device: EGL or Mesa missing, no such device, GL too old."""


class ShaderError(GlrenderError):
    """A GLSL source could not be preprocessed, compiled or linked.

    ``path`` and ``line`` point at the original file (relative to the shader root)
    and line, not at the concatenated source the driver saw.
    """

    def __init__(self, message: str, path: str | None = None, line: int | None = None,
                 log: str | None = None):
        self.path, self.line, self.log = path, line, log
        where = f"{path}:{line}: " if path is not None and line is not None else (
            f"{path}: " if path is not None else "")
        super().__init__(where + message)


class SceneError(GlrenderError):
    """A scene file or scene description is invalid."""


class UsageError(GlrenderError, ValueError):
    """A function or command was called with arguments it cannot use."""


class MissingExtra(UsageError):
    """An optional package is not installed. The message names the command that installs
    glrender's extra ``extra`` into the Python that is running (see :func:`install_command`)."""

    def __init__(self, needs: str, package: str, extra: str):
        self.package, self.extra = package, extra
        super().__init__(f"{needs} needs the {package} package, which is not installed; "
                         f"install it with: {install_command(extra)}")


def install_command(extra: str) -> str:
    """The command that installs glrender's optional ``extra`` into this Python.

    From a source checkout (an editable install, as ``./dev.sh`` makes), the checkout's
    extra: ``.venv/bin/python -m pip install -e '.[preview]'``; else the published
    package's: ``python -m pip install 'glrender[preview]'``. Paths inside the current
    folder are shown relative to it."""
    import os
    import shlex
    import sys
    from pathlib import Path

    def shown(path: str) -> str:
        try:
            relative = os.path.relpath(path)
        except ValueError:
            return path
        return relative if not relative.startswith("..") else path

    python = shown(sys.executable or "python")
    if os.sep not in python:
        python = "." + os.sep + python if os.path.exists(python) else python
    root = Path(__file__).resolve().parent.parent
    pyproject = root / "pyproject.toml"
    try:
        checkout = pyproject.is_file() and 'name = "glrender"' in pyproject.read_text()
    except OSError:
        checkout = False
    if checkout:
        return f"{shlex.quote(python)} -m pip install -e {shlex.quote(f'{shown(str(root))}[{extra}]')}"
    return f"{shlex.quote(python)} -m pip install {shlex.quote(f'glrender[{extra}]')}"
