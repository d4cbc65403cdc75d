"""Wavefront OBJ and MTL: an own parser (trimesh drops tab-separated vertices and resolves
negative indices against the wrong count), as scene or as one mesh.

OBJ: ``v`` (extra components ignored), ``vt``, ``vn``, ``f`` with ``v``, ``v/vt``,
``v//vn``, ``v/vt/vn`` corners, positive or negative (relative to the vertices read so
far) indices, polygons fanned into triangles (as Mitsuba does), ``usemtl``, ``mtllib``,
``o`` and ``g``. Corners are made unique by their (v, vt, vn) triple, so uv seams and
hard edges split vertices. Texture coordinates are flipped to Mitsuba's convention
(v' = 1 - v: OBJ counts v upward from the bottom of the image). Faces without normals
get angle-weighted vertex normals.

MTL to materials (docs/scene-format.md has the table): ``Kd`` diffuse reflectance
(``map_Kd`` a bitmap texture, ``-s``/``-o``/``-clamp`` honoured), ``Ks`` with ``Ns``
a rough specular layer (alpha = sqrt(2 / (Ns + 2)), Walter et al. 2007's
Phong-Beckmann match): roughplastic over ``Kd``, or a roughconductor when ``Kd`` is
black; ``illum`` 4, 6, 7, 9 or ``d`` < 1 a dielectric of IOR ``Ni``; ``Ke`` an area
light on the faces that use the material. The PBR extension's ``Pr`` (roughness) and ``Pm``
(metallic), where either is given, choose the material by glTF's metallic-roughness rule
(:mod:`.pbr`) with ``Kd`` (or ``map_Kd``) as the base colour; a missing ``Pr`` is the
roughness whose GGX alpha matches ``Ns``, a missing ``Pm`` 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...accel import disk_cache
from ...errors import SceneError
from .. import model as m
from .diagnostics import Notes, cause, excerpt, image_failure, read_image_checked, warn
from .meshes import MeshData, finish_mesh, finish_mesh_cached
from .pbr import metallic_roughness_material
from .scene_files import MissingFile, SceneFiles, read_bytes, read_bytes_digest

MAX_FILE_BYTES = 1 << 31
FAST_PATH_BYTES = 1 << 16     # files above this try the bulk parser first
# The version of what _read_obj_fast returns for given bytes: files of CACHE_MIN_BYTES or more
# that it parses are kept in the BVH cache (accel/disk_cache.py) under it, keyed by their
# bytes, so bump it with any change to that parser's output.
BULK_PARSER_VERSION = 1
CACHE_MIN_BYTES = 1 << 20


@dataclass
class MtlMaterial:
    name: str
    line: int
    Kd: tuple = (0.8, 0.8, 0.8)
    Ks: tuple = (0.0, 0.0, 0.0)
    Ke: tuple = (0.0, 0.0, 0.0)
    Tf: tuple | None = None
    Ns: float = 0.0
    Ni: float = 1.5
    d: float = 1.0
    illum: int = 2
    Pr: float | None = None                 # PBR extension: roughness, metallic in [0, 1]
    Pm: float | None = None
    map_Kd: m.Texture | None = None
    map_d: m.Texture | None = None          # opacity (alpha cutout)
    norm: m.Texture | None = None           # tangent-space normal map


@dataclass
class ObjFile:
    """The parsed file: unique corners (position, texcoord, normal indices; -1 absent),
    triangles as corner indices, and per triangle its material and object numbers."""

    path: Path
    positions: np.ndarray
    texcoords: np.ndarray
    normals: np.ndarray
    corners: np.ndarray                 # (C, 3) int64
    triangles: np.ndarray               # (T, 3) into corners
    tri_material: np.ndarray            # (T,) into material_names
    tri_object: np.ndarray              # (T,) into object_names
    material_names: list = field(default_factory=list)
    object_names: list = field(default_factory=list)
    materials: dict = field(default_factory=dict)
    # what names the file's bytes and their parser (meshes.finish_mesh_cached), when its
    # finished meshes are cached: large files the bulk parser read
    origin: dict | None = None

    def mesh(self, select: np.ndarray | None = None, part: int | None = None) -> MeshData:
        """The triangles ``select`` (a boolean mask; all by default) as one mesh, finished
        (meshes.finish_mesh). ``part``: a number that names ``select`` among the file's
        selections, under which the finished mesh is cached (no number with a mask: not
        cached)."""
        if self.origin is None or (select is not None and part is None):
            return finish_mesh(self._assemble(select), self.path)
        return finish_mesh_cached(lambda: self._assemble(select), self.path, {**self.origin, "part": part})

    def _assemble(self, select: np.ndarray | None) -> MeshData:
        """The triangles ``select`` as one mesh, unfinished."""
        tris = self.triangles if select is None else self.triangles[select]
        if select is None and np.bincount(tris.reshape(-1), minlength=len(self.corners)).all():
            # every corner used (the usual whole file): no sort needed
            c, inverse = self.corners, tris.reshape(-1)
        else:
            used, inverse = np.unique(tris.reshape(-1), return_inverse=True)
            c = self.corners[used]
        vertices = self.positions[c[:, 0]]
        uvs = normals = None
        if (c[:, 1] >= 0).any() and len(self.texcoords):
            uvs = np.where((c[:, 1] >= 0)[:, None], self.texcoords[np.maximum(c[:, 1], 0)], 0.0)
        if (c[:, 2] >= 0).any() and len(self.normals):
            # corners without a normal get 0: the renderer falls back to the face normal there
            normals = np.where((c[:, 2] >= 0)[:, None], self.normals[np.maximum(c[:, 2], 0)], 0.0)
        return MeshData(vertices, inverse.reshape(-1, 3), normals, uvs)

    def merged(self) -> MeshData:
        return self.mesh()


def _floats(parts, lo: int, hi: int, path, lineno: int, what: str) -> list[float]:
    if len(parts) - 1 < lo:
        raise SceneError(f"{path}:{lineno}: {what} needs at least {lo} numbers, got {len(parts) - 1}")
    try:
        return [float(x) for x in parts[1:1 + hi]]
    except ValueError:
        raise SceneError(f"{path}:{lineno}: {what}: expected numbers, got "
                         f"{excerpt(' '.join(parts[1:]))}") from None


def _read_text(path: Path) -> str:
    return read_bytes(path, MAX_FILE_BYTES).decode("utf-8", errors="replace")


def _statements(text: str):
    """(line number, stripped line, its tokens) of every line that is not blank or a comment."""
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if line and line[0] != "#":
            yield lineno, line, line.split()


def _unique_corners(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct (v, vt, vn) rows and the index of each input row among them, through one
    int64 key per row (sorting rows of a (C, 3) array directly is 20x slower)."""
    c = corners + 1                                   # -1 (absent) becomes 0
    span = c.max(axis=0) + 1
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0 ** 62:
        key = (c[:, 0] * span[1] + c[:, 1]) * span[2] + c[:, 2]
        _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
        return corners[first], inverse.reshape(-1)
    unique, inverse = np.unique(corners, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)


