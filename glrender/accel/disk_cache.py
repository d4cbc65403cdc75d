"""An on-disk cache of arrays computed from arrays: built BVHs, recomputed vertex normals and
parsed OBJ files.

A render of a large mesh spends seconds on work whose result depends only on its input
arrays and the code that computes it (the BVH build, :mod:`.bvh_cache`; the vertex normals,
``scene/loaders/meshes.py``; the OBJ bulk parser, ``scene/loaders/obj.py``, whose input is
the file's bytes). Each result is kept as one file named by a key: the SHA-256
of the input arrays' bytes (with their dtypes and shapes), the parameters of the
computation, the version constant its code carries (bumped when the output changes) and
numpy's version (a reduction may sum in another order). Hashing is hardware SHA where the
CPU has it: 1.8 GB/s measured here, twice blake2b's 0.9 GB/s.

Location: ``$GLRENDER_CACHE_DIR/bvh``, else ``$XDG_CACHE_HOME/glrender/bvh``, else
``~/.cache/glrender/bvh``. ``GLRENDER_CACHE=off`` turns the cache off (nothing is read or
written). ``GLRENDER_CACHE_SIZE`` caps the folder (bytes, or with a K/M/G/T suffix in
powers of 1024; default 2G): after each write the least recently used entries go until the
total fits, and a hit counts as a use (its modification time is set to now).

An entry is trusted only whole: the file holds a magic, a CRC-32 of everything after it, and
a JSON header naming the format, the kind, the version, the full key and each array's dtype,
shape and place. A short file, a flipped byte, another version or another key is a miss, and
the caller's recomputed result replaces the entry. Writes go to a temporary file in the same
folder, then ``os.replace``: a reader sees the old entry or the new one, never half of one.
A cache that cannot be read or written never fails a render: an unwritable folder or a full
disk costs one warning line per process, and the result is computed as if uncached.
"""
from __future__ import annotations

import hashlib
import json
import mmap
import os
import re
import struct
import tempfile
import time
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FORMAT = 1
MAGIC = b"GLRCACHE"
PREFIX = struct.Struct("<8sQQ")         # magic, CRC-32 of the rest, header bytes
ALIGN = 64                              # arrays start on 64-byte boundaries
SUFFIX = ".bin"
DEFAULT_SIZE = 2 << 30
STALE_TEMP_SECONDS = 3600               # a temporary file this old was left by a crash
_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_warned: set[str] = set()


@dataclass
class Entry:
    """A cached result: its arrays (views of the file, mapped copy-on-write) and its JSON metadata."""

    arrays: dict[str, np.ndarray]
    meta: dict


def enabled() -> bool:
    """False when ``GLRENDER_CACHE`` is ``off`` (or ``0``, ``false``, ``no``)."""
    return os.environ.get("GLRENDER_CACHE", "").strip().lower() not in ("off", "0", "false", "no")


def cache_dir() -> Path:
    """The folder of the cache (see the module doc)."""
    base = os.environ.get("GLRENDER_CACHE_DIR")
    if base:
        return Path(base) / "bvh"
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(xdg) / "glrender" / "bvh"


def size_limit() -> int:
    """Bytes the folder may hold: ``GLRENDER_CACHE_SIZE`` (an unreadable value: one warning,
    and the default 2 GiB)."""
    text = os.environ.get("GLRENDER_CACHE_SIZE", "").strip()
    if not text:
        return DEFAULT_SIZE
    match = re.fullmatch(r"(\d+(?:\.\d*)?)\s*([KMGT]?)(?:i?B)?", text, re.IGNORECASE)
    if match is None:
        _warn_once("size", f"GLRENDER_CACHE_SIZE={text!r} is not a size such as 2G, 500M or "
                           f"1048576; the BVH cache keeps its default of 2G")
        return DEFAULT_SIZE
    return int(float(match.group(1)) * _UNITS[match.group(2).upper()])


def key(kind: str, version: int, params: dict, arrays) -> str:
    """The hex key of computing ``kind`` (at code ``version``, with JSON-able ``params``)
    from ``arrays``: every array's dtype, shape and bytes in order."""
    h = hashlib.sha256()
    h.update(json.dumps([FORMAT, kind, version, np.__version__, params], sort_keys=True,
                        default=repr).encode())
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"|{a.dtype.str}{a.shape}|".encode())
        h.update(a.reshape(-1).view(np.uint8) if a.size else b"")
    return h.hexdigest()


def _path(kind: str, key_hex: str) -> Path:
    return cache_dir() / f"{kind}-{key_hex}{SUFFIX}"


