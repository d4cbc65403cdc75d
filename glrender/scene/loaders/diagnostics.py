"""What loaders tell their users: warnings, excerpts of file content, the files read.

- Warnings go through Python's :mod:`warnings` with the category
  :class:`GlrenderWarning`; a loader collects what it skipped (unsupported tags,
  plugins, extensions) and reports it in *one* warning that lists each item with its
  line number, instead of one warning per occurrence.
- A message that quotes a file's content quotes it through :func:`excerpt`: control
  characters escaped (a scene file must not be able to drive the user's terminal with
  ESC sequences), the length capped; :func:`printable` escapes a whole message, which
  every warning and every error leaving :func:`glrender.load` gets as well.
- Where referenced files may be, and how they are read: :mod:`.scene_files`.
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
    warnings.warn(printable(message), GlrenderWarning, stacklevel=3)


EXCERPT_CHARS = 80


def printable(text: str) -> str:
    """``text`` with every character that is not printable (ESC, BEL, NUL, the other C0
    and C1 controls, line breaks, Unicode format characters such as bidi overrides)
    written as its Python escape (``\\x1b``); printable text is unchanged."""
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)


def excerpt(value, limit: int = EXCERPT_CHARS, quote: bool = True) -> str:
    """File content as a message may quote it: text (bytes are decoded as UTF-8 with
    replacement characters) with the non-printable characters escaped as
    :func:`printable` does, cut to ``limit`` characters followed by ``...`` when longer,
    in quotes as ``repr`` writes them unless ``quote`` is false. Anything else (a number
    or list from a JSON file) is shown by a size-limited ``repr``."""
    if isinstance(value, (bytes, bytearray)):
        value = bytes(value[:4 * limit + 4]).decode("utf-8", errors="replace")
    elif not isinstance(value, str):
        import reprlib

        value, quote = reprlib.repr(value), False
    head = value[:limit + 1]          # every character takes at least one place
    size = kept = 0
    for ch in head:
        width = 1 if ch.isprintable() else len(repr(ch)) - 2
        if size + width > limit:
            break
        size += width
        kept += 1
    text = value[:kept]
    shown = repr(text) if quote else printable(text)
    return shown + ("..." if kept < len(value) else "")


MAX_NOTES = 20


class Notes:
    """Things a loader skipped, reported together: ``add(what, line)`` then ``emit()``
    (the first MAX_NOTES kinds of them, and how many more)."""

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
        if len(parts) > MAX_NOTES:       # a garbage file: thousands of distinct "statements"
            parts = parts[:MAX_NOTES] + [f"and {len(parts) - MAX_NOTES} more"]
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


def cause(exc: BaseException, path=None) -> str:
    """Why a reader failed, for the parenthesis of a message about ``path``: a SceneError's
    own text (already made safe; the leading ``path:`` dropped), or the first line of
    another exception's text through :func:`excerpt` (a parser's message may quote the file)."""
    text = str(exc)
    if isinstance(exc, SceneError):
        return text.removeprefix(f"{printable(str(path))}: ") if path is not None else text
    first = text.splitlines()[0] if text.strip() else type(exc).__name__
    return excerpt(first, 2 * EXCERPT_CHARS, quote=False)


def note_file(path) -> None:
    """Add ``path`` to the files :func:`record_files` collects on this thread, if any."""
    if getattr(_recording, "files", None) is not None:
        _recording.files.append(Path(os.path.abspath(path)))


@contextmanager
def record_digests():
    """Collect the SHA-256 of every file read whole on this thread (:func:`note_digest`):
    yields a dict (absolute path -> hex digest) for :func:`file_hashes`, so a file that a
    loader read and hashed (the mesh caches key large files by their bytes) is not read
    and hashed again."""
    outer = getattr(_recording, "digests", None)
    digests: dict[str, str] = {}
    _recording.digests = digests
    try:
        yield digests
    finally:
        _recording.digests = outer
        if outer is not None:
            outer.update(digests)


def recording_digests() -> bool:
    return getattr(_recording, "digests", None) is not None


def note_digest(path, digest: str) -> None:
    """The SHA-256 of the bytes just read from ``path``, for :func:`record_digests`, if any."""
    if recording_digests():
        _recording.digests[os.path.abspath(path)] = digest


def file_hashes(paths, known: dict[str, str] | None = None) -> dict[str, str]:
    """SHA-256 of each file (absolute path -> hex digest): what a checkpoint records, so that
    resuming after an input changed is refused by the file's name. ``known``: digests of
    bytes already read (:func:`record_digests`), taken as they are."""
    import hashlib

    hashes: dict[str, str] = {}
    for p in paths:
        key = os.path.abspath(p)
        if key in hashes:
            continue
        if known and key in known:
            hashes[key] = known[key]
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


#: The most pixels an image a scene refers to (a texture or an environment map) may have, in
#: every format: 2^26 = 67,108,864, which is 8192 x 8192 or any other shape with no more
#: pixels. Checked from the file's header before any pixel is decoded.
MAX_TEXTURE_PIXELS = 1 << 26


def check_image_size(width: int, height: int) -> None:
    """Refuse an image of more than :data:`MAX_TEXTURE_PIXELS` (a SceneError saying why,
    for the caller to put after the file and the image's name)."""
    from ...film.io import ImageTooLarge

    if width * height > MAX_TEXTURE_PIXELS:
        raise SceneError(image_failure(ImageTooLarge("", width, height, MAX_TEXTURE_PIXELS,
                                                     "a texture or environment map")))


def image_failure(exc: BaseException, path=None) -> str:
    """Why an image could not be read, without its path (the message names it once): our
    own readers' reason, or a decoder's as "cannot decode it (...)"."""
    from ...film.io import ImageTooLarge

    text = str(exc).strip()
    text = text.splitlines()[0] if text else type(exc).__name__
    if path is not None:
        for shown in (str(path), printable(str(path))):
            text = text.removeprefix(f"{shown}: ").replace(f" {shown!r}", "").replace(shown, "it")
    text = text.removeprefix(": ")
    if isinstance(exc, (ImageTooLarge, SceneError)):
        return text
    return f"cannot decode it ({excerpt(text, 2 * EXCERPT_CHARS, quote=False)})"


def read_image_checked(path, environment: bool = False) -> np.ndarray:
    """An image file a scene refers to, as linear RGB (glrender.film.io.read_image): refused
    from its header when larger than :data:`MAX_TEXTURE_PIXELS`, and after decoding when it
    holds NaN or infinite values (an ``environment`` map: or negative ones). The SceneError
    says only why: the caller names the scene file, its line or field and the image."""
    from ...film.io import read_image

    path = Path(path)
    try:
        image = read_image(path, MAX_TEXTURE_PIXELS, "a texture or environment map")
    except Exception as exc:        # our readers' errors, and whatever a decoder raises
        raise SceneError(image_failure(exc, path)) from None
    if not np.all(np.isfinite(image)):
        raise SceneError("it holds NaN or infinite values")
    if environment and image.size and image.min() < 0:
        raise SceneError("it holds negative values (an environment map is radiance)")
    return image
