"""Where the files a scene refers to may be: one policy for every loader and every kind of
reference (includes, meshes, material libraries, textures, buffers, environment maps).

Scene files come from strangers. A reference is a path relative to the file that names it
(Mitsuba's ``<path>`` folders are tried too); followed through its symbolic links, it must
lead inside the scene file's folder or inside a folder the user allows
(``glrender render --search-path DIR``, ``glrender.load(path, search_path=[DIR])``), to a
regular file. Anything else - ``../../etc/passwd``, an absolute path, a link to a file
outside, a link to ``/dev/zero``, a folder - is refused in one line that names the
referencing file, its line or field, and the path, before anything is read and whether or
not the file exists. Every file is read through :func:`read_bytes` or after
:meth:`SceneFiles.resolve`, so nothing outside those folders reaches a loader.
"""
from __future__ import annotations

import hashlib
import os
import stat
import threading
from contextlib import contextmanager
from pathlib import Path

from ...errors import SceneError
from .diagnostics import excerpt, note_digest, note_file, printable, recording_digests


class MissingFile(SceneError):
    """A reference to a file that is not there (inside the allowed folders); a loader may
    go on without it (an OBJ's material library)."""


_search = threading.local()


@contextmanager
def search_path(folders):
    """Folders besides the scene's own that references may lead into, for the scenes
    loaded on this thread inside the block: the command line's ``--search-path``, the
    default of :func:`glrender.load`'s ``search_path``."""
    outer = current_search_path()
    _search.folders = tuple(Path(f) for f in folders)
    try:
        yield
    finally:
        _search.folders = outer


def current_search_path() -> tuple[Path, ...]:
    return getattr(_search, "folders", ())


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a pipe"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a file"


def _where(referrer, line: int | None, field: str | None) -> str:
    if line is not None:
        return f"{referrer}:{line}"
    return f"{referrer}: {field}" if field else f"{referrer}"


def _check_name(name, where: str, what: str) -> None:
    """A path the file system can take: text, not blank, no NUL, encodable."""
    try:
        ok = isinstance(name, str) and bool(name.strip()) and "\0" not in name and \
            bool(os.fsencode(name))
    except UnicodeError:
        ok = False
    if not ok:
        raise SceneError(f"{where}: expected a {what} name, got {excerpt(name)}")


class SceneFiles:
    """The files one scene refers to: ``root`` is the scene file's folder, ``search`` the
    folders the user allows besides it (default: those of :func:`search_path`)."""

    def __init__(self, root, search=None):
        self.root = Path(os.path.realpath(root))
        extra = current_search_path() if search is None else search
        self.folders = tuple(dict.fromkeys([self.root, *(Path(os.path.realpath(f)) for f in extra)]))

    def allows(self, path: Path) -> bool:
        """Whether the real (link-free) ``path`` lies in an allowed folder."""
        return any(path.is_relative_to(folder) for folder in self.folders)

    def _outside(self, where: str, what: str, name: str, real: Path) -> SceneError:
        also = " or a --search-path folder" if len(self.folders) > 1 else ""
        return SceneError(f"{where}: {what} {excerpt(name)} resolves to {printable(str(real))}, "
                          f"outside the scene's folder {self.root}{also}: refused (allow its "
                          f"folder with --search-path)")

    def resolve(self, name, referrer, line: int | None = None, what: str = "file",
                search: tuple = (), field: str | None = None) -> Path:
        """The real path of the regular file ``name`` refers to, relative to the folder of
        ``referrer``, then to each of the folders ``search`` (Mitsuba's); errors name
        ``referrer`` and its ``line`` or ``field``. Raises :class:`MissingFile` when no
        candidate exists, SceneError when one leads outside or is not a regular file."""
        where = _where(referrer, line, field)
        _check_name(name, where, what)
        base = Path(referrer).parent
        outside = None
        for folder in (base, *search):
            candidate = Path(folder) / name
            real = Path(os.path.realpath(candidate))
            inside = self.allows(real)
            try:
                mode = os.stat(real).st_mode
            except (FileNotFoundError, NotADirectoryError):
                mode = None
            except OSError as exc:
                if inside:
                    raise SceneError(f"{where}: cannot read {what} {excerpt(name)} "
                                     f"({exc.strerror or type(exc).__name__})") from None
                mode = None
            if mode is not None and not stat.S_ISREG(mode):
                raise SceneError(f"{where}: {what} {excerpt(name)} is not a regular file "
                                 f"({_kind(mode)})")
            if not inside:
                # refused: the path the file names, or a file found outside through a
                # search folder (Mitsuba's <path> may lead anywhere; it reads nothing)
                if outside is None and (folder is base or mode is not None):
                    outside = real
            elif mode is not None:
                note_file(candidate)
                return real
        if outside is not None:
            raise self._outside(where, what, name, outside)
        looked = ", ".join(printable(str(Path(os.path.realpath(f)))) for f in (base, *search))
        raise MissingFile(f"{where}: {what} {excerpt(name)} not found (looked in {looked})")


def check_regular(path) -> os.stat_result:
    """``path``'s status, after SceneError when it is not there or not a regular file
    (a folder, ``/dev/zero``, a pipe)."""
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise SceneError(f"{printable(str(path))}: no such file") from None
    except OSError as exc:
        raise SceneError(f"{printable(str(path))}: cannot read ({exc.strerror or exc})") from None
    if not stat.S_ISREG(info.st_mode):
        raise SceneError(f"{printable(str(path))}: not a regular file ({_kind(info.st_mode)})")
    return info


def read_bytes(path, limit: int | None = None) -> bytes:
    """A whole regular file, with errors that name it; files above ``limit`` bytes are
    refused before they are read. While a scene loads (diagnostics.record_digests) its
    SHA-256 is noted for the scene's file hashes."""
    data = _read(path, limit)
    if recording_digests():
        note_digest(path, hashlib.sha256(data).hexdigest())
    return data


def read_bytes_digest(path, limit: int | None = None) -> tuple[bytes, str]:
    """:func:`read_bytes` and the SHA-256 of what it read (hex): the key a cache of what
    is read from the file is kept under, noted for the scene's file hashes too."""
    data = _read(path, limit)
    digest = hashlib.sha256(data).hexdigest()
    note_digest(path, digest)
    return data, digest


def _read(path, limit: int | None) -> bytes:
    info = check_regular(path)
    if limit is not None and info.st_size > limit:
        raise SceneError(f"{printable(str(path))}: {info.st_size} bytes is more than this loader "
                         f"reads ({limit})")
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as exc:
        raise SceneError(f"{printable(str(path))}: cannot read ({exc.strerror or exc})") from None