def load(kind: str, key_hex: str, version: int) -> Entry | None:
    """The entry of ``key_hex``, or None: none, unreadable, corrupt, or of another kind,
    version or key (the caller computes the result and :func:`store` s it over the file)."""
    if not enabled():
        return None
    path = _path(kind, key_hex)
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size < PREFIX.size:
                return None
            # mapped copy-on-write, not read: the arrays are the page cache's pages until
            # written to (a 70 MB entry checked in 30 ms instead of 50-160 ms for a read into
            # fresh memory); writers replace files, never change one, so it stays whole
            data = np.frombuffer(mmap.mmap(f.fileno(), size, flags=mmap.MAP_PRIVATE,
                                           prot=mmap.PROT_READ | mmap.PROT_WRITE), np.uint8)
    except (OSError, ValueError):
        return None
    entry = _parse(data, kind, key_hex, version)
    if entry is not None:
        try:
            os.utime(path)                        # a use: the least recently used go first
        except OSError:
            pass
    return entry


def _parse(data: np.ndarray, kind: str, key_hex: str, version: int) -> Entry | None:
    magic, crc, header_bytes = PREFIX.unpack_from(data, 0)
    rest = memoryview(data)[PREFIX.size:]
    if magic != MAGIC or PREFIX.size + header_bytes > len(data) or zlib.crc32(rest) != crc:
        return None
    try:
        header = json.loads(bytes(rest[:header_bytes]))
        if (header["format"], header["kind"], header["version"], header["key"]) != \
                (FORMAT, kind, version, key_hex):
            return None
        payload = _aligned(PREFIX.size + header_bytes)
        arrays = {}
        for name, dtype, shape, offset in header["arrays"]:
            dtype, shape = np.dtype(dtype), tuple(shape)
            begin = payload + offset
            end = begin + dtype.itemsize * int(np.prod(shape, dtype=np.int64))
            if offset % ALIGN or end > len(data):
                return None
            arrays[name] = data[begin:end].view(dtype).reshape(shape)
        return Entry(arrays, header["meta"])
    except (ValueError, KeyError, TypeError):
        return None


def _plain(value):
    """numpy scalars in metadata as Python numbers."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} in cache metadata")


def _aligned(n: int) -> int:
    return -(-n // ALIGN) * ALIGN


def store(kind: str, key_hex: str, version: int, arrays: dict[str, np.ndarray], meta: dict) -> None:
    """Write an entry (atomically), then evict the least recently used entries over the
    size limit. Failures (a read-only folder, a full disk) cost one warning per process."""
    if not enabled():
        return
    arrays = {name: np.ascontiguousarray(a) for name, a in arrays.items()}
    table, offset = [], 0
    for name, a in arrays.items():
        table.append([name, a.dtype.str, list(a.shape), offset])
        offset = _aligned(offset + a.nbytes)
    header = json.dumps({"format": FORMAT, "kind": kind, "version": version, "key": key_hex,
                         "arrays": table, "meta": meta}, default=_plain).encode()
    payload = _aligned(PREFIX.size + len(header))
    total = payload + offset
    limit = size_limit()
    if total > limit:
        return                                    # it would evict everything, itself too
    folder = cache_dir()
    tmp = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{kind}-", suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            crc = zlib.crc32(header)
            pad = bytes(payload - PREFIX.size - len(header))
            crc = zlib.crc32(pad, crc)
            f.write(bytes(PREFIX.size))           # the prefix, once the CRC is known
            f.write(header + pad)
            written = 0
            for (name, _, _, at), a in zip(table, arrays.values()):
                gap = bytes(at - written)
                raw = a.reshape(-1).view(np.uint8) if a.size else b""
                crc = zlib.crc32(raw, zlib.crc32(gap, crc))
                f.write(gap)
                f.write(raw)
                written = at + a.nbytes
            f.seek(0)
            f.write(PREFIX.pack(MAGIC, crc, len(header)))
        os.replace(tmp, _path(kind, key_hex))
        tmp = None
        evict(limit)
    except OSError as exc:
        _warn_once("write", f"cannot write the BVH cache in {folder} ({exc.strerror or exc}); "
                            f"large meshes are built again on every run (GLRENDER_CACHE=off "
                            f"stops trying)")
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def evict(limit: int) -> None:
    """Delete the least recently used entries until the folder holds at most ``limit``
    bytes (and temporary files that a crashed writer left)."""
    folder = cache_dir()
    entries, total, now = [], 0, time.time()
    for item in os.scandir(folder):
        try:
            st = item.stat()
        except OSError:
            continue                              # another process evicted it
        if item.name.endswith(SUFFIX):
            entries.append((st.st_mtime_ns, item.name, st.st_size))
            total += st.st_size
        elif item.name.endswith(".tmp") and now - st.st_mtime > STALE_TEMP_SECONDS:
            _unlink(folder / item.name)
    for _, name, size in sorted(entries):
        if total <= limit:
            break
        _unlink(folder / name)
        total -= size


def _unlink(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _warn_once(what: str, message: str) -> None:
    if what not in _warned:
        _warned.add(what)
        warnings.warn(message, RuntimeWarning, stacklevel=3)