def _corners(flat: np.ndarray, nv: int, nvt: int, nvn: int) -> tuple[np.ndarray, np.ndarray]:
    """Distinct corners of the face corners ``flat`` (C, 3): when every corner's uv and
    normal index is its position's (or absent in every corner), as exporters usually
    write, the positions are the corners and no sort is needed; else _unique_corners."""
    same = []
    for axis, count in ((1, nvt), (2, nvn)):
        column = flat[:, axis]
        if (column < 0).all():
            same.append(False)
        elif count >= nv and np.array_equal(column, flat[:, 0]):
            same.append(True)
        else:
            return _unique_corners(flat)
    ids = np.arange(nv, dtype=np.int64)
    none = np.full(nv, -1, np.int64)
    corners = np.stack([ids, ids if same[0] else none, ids if same[1] else none], axis=1)
    return corners, flat[:, 0].copy()


_MARKERS = ("usemtl", "mtllib", "o", "g", "s", "vp")


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[first, end) of each run of consecutive True entries."""
    edges = np.flatnonzero(np.diff(np.concatenate([[False], mask, [False]]).view(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


def _read_obj_fast(data: bytes, path: Path):
    """Large files, the common shape, parsed by numpy over the whole file: ``v`` lines with
    the same count (>= 3) of numbers, ``vt`` lines with the same count, ``vn`` with 3,
    faces of three or more corners (triangles, quads and larger polygons, mixed in any
    order, fanned as the general parser fans them) all in the same ``v``, ``v/vt``,
    ``v//vn`` or ``v/vt/vn`` form (relative indices resolved as the general parser does), comments,
    blank lines and ``usemtl``/``mtllib``/``o``/``g``/``s``. The lines are classified by
    their first bytes, their tokens counted per line and per face corner, and every kind
    parsed in bulk from the file's own bytes (the keywords blanked). Anything else returns
    None: the general parser then reads the file and reports errors with line numbers."""
    buf = np.frombuffer(data, np.uint8)
    n = len(buf)
    if n == 0:
        return None
    returns = data.count(b"\r")
    if np.count_nonzero(buf < 32) != data.count(b"\n") + data.count(b"\t") + returns or \
            (returns and returns != data.count(b"\r\n")):
        return None     # other line breaks or whitespace of str.splitlines / str.split
    if (buf >= 0x80).any() and any(s in data for s in (b"\xc2\x85", b"\xe2\x80\xa8", b"\xe2\x80\xa9")):
        return None
    starts = np.concatenate([[0], np.flatnonzero(buf == 10) + 1])
    if starts[-1] == n:
        starts = starts[:-1]
    padded = np.concatenate([buf, np.zeros(2, np.uint8)])
    b0, b1, b2 = padded[starts], padded[starts + 1], padded[starts + 2]
    sep1, sep2 = b1 <= 32, b2 <= 32                  # whitespace (or the end of the file)
    is_v = (b0 == ord("v")) & sep1
    is_vt = (b0 == ord("v")) & (b1 == ord("t")) & sep2
    is_vn = (b0 == ord("v")) & (b1 == ord("n")) & sep2
    is_f = (b0 == ord("f")) & sep1
    # tokens: [first, last] bytes of every run of non-whitespace (the only bytes <= 32 left
    # are tab, CR, LF and space)
    ws = buf <= 32
    token_first = np.flatnonzero(ws[:-1] > ws[1:]) + 1
    token_last = np.flatnonzero(ws[:-1] < ws[1:])
    if not ws[0]:
        token_first = np.concatenate([[0], token_first])
    if not ws[-1]:
        token_last = np.append(token_last, n - 1)
    del ws
    line_token = np.searchsorted(token_first, np.append(starts, n))   # first token of each line
    per_line = np.diff(line_token)
    rest = ~(is_v | is_vt | is_vn | is_f) & (b0 != ord("#")) & (per_line > 0)
    marks = []                                         # (line index, keyword, name)
    for i in np.flatnonzero(rest).tolist():
        end = starts[i + 1] if i + 1 < len(starts) else n
        line = data[starts[i]:end].decode("utf-8", errors="replace").strip()
        if not line:
            continue        # blank by str.strip (non-ASCII spaces)
        key = line.split()[0]
        if key not in _MARKERS:
            return None
        marks.append((i, key, line[len(key):].strip()))
    if not is_f.any() or not is_v.any():
        return None
    if per_line[is_vn].size and (per_line[is_vn] != 4).any():
        return None
    widths = []
    for mask in (is_v, is_vt):
        counts = per_line[mask]
        widths.append(int(counts[0]) - 1 if counts.size else 0)
        if counts.size and (counts != counts[0]).any():
            return None
    v_width, vt_width = widths
    f_lines = np.flatnonzero(is_f)
    sizes = per_line[f_lines] - 1                     # corners of each face
    if v_width < 3 or (is_vt.any() and vt_width < 1) or sizes.min() < 3:
        return None
    nf, total = len(f_lines), int(sizes.sum())
    face_start = np.cumsum(sizes) - sizes             # each face's first corner
    # face corners (the tokens after "f"): each the same count of '/' and of '//' as the first
    corner_tokens = np.repeat(line_token[f_lines] + 1 - face_start, sizes) + np.arange(total)
    first, last = token_first[corner_tokens], token_last[corner_tokens] + 1
    slash_at = np.flatnonzero(buf == ord("/"))
    slashes = np.searchsorted(slash_at, last) - np.searchsorted(slash_at, first)
    doubles = np.zeros_like(slashes)
    adjacent = np.diff(slash_at) == 1                 # "//" (a bytes search is 7x slower)
    if adjacent.any():
        double_at = slash_at[:-1][adjacent]
        doubles = np.searchsorted(double_at, last) - np.searchsorted(double_at, first)
    del token_first, token_last, first, last
    n_slash, n_double = int(slashes[0]), int(doubles[0])
    if (slashes != n_slash).any() or (doubles != n_double).any() or n_slash > 2 or \
            n_double > (1 if n_slash == 2 else 0):
        return None
    fields = 1 + n_slash - n_double
    blank = buf.copy()
    blank[starts[is_v | is_f]] = 32
    two = starts[is_vt | is_vn]
    blank[two], blank[two + 1] = 32, 32
    blank[slash_at] = 32                  # only face lines are parsed as indices
    text = blank.tobytes()
    del blank

    def parse(mask, dtype, width, count):
        """The numbers of the ``mask`` lines, ``count`` rows of ``width``."""
        line_end = np.append(starts, n)
        parts = []
        for a, b in _runs(mask):
            chunk = np.fromstring(text[line_end[a]:line_end[b]], dtype=dtype, sep=" ")
            parts.append(chunk)
        out = np.concatenate(parts) if parts else np.zeros(0, dtype)
        if out.size != width * count:
            raise ValueError("not a number")
        return out.reshape(-1, width)

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")   # numpy warns (DeprecationWarning) on a bad token
        try:
            pos = parse(is_v, np.float64, v_width, np.count_nonzero(is_v))[:, :3]
            tex = parse(is_vt, np.float64, vt_width, np.count_nonzero(is_vt)) if is_vt.any() \
                else np.zeros((0, 1))
            nrm = parse(is_vn, np.float64, 3, np.count_nonzero(is_vn)) if is_vn.any() \
                else np.zeros((0, 3))
            ids = parse(is_f, np.int64, fields, total)
        except (DeprecationWarning, ValueError):
            return None
    if not (np.isfinite(pos).all() and np.isfinite(tex).all() and np.isfinite(nrm).all()):
        return None         # NaN / infinity (or numpy's looser spellings): the general parser
    if len(tex):
        tex = np.stack([tex[:, 0], 1.0 - tex[:, 1] if vt_width > 1 else np.ones(len(tex))], axis=1)
    else:
        tex = np.zeros((0, 2))
    # indices: 1-based, or relative to the count read before the face's line
    columns = [0, 1, 2][:fields] if n_double == 0 else [0, 2]
    corner = np.full((total, 3), -1, np.int64)
    for j, axis in enumerate(columns):
        i = ids[:, j]
        if (i == 0).any():
            return None
        if (i < 0).any():
            before = np.repeat(np.cumsum((is_v, is_vt, is_vn)[axis])[f_lines], sizes)
            i = np.where(i < 0, i + before, i - 1)
        else:
            i = i - 1
        if i.size and (i.min() < 0 or i.max() >= (len(pos), len(tex), len(nrm))[axis]):
            return None
        corner[:, axis] = i
    # polygons fanned around their first corner, face by face, as the general parser does
    if (sizes == 3).all():
        fan, face_of = corner.reshape(-1, 3, 3), np.arange(nf)
    else:
        per_face = sizes - 2
        face_of = np.repeat(np.arange(nf), per_face)
        first = face_start[face_of]
        j = np.arange(len(face_of)) - np.repeat(np.cumsum(per_face) - per_face, per_face)
        fan = corner[np.stack([first, first + j + 1, first + j + 2], axis=1)]
    # materials, objects and libraries: the face each marker precedes
    faces_before = np.cumsum(is_f) - is_f
    mat_starts, obj_starts, mtl_files = [], [], []
    for i, key, name in marks:
        if key == "mtllib":
            mtl_files.append((name, i + 1))
        elif key not in ("s", "vp"):
            (mat_starts if key == "usemtl" else obj_starts).append((int(faces_before[i]),
                                                                    name or "default"))

    def numbered(marker_starts):
        names, index = ["default"], {"default": 0}
        per_face = np.zeros(nf, np.int64)
        for j, (at, name) in enumerate(marker_starts):
            stop = marker_starts[j + 1][0] if j + 1 < len(marker_starts) else nf
            per_face[at:stop] = index.setdefault(name, len(names))
            if index[name] == len(names):
                names.append(name)
        return names, per_face[face_of]
    mat_names, tri_mat = numbered(mat_starts)
    obj_names, tri_obj = numbered(obj_starts)
    unique, inverse = _corners(fan.reshape(-1, 3), len(pos), len(tex), len(nrm))
    obj = ObjFile(path, np.ascontiguousarray(pos), tex, nrm, unique, inverse.reshape(-1, 3),
                  tri_mat, tri_obj, mat_names, obj_names)
    return obj, mtl_files


_OBJ_ARRAYS = ("positions", "texcoords", "normals", "corners", "triangles", "tri_material", "tri_object")


def _read_obj_cached(data: bytes, digest: str, path: Path):
    """:func:`_read_obj_fast`, read from the cache when a file of these bytes (``digest``:
    their SHA-256) was parsed before (files of ``CACHE_MIN_BYTES`` or more; what the bulk
    parser declines is not cached: the general parser reads it, with its warnings, every
    time)."""
    if len(data) < CACHE_MIN_BYTES or not disk_cache.enabled():
        return _read_obj_fast(data, path)
    key = disk_cache.key("obj", BULK_PARSER_VERSION, {"sha256": digest, "bytes": len(data)}, [])
    entry = disk_cache.load("obj", key, BULK_PARSER_VERSION)
    if entry is not None:
        try:
            meta = entry.meta
            obj = ObjFile(path, *(entry.arrays[name] for name in _OBJ_ARRAYS),
                          list(meta["material_names"]), list(meta["object_names"]))
            return obj, [(str(name), int(line)) for name, line in meta["mtl_files"]]
        except (KeyError, TypeError, ValueError):
            pass                # not what this parser writes: parse again, and replace it
    fast = _read_obj_fast(data, path)
    if fast is not None:
        obj, mtl_files = fast
        disk_cache.store("obj", key, BULK_PARSER_VERSION,
                         {name: getattr(obj, name) for name in _OBJ_ARRAYS},
                         {"material_names": obj.material_names, "object_names": obj.object_names,
                          "mtl_files": mtl_files})
    return fast


def read_obj(path, files: SceneFiles | None = None, read_materials: bool = True) -> ObjFile:
    """Parse an OBJ file (and its MTL files when ``read_materials``)."""
    path = Path(path)
    files = files or SceneFiles(path.parent)
    data, digest = read_bytes_digest(path, MAX_FILE_BYTES)
    fast = _read_obj_cached(data, digest, path) if len(data) > FAST_PATH_BYTES else None
    if fast is not None:
        obj, mtl_files = fast
        if len(data) >= CACHE_MIN_BYTES:
            obj.origin = {"reader": "obj", "version": BULK_PARSER_VERSION, "sha256": digest}
        _read_materials(obj, mtl_files, path, files, read_materials)
        return obj
    text = data.decode("utf-8", errors="replace")
    notes = Notes(path, "ignored OBJ statements")
    pos, tex, nrm = [], [], []
    pos_lines = []
    cv, ct, cn = [], [], []           # corner indices, three per triangle
    tri_mat, tri_obj = [], []
    mat_names, obj_names = ["default"], ["default"]
    mat_index, obj_index = {"default": 0}, {"default": 0}
    cur_mat = cur_obj = 0
    mtl_files = []
    late_positive = False
    for lineno, line, parts in _statements(text):
        key = parts[0]
        if key == "v":
            pos.append(_floats(parts, 3, 3, path, lineno, "v"))
            pos_lines.append(lineno)
        elif key == "vt":
            uv = _floats(parts, 1, 2, path, lineno, "vt")
            tex.append((uv[0], 1.0 - (uv[1] if len(uv) > 1 else 0.0)))
        elif key == "vn":
            nrm.append(_floats(parts, 3, 3, path, lineno, "vn"))
        elif key == "f":
            if len(parts) < 4:
                raise SceneError(f"{path}:{lineno}: a face needs at least 3 vertices, got {len(parts) - 1}")
            corner = []
            for token in parts[1:]:
                fields = token.split("/")
                if len(fields) > 3 or not fields[0]:
                    raise SceneError(f"{path}:{lineno}: malformed face vertex {excerpt(token)}")
                ids = []
                for k, (text_id, count) in enumerate(zip(fields + ["", ""], (len(pos), len(tex), len(nrm)))):
                    if k >= len(fields) or text_id == "":
                        ids.append(-1)
                        continue
                    try:
                        i = int(text_id)
                    except ValueError:
                        raise SceneError(f"{path}:{lineno}: malformed face vertex {excerpt(token)}") from None
                    if i < 0:
                        i += count
                        if i < 0:
                            raise SceneError(f"{path}:{lineno}: relative index "
                                             f"{excerpt(text_id, quote=False)} reaches before "
                                             f"the first {('vertex', 'texture coordinate', 'normal')[k]}")
                    elif i == 0:
                        raise SceneError(f"{path}:{lineno}: index 0 in {excerpt(token)} (OBJ counts from 1)")
                    else:
                        i -= 1
                        if i >= count:
                            if i >= 1 << 62:
                                raise SceneError(f"{path}:{lineno}: index "
                                                 f"{excerpt(text_id, quote=False)} in {excerpt(token)} "
                                                 f"is out of range")
                            late_positive = True   # checked against the final count below
                    ids.append(i)
                corner.append(ids)
            for k in range(1, len(corner) - 1):
                for c in (corner[0], corner[k], corner[k + 1]):
                    cv.append(c[0])
                    ct.append(c[1])
                    cn.append(c[2])
                tri_mat.append(cur_mat)
                tri_obj.append(cur_obj)
        elif key == "usemtl":
            name = line[len(key):].strip() or "default"
            cur_mat = mat_index.setdefault(name, len(mat_names))
            if cur_mat == len(mat_names):
                mat_names.append(name)
        elif key in ("o", "g"):
            name = line[len(key):].strip() or "default"
            cur_obj = obj_index.setdefault(name, len(obj_names))
            if cur_obj == len(obj_names):
                obj_names.append(name)
        elif key == "mtllib":
            mtl_files.append((line[len(key):].strip(), lineno))
        elif key in ("s", "vp"):
            pass
        else:
            notes.add(excerpt(key), lineno)
    notes.emit()
    if not cv:
        raise SceneError(f"{path}: no faces found")
    positions = np.asarray(pos, np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(positions)):
        bad = int(np.flatnonzero(~np.isfinite(positions).all(axis=1))[0])
        raise SceneError(f"{path}:{pos_lines[bad]}: vertex with a NaN or infinite coordinate")
    corners = np.stack([np.asarray(cv, np.int64), np.asarray(ct, np.int64),
                        np.asarray(cn, np.int64)], axis=1)
    if late_positive:
        for k, (name, n) in enumerate((("vertex", len(pos)), ("texture coordinate", len(tex)),
                                       ("normal", len(nrm)))):
            if corners[:, k].max() >= n:
                raise SceneError(f"{path}: a face refers to {name} {int(corners[:, k].max()) + 1}, "
                                 f"but the file has {n}")
    unique, inverse = _unique_corners(corners)
    obj = ObjFile(path, positions, np.asarray(tex, np.float64).reshape(-1, 2),
                  np.asarray(nrm, np.float64).reshape(-1, 3), unique,
                  inverse.reshape(-1, 3), np.asarray(tri_mat, np.int64), np.asarray(tri_obj, np.int64),
                  mat_names, obj_names)
    _read_materials(obj, mtl_files, path, files, read_materials)
    return obj


def _read_materials(obj: ObjFile, mtl_files, path: Path, files: SceneFiles, read_materials: bool):
    """The MTL files of ``mtllib`` statements: a missing one is a warning (its materials
    become grey diffuse), one the path policy refuses an error."""
    if read_materials:
        for name, lineno in mtl_files:
            for mtl_path in _mtl_paths(name, path, lineno, files):
                obj.materials.update(read_mtl(mtl_path, files))


def _mtl_paths(rest: str, referrer: Path, lineno: int, files: SceneFiles) -> list[Path]:
    """``mtllib`` takes several names, but some exporters write one name with spaces."""
    names = [rest]
    if len(rest.split()) > 1:
        try:
            return [files.resolve(rest, referrer, lineno, "material library")]
        except MissingFile:
            names = rest.split()
    paths = []
    for name in names:
        try:
            paths.append(files.resolve(name, referrer, lineno, "material library"))
        except MissingFile as exc:
            warn(f"{exc} (its materials become grey diffuse)")
    return paths


_MAP_OPTION_ARGS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
                    "-imfchan": 1, "-mm": 2, "-texres": 1, "-type": 1}


def _read_data_image(image_path: Path, opacity: bool) -> np.ndarray:
    """A data texture as stored (no sRGB decode): an opacity map's alpha channel where it
    has one, else its grey level; a normal map's RGB."""
    from ...film.io import open_pil
    from .diagnostics import check_image_size

    with open_pil(image_path) as im:
        check_image_size(*im.size)
        if opacity:
            a = np.asarray(im.convert("RGBA") if "A" in im.getbands() else im.convert("L"),
                           np.float64)
            a = a[..., 3] if a.ndim == 3 else a
            return np.repeat((a / 255.0)[..., None], 3, axis=-1).astype(np.float32)
        return (np.asarray(im.convert("RGB"), np.float64) / 255.0).astype(np.float32)


