"""What loaders tell their users besides errors: warnings, and referenced files.

- Warnings go through Python's :mod:`warnings` with the category
  :class:`GlrenderWarning`; a loader collects what it skipped (unsupported tags,
  plugins, extensions) and reports it in *one* warning that lists each item with its
  line number, instead of one warning per occurrence.
- Files a scene refers to are resolved relative to the referencing file's folder;
  a path that leaves the scene's folder (``..``, absolute paths) is reported, a
  missing file is an error that names the referencing file and line.
"""
from __future__ import annotations

import os
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ...errors import SceneError


class GlrenderWarning(UserWarning):
    """A scene loaded, but not everything in it is used as written."""


def warn(message: str) -> None:
    warnings.warn(message, GlrenderWarning, stacklevel=3)


class Notes:
    """Things a loader skipped, reported together: ``add(what, line)`` then ``emit()``."""

    def __init__(self, source, title: str):
        self.source, self.title = str(source), title
        self.items: dict[str, list] = {}

    def add(self, what: str, line: int | None = None) -> None:
        lines = self.items.setdefault(what, [])
        if line is not None and line not in lines:
            lines.append(line)

    def emit(self) -> None:
        if not self.items:
            return
        parts = []
        for what, lines in self.items.items():
            if lines:
                shown = ", ".join(map(str, lines[:8])) + (", ..." if len(lines) > 8 else "")
                parts.append(f"{what} (line{'s' if len(lines) > 1 else ''} {shown})")
            else:
                parts.append(what)
        warn(f"{self.source}: {self.title}: {'; '.join(parts)}")
        self.items = {}


_recording = threading.local()


@contextmanager
def record_files():
    """Collect the files that scenes loaded on this thread refer to: yields a list that
    fills with the absolute path of each file found, as the scene names it (symbolic
    links not followed), so a copy of those files in the same layout loads the same
    scene (glrender.distributed ships scenes to workers this way)."""
    outer = getattr(_recording, "files", None)
    files: list[Path] = []
    _recording.files = files
    try:
        yield files
    finally:
        _recording.files = outer
        if outer is not None:
            outer.extend(files)


def file_hashes(paths) -> dict[str, str]:
    """SHA-256 of each file (absolute path -> hex digest): what a checkpoint records, so that
    resuming after an input changed is refused by the file's name."""
    import hashlib

    hashes: dict[str, str] = {}
    for p in paths:
        key = os.path.abspath(p)
        if key in hashes:
            continue
        h = hashlib.sha256()
        try:
            with open(key, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
        except OSError:
            continue            # gone since the loader read it: nothing to compare
        hashes[key] = h.hexdigest()
    return hashes


class SceneFiles:
    """Resolves the files a scene refers to, relative to the folder of the scene file
    that refers to them, and remembers the scene's root folder to report paths that
    leave it (once per path)."""

    def __init__(self, root: Path):
        self.root = Path(root).resolve()
        self._reported: set[Path] = set()

    def resolve(self, name: str, referrer, line: int | None = None, what: str = "file",
                search: tuple = ()) -> Path:
        """The existing file ``name`` refers to; ``search`` adds extra folders to try
        (Mitsuba's <path>). Raises SceneError naming ``referrer`` and ``line``."""
        where = f"{referrer}:{line}" if line is not None else f"{referrer}"
        if not isinstance(name, str) or not name.strip() or "\0" in name:
            raise SceneError(f"{where}: expected a {what} name, got {name!r}")
        base = Path(referrer).parent
        candidates = [base / name] + [Path(folder) / name for folder in search]
        for candidate in candidates:
            try:
                path = candidate.resolve()
                found = path.is_file()
            except (OSError, RuntimeError):
                continue
            if found:
                self._check_inside(path, name, where)
                if getattr(_recording, "files", None) is not None:
                    _recording.files.append(Path(os.path.abspath(candidate)))
                return path
        raise SceneError(f"{where}: {what} {name!r} not found (looked in {base.resolve()})")

    def _check_inside(self, path: Path, name: str, where: str) -> None:
        try:
            path.relative_to(self.root)
        except ValueError:
            if path not in self._reported:
                self._reported.add(path)
                warn(f"{where}: {name!r} resolves to {path}, outside the scene's folder "
                     f"{self.root}")


def read_bytes(path, limit: int | None = None) -> bytes:
    """A whole file, with errors that name it (and refuse files above ``limit`` bytes)."""
    path = Path(path)
    try:
        if limit is not None and path.stat().st_size > limit:
            raise SceneError(f"{path}: {path.stat().st_size} bytes is more than this loader reads "
                             f"({limit})")
        return path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{path}: no such file") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read ({exc.strerror or exc})") from None


MAX_IMAGE_PIXELS = 1 << 26        # 8192 x 8192: larger textures are refused before decoding


def check_image_size(width: int, height: int, where: str) -> None:
    if width * height > MAX_IMAGE_PIXELS:
        raise SceneError(f"{where}: the image declares {width} x {height} pixels, more than the "
                         f"{MAX_IMAGE_PIXELS} a texture may have")


def read_image_checked(path) -> np.ndarray:
    """An image file as linear RGB (glrender.film.io.read_image), its declared size checked
    first for formats PIL reads lazily (a PNG header may claim 10^10 pixels)."""
    from PIL import Image

    from ...film.io import read_image

    path = Path(path)
    if path.suffix.lower() not in (".exr", ".hdr", ".pfm", ".npy"):
        try:
            with Image.open(path) as im:
                check_image_size(im.size[0], im.size[1], str(path))
        except SceneError:
            raise
        except Exception as exc:       # PIL's errors for truncated, unknown or bomb files
            raise SceneError(f"{path}: cannot read the image ({exc})") from None
    try:
        return read_image(path)
    except Exception as exc:
        raise SceneError(f"{path}: cannot read the image ({exc})") from None
