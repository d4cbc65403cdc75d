"""Stanford PLY, ASCII and binary (either byte order), read with numpy.

Vertex properties ``x y z`` (required), ``nx ny nz``, and texture coordinates
``u v`` / ``s t`` / ``texture_u texture_v``; faces as ``vertex_indices`` (or
``vertex_index``) lists, polygons fanned into triangles. Other elements and
properties are skipped. Texture coordinates are used as written (Mitsuba does not flip
PLY's v). Every count a header declares is checked against the bytes that follow
before anything is allocated, so a header claiming 10^12 vertices fails at once.

Binary faces whose lists all have the same length are read in one numpy view; mixed
lengths take a slower walk.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import SceneError
from .diagnostics import excerpt
from .meshes import CACHE_MIN_FILE_BYTES, MeshData, finish_mesh, finish_mesh_cached
from .scene_files import read_bytes_digest

# The version of what _parse returns for given bytes: finished meshes of large PLY files are
# kept in the BVH cache under it (meshes.finish_mesh_cached), so bump it with any change to
# the reader's output.
READER_VERSION = 1

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
MAX_HEADER_BYTES = 1 << 16
MAX_ELEMENTS = 256
_UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))


class _Element:
    def __init__(self, name: str, count: int):
        self.name, self.count = name, count
        self.shown = excerpt(name)          # for messages
        self.names: set[str] = set()
        self.props: list[tuple] = []   # (name, dtype) or (name, count dtype, item dtype)

    @property
    def fixed(self) -> bool:
        return all(len(p) == 2 for p in self.props)


def _header(data: bytes, path: Path):
    end = data.find(b"end_header", 0, MAX_HEADER_BYTES)
    if not data.startswith(b"ply") or end < 0:
        raise SceneError(f"{path}: not a PLY file (no 'ply' magic or no end_header in the first "
                         f"{MAX_HEADER_BYTES} bytes)")
    nl = data.find(b"\n", end)
    body_start = len(data) if nl < 0 else nl + 1
    fmt, elements = None, []
    text = data[:end].decode("ascii", errors="replace")
    for lineno, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts or parts[0] in ("ply", "comment", "obj_info"):
            continue
        where = f"{path}:{lineno}"
        if parts[0] == "format":
            if len(parts) < 2 or parts[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise SceneError(f"{where}: unknown PLY format {excerpt(' '.join(parts[1:]))}")
            fmt = parts[1]
        elif parts[0] == "element":
            try:
                count = int(parts[2])
            except (IndexError, ValueError):
                raise SceneError(f"{where}: malformed element line {excerpt(line.strip())}") from None
            if count < 0:
                raise SceneError(f"{where}: negative element count {count}")
            elements.append(_Element(parts[1], count))
            if len(elements) > MAX_ELEMENTS:
                raise SceneError(f"{where}: more than {MAX_ELEMENTS} elements")
        elif parts[0] == "property":
            if not elements:
                raise SceneError(f"{where}: property before any element")
            try:
                if parts[1] == "list":
                    elements[-1].props.append((parts[4], _TYPES[parts[2]], _TYPES[parts[3]]))
                else:
                    elements[-1].props.append((parts[2], _TYPES[parts[1]]))
            except (IndexError, KeyError):
                raise SceneError(f"{where}: malformed property line {excerpt(line.strip())}") from None
            name = elements[-1].props[-1][0]
            if name in elements[-1].names:
                raise SceneError(f"{where}: property {excerpt(name)} is declared twice in element "
                                 f"{elements[-1].shown}")
            elements[-1].names.add(name)
        else:
            raise SceneError(f"{where}: unexpected header line {excerpt(line.strip())}")
    if fmt is None:
        raise SceneError(f"{path}: the header has no format line")
    return fmt, elements, body_start


def read_ply(path) -> MeshData:
    """A PLY file's mesh, finished (meshes.finish_mesh); a file of
    ``meshes.CACHE_MIN_FILE_BYTES`` or more is kept in the cache under its bytes."""
    path = Path(path)
    data, digest = read_bytes_digest(path)
    if len(data) < CACHE_MIN_FILE_BYTES:
        return finish_mesh(_parse(data, path), path)
    return finish_mesh_cached(lambda: _parse(data, path), path,
                              {"reader": "ply", "version": READER_VERSION, "sha256": digest})


def _parse(data: bytes, path: Path) -> MeshData:
    """The mesh in a PLY file's bytes, as read (not finished)."""
    fmt, elements, start = _header(data, path)
    names = [e.name for e in elements]
    if "vertex" not in names or "face" not in names:
        raise SceneError(f"{path}: expected 'vertex' and 'face' elements, found "
                         f"{excerpt(', '.join(names), quote=False) or 'none'}")
    if fmt == "ascii":
        values = _read_ascii(data[start:], elements, path)
    else:
        values = _read_binary(data, start, elements, path, "<" if fmt.endswith("little_endian") else ">")
    vert = values["vertex"]
    if vert is None:
        raise SceneError(f"{path}: vertices with list properties are not supported")
    for axis in "xyz":
        if axis not in vert:
            raise SceneError(f"{path}: vertices have no '{axis}' property")
    vertices = np.stack([vert["x"], vert["y"], vert["z"]], axis=1).astype(np.float64)
    normals = uvs = None
    if all(k in vert for k in ("nx", "ny", "nz")):
        normals = np.stack([vert["nx"], vert["ny"], vert["nz"]], axis=1).astype(np.float64)
    for u, v in _UV_NAMES:
        if u in vert and v in vert:
            uvs = np.stack([vert[u], vert[v]], axis=1).astype(np.float64)
            break
    faces = values["face"]
    if faces is None:
        raise SceneError(f"{path}: faces have no 'vertex_indices' list")
    return MeshData(vertices, faces, normals, uvs)