def _texture_map(parts, path: Path, lineno: int, files: SceneFiles,
                 data: str | None = None) -> m.Texture:
    """A ``map_Kd`` (or, with ``data`` "opacity" / "normal", ``map_d`` / ``norm``)
    statement: options (``-s``, ``-o``, ``-clamp``; others ignored) and a file name (which
    may contain spaces). Data maps are read as stored, without the sRGB decode."""
    scale, offset, clamp = [1.0, 1.0], [0.0, 0.0], False
    i = 1
    while i < len(parts) and parts[i].startswith("-") and len(parts) - i > 1:
        opt = parts[i]
        if opt in ("-s", "-o", "-t"):
            values = []
            i += 1
            while i < len(parts) - 1 and len(values) < 3:
                try:
                    values.append(float(parts[i]))
                except ValueError:
                    break
                i += 1
            if opt == "-s" and values:
                scale = [values[0], values[1] if len(values) > 1 else 1.0]
            elif opt == "-o" and values:
                offset = [values[0], values[1] if len(values) > 1 else 0.0]
        elif opt in _MAP_OPTION_ARGS:
            if opt == "-clamp":
                clamp = parts[i + 1].lower() == "on"
            i += 1 + _MAP_OPTION_ARGS[opt]
        else:
            break
    name = " ".join(parts[i:])
    image_path = files.resolve(name, path, lineno, "texture")
    try:
        if data is not None and image_path.suffix.lower() not in (".exr", ".hdr", ".pfm", ".npy"):
            image = _read_data_image(image_path, data == "opacity")     # stored values
        else:
            image = read_image_checked(image_path)
    except Exception as exc:
        raise SceneError(f"{path}:{lineno}: texture {excerpt(name)}: "
                         f"{image_failure(exc, image_path)}") from None
    # options act on OBJ's uv (v up); in the flipped convention v' = 1 - v they become
    # v' -> s_v v' + (1 - s_v - o_v)
    M = np.array([[scale[0], 0.0, offset[0]], [0.0, scale[1], 1.0 - scale[1] - offset[1]],
                  [0.0, 0.0, 1.0]])
    return m.Texture("bitmap", image=image, uv_transform=M, wrap="clamp" if clamp else "repeat",
                     name=name)


