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