def _fan(lists: list[np.ndarray]) -> np.ndarray:
    """Triangles of polygons given as index arrays (fans around each first vertex)."""
    tris = [np.stack([np.full(len(p) - 2, p[0]), p[1:-1], p[2:]], axis=1) for p in lists if len(p) >= 3]
    return np.concatenate(tris).astype(np.int64) if tris else np.zeros((0, 3), np.int64)


def _fan_uniform(arr: np.ndarray) -> np.ndarray:
    n = arr.shape[1]
    if n < 3:
        return np.zeros((0, 3), np.int64)
    k = np.arange(1, n - 1)
    return np.stack([np.repeat(arr[:, :1], n - 2, axis=1), arr[:, k], arr[:, k + 1]],
                    axis=2).reshape(-1, 3).astype(np.int64)


def _index_prop(element: _Element):
    for p in element.props:
        if len(p) == 3 and p[0] in ("vertex_indices", "vertex_index"):
            return p
    return None


def _read_binary(data: bytes, offset: int, elements, path: Path, order: str) -> dict:
    out = {"vertex": None, "face": None}
    for el in elements:
        if el.fixed and not el.props:
            if el.name == "vertex":
                out["vertex"] = {}          # (no coordinates: an error below)
            continue
        if el.fixed:
            dtype = np.dtype([(name, order + t) for name, t in el.props])
            need = el.count * dtype.itemsize
            if offset + need > len(data):
                raise SceneError(f"{path}: element {el.shown} declares {el.count} records of "
                                 f"{dtype.itemsize} bytes; the file ends {offset + need - len(data)} "
                                 f"bytes short (truncated or corrupt)")
            arr = np.frombuffer(data, dtype, el.count, offset)
            offset += need
            if el.name == "vertex":
                out["vertex"] = {name: arr[name] for name in arr.dtype.names}
            continue
        # an element with lists: every record holds at least its fixed part and counts
        minimum = sum(np.dtype(p[1]).itemsize for p in el.props)
        if offset + el.count * minimum > len(data):
            raise SceneError(f"{path}: element {el.shown} declares {el.count} records of at least "
                             f"{minimum} bytes; the file has {len(data) - offset} left (truncated or corrupt)")
        faces, offset = _binary_lists(data, offset, el, path, order)
        if el.name == "face":
            out["face"] = faces
    return out