def read_mtl(path: Path, files: SceneFiles) -> dict[str, MtlMaterial]:
    text = _read_text(path)
    notes = Notes(path, "ignored MTL statements")
    out: dict[str, MtlMaterial] = {}
    cur = None
    for lineno, line, parts in _statements(text):
        key = parts[0]
        if key == "newmtl":
            name = line[len(key):].strip()
            cur = out[name] = MtlMaterial(name, lineno)
            continue
        if cur is None:
            raise SceneError(f"{path}:{lineno}: {excerpt(key)} before the first newmtl")
        if key in ("Kd", "Ks", "Ke", "Tf"):
            if len(parts) > 1 and parts[1] in ("spectral", "xyz"):
                notes.add(excerpt(f"{key} {parts[1]}"), lineno)
                continue
            values = _floats(parts, 1, 3, path, lineno, key)
            rgb = tuple(values) if len(values) == 3 else (values[0],) * 3
            if not all(math.isfinite(x) for x in rgb) or min(rgb) < 0:
                raise SceneError(f"{path}:{lineno}: {key}: expected non-negative finite numbers")
            setattr(cur, key, rgb)
        elif key in ("Ns", "Ni", "d", "Tr"):
            value = _floats(parts, 1, 1, path, lineno, key)[0]
            if not math.isfinite(value):
                raise SceneError(f"{path}:{lineno}: {key}: expected a finite number")
            if key == "Tr":
                cur.d = 1.0 - value
            else:
                setattr(cur, key, value)
        elif key == "illum":
            cur.illum = int(_floats(parts, 1, 1, path, lineno, key)[0])
        elif key in ("Pr", "Pm"):
            value = _floats(parts, 1, 1, path, lineno, key)[0]
            if not 0.0 <= value <= 1.0:
                raise SceneError(f"{path}:{lineno}: {key}: expected a number in [0, 1], got "
                                 f"{excerpt(parts[1], quote=False)}")
            setattr(cur, key, value)
        elif key == "map_Kd":
            cur.map_Kd = _texture_map(parts, path, lineno, files)
        elif key == "map_d":
            cur.map_d = _texture_map(parts, path, lineno, files, data="opacity")
        elif key == "norm":
            cur.norm = _texture_map(parts, path, lineno, files, data="normal")
        elif key == "Ka":
            pass    # ambient colour: no meaning in a physically based renderer
        else:
            notes.add(excerpt(key), lineno)
    notes.emit()
    return out


def phong_alpha(ns: float) -> float:
    """Beckmann roughness matching a Phong exponent (Walter et al. 2007, eq. 33 inverted)."""
    return float(min(max(math.sqrt(2.0 / (max(ns, 0.0) + 2.0)), 1e-3), 1.0))


def obj_material(mtl: MtlMaterial | None, name: str) -> tuple[m.Material, m.Emission | None]:
    """The renderer's material (and emission) for one MTL material."""
    if mtl is None:
        return m.Material("diffuse", reflectance=(0.5, 0.5, 0.5), name=name), None
    reflectance = mtl.map_Kd if mtl.map_Kd is not None else mtl.Kd
    ior = mtl.Ni if mtl.Ni > 1.0 else 1.5
    emission = m.Emission(tuple(mtl.Ke)) if max(mtl.Ke) > 0 else None
    glass = mtl.illum in (4, 6, 7, 9) or mtl.d < 1.0
    black_kd = mtl.map_Kd is None and max(mtl.Kd) == 0
    if glass:
        mat = m.Material("dielectric", int_ior=ior, ext_ior=1.0, name=name,
                         specular_transmittance=tuple(mtl.Tf) if mtl.Tf else (1.0, 1.0, 1.0))
    elif mtl.Pr is not None or mtl.Pm is not None:
        roughness = mtl.Pr if mtl.Pr is not None else math.sqrt(phong_alpha(mtl.Ns))
        mat = metallic_roughness_material(reflectance, mtl.Pm or 0.0, roughness, name=name)
    elif max(mtl.Ks) > 0 and mtl.illum != 1 and black_kd:
        mat = m.Material("roughconductor", eta=(0.0, 0.0, 0.0), k=(1.0, 1.0, 1.0),
                         specular_reflectance=tuple(mtl.Ks), alpha=(phong_alpha(mtl.Ns),) * 2,
                         name=name)
    elif max(mtl.Ks) > 0 and mtl.illum != 1:
        mat = m.Material("roughplastic", reflectance=reflectance, specular_reflectance=tuple(mtl.Ks),
                         int_ior=ior, ext_ior=1.0, alpha=(phong_alpha(mtl.Ns),) * 2, name=name)
    else:
        mat = m.Material("diffuse", reflectance=reflectance, name=name)
    mat.opacity, mat.normal_map = mtl.map_d, mtl.norm
    return mat, emission