def _binary_lists(data: bytes, offset: int, el: _Element, path: Path, order: str):
    """(triangles or None, offset after the element) of a binary element with lists."""
    index_prop = _index_prop(el)
    if el.count == 0:
        return np.zeros((0, 3), np.int64), offset
    if len(el.props) == 1 and index_prop is not None:
        # fast path: every list as long as the first
        count_t, item_t = np.dtype(order + index_prop[1]), np.dtype(order + index_prop[2])
        if offset + count_t.itemsize > len(data):
            raise SceneError(f"{path}: the face data is truncated")
        n = int(np.frombuffer(data, count_t, 1, offset)[0])
        # the record size from the count the file declares, checked before numpy sees it
        size = count_t.itemsize + n * item_t.itemsize
        fits = n > 0 and offset + el.count * size <= len(data)
        rec = np.dtype([("n", count_t), ("i", item_t, (n,))]) if fits else None
        if rec is not None:
            arr = np.frombuffer(data, rec, el.count, offset)
            if np.all(arr["n"] == n):
                return _fan_uniform(arr["i"].reshape(el.count, n)), offset + el.count * rec.itemsize
    # general walk, record by record
    lists = []
    for _ in range(el.count):
        for p in el.props:
            if len(p) == 2:
                offset += np.dtype(p[1]).itemsize
                continue
            count_t, item_t = np.dtype(order + p[1]), np.dtype(order + p[2])
            if offset + count_t.itemsize > len(data):
                raise SceneError(f"{path}: element {el.shown} is truncated")
            n = int(np.frombuffer(data, count_t, 1, offset)[0])
            offset += count_t.itemsize
            if n < 0 or offset + n * item_t.itemsize > len(data):
                raise SceneError(f"{path}: element {el.shown} is truncated (a list of {n} items "
                                 f"runs past the end of the file)")
            items = np.frombuffer(data, item_t, n, offset)
            offset += n * item_t.itemsize
            if p is index_prop:
                lists.append(items.astype(np.int64))
    return (_fan(lists) if index_prop is not None else None), offset


def _read_ascii(body: bytes, elements, path: Path) -> dict:
    tokens = body.split()
    out = {"vertex": None, "face": None}
    pos = 0
    for el in elements:
        if el.count * max(len(el.props), 1) > len(tokens) - pos:
            raise SceneError(f"{path}: element {el.shown} declares {el.count} records; the file "
                             f"has {len(tokens) - pos} values left (truncated or corrupt)")
        if el.fixed:
            n = len(el.props)
            block = tokens[pos:pos + el.count * n]
            pos += el.count * n
            try:
                arr = np.array(block, np.float64).reshape(el.count, n)
            except ValueError:
                raise SceneError(f"{path}: element {el.shown} holds a value that is not a number") from None
            if el.name == "vertex":
                out["vertex"] = {name: arr[:, k] for k, (name, _) in enumerate(el.props)}
            continue
        index_prop = _index_prop(el)
        lists = []
        try:
            if len(el.props) == 1 and index_prop is not None and el.count:
                n = int(tokens[pos])
                end = pos + el.count * (n + 1)
                if n >= 0 and end <= len(tokens):
                    arr = np.array(tokens[pos:end], np.int64).reshape(el.count, n + 1)
                    if np.all(arr[:, 0] == n):
                        out["face"] = _fan_uniform(arr[:, 1:])
                        pos = end
                        continue
            for _ in range(el.count):
                for p in el.props:
                    if len(p) == 2:
                        pos += 1
                        continue
                    n = int(tokens[pos])
                    if n < 0 or pos + 1 + n > len(tokens):
                        raise SceneError(f"{path}: element {el.shown} is truncated")
                    items = np.array(tokens[pos + 1:pos + 1 + n], np.int64)
                    pos += 1 + n
                    if p is index_prop:
                        lists.append(items)
        except (ValueError, IndexError, OverflowError):
            raise SceneError(f"{path}: element {el.shown} is malformed or truncated") from None
        if el.name == "face":
            out["face"] = _fan(lists) if index_prop is not None else None
    return out