def load_obj_scene(path, **params) -> m.Scene:
    """An OBJ file as a scene: one shape per (object, material) pair, materials from its
    MTL files, area lights where ``Ke`` > 0; no camera (a default one frames it)."""
    from .finish import finish_scene

    path = Path(path)
    files = SceneFiles(path.parent)
    obj = read_obj(path, files)
    scene = m.Scene(source=str(path))
    mat_ids, emissions = {}, {}
    for k, name in enumerate(obj.material_names):
        if not (obj.tri_material == k).any():
            continue
        if name not in obj.materials and name != "default":
            warn(f"{path}: material {excerpt(name)} is not defined in the material libraries; "
                 f"using grey diffuse")
        mat, emission = obj_material(obj.materials.get(name), name)
        mat_ids[k] = scene.add_material(mat)
        emissions[k] = emission
    # one key per (object, material) pair: a sort of rows (np.unique(axis=0)) is 30x slower
    key = obj.tri_object * len(obj.material_names) + obj.tri_material
    single = bool((key == key[0]).all())
    for pair in (key[:1] if single else np.unique(key)).tolist():
        obj_id, mat_id = divmod(pair, len(obj.material_names))
        mesh = obj.mesh(None if single else key == pair, pair)
        scene.shapes.append(m.Shape("mesh", material=mat_ids[mat_id], vertices=mesh.vertices,
                                    triangles=mesh.triangles, normals=mesh.normals, uvs=mesh.uvs,
                                    emission=emissions[mat_id],
                                    name=f"{obj.object_names[obj_id]}/{obj.material_names[mat_id]}"))
    return finish_scene(scene, has_camera=False)
