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
light on the faces that use the material.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import SceneError
from .. import model as m
from .diagnostics import Notes, SceneFiles, read_bytes, read_image_checked, warn
from .meshes import MeshData, finish_mesh

MAX_FILE_BYTES = 1 << 31
FAST_PATH_BYTES = 1 << 16     # files above this try the bulk parser first


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

    def mesh(self, select: np.ndarray | None = None) -> MeshData:
        """The triangles ``select`` (a boolean mask; all by default) as one mesh."""
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
        return finish_mesh(MeshData(vertices, inverse.reshape(-1, 3), normals, uvs), self.path)

    def merged(self) -> MeshData:
        return self.mesh()


def _floats(parts, lo: int, hi: int, path, lineno: int, what: str) -> list[float]:
    if len(parts) - 1 < lo:
        raise SceneError(f"{path}:{lineno}: {what} needs at least {lo} numbers, got {len(parts) - 1}")
    try:
        return [float(x) for x in parts[1:1 + hi]]
    except ValueError:
        raise SceneError(f"{path}:{lineno}: {what}: expected numbers, got {' '.join(parts[1:])!r}") from None


def _read_text(path: Path) -> str:
    return read_bytes(path, MAX_FILE_BYTES).decode("utf-8", errors="replace")


def _statements(text: str):
    """(line number, stripped line, its tokens) of every line that is not blank or a comment."""
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if line and line[0] != "#":
            yield lineno, line, line.split()


def _numbers(text: str, dtype) -> np.ndarray:
    """Whitespace-separated numbers parsed in C; ValueError unless every token is one."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")      # numpy warns (DeprecationWarning) on a bad token
        try:
            arr = np.fromstring(text, dtype=dtype, sep=" ")
        except (DeprecationWarning, ValueError):
            raise ValueError("not a number") from None
    if arr.size != len(text.split()):
        raise ValueError("not a number")
    return arr


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


def _read_obj_fast(text: str, path: Path):
    """Large files, the common shape: every ``v`` has 3 numbers and every face has the same
    number of corners in the same format with positive indices. Lines are sorted by kind in
    one pass and each kind is parsed by numpy in bulk; anything else returns None (the
    general parser then reads the file and reports errors with their line numbers)."""
    import re

    if re.search(r"^(?![ \t]*$|v |f |vt |vn |usemtl\b|mtllib\b|[ogs]\b|#)", text, re.M):
        return None
    v = re.findall(r"^v (.*)$", text, re.M)
    f = re.findall(r"^f (.*)$", text, re.M)
    vt = re.findall(r"^vt (.*)$", text, re.M) if "vt " in text else []
    vn = re.findall(r"^vn (.*)$", text, re.M) if "vn " in text else []
    mat_starts, obj_starts, mtl_files = [], [], []
    markers = list(re.finditer(r"^(usemtl|mtllib|o|g)\b(.*)$", text, re.M))
    if markers:
        face_at = np.array([mt.start() for mt in re.finditer(r"^f ", text, re.M)])
        for mt in markers:
            key, name = mt.group(1), mt.group(2).strip()
            if key == "mtllib":
                mtl_files.append((name, text.count("\n", 0, mt.start()) + 1))
            else:
                target = mat_starts if key == "usemtl" else obj_starts
                target.append((int(np.searchsorted(face_at, mt.start())), name or "default"))
    if not f or not v:
        return None
    try:
        pos = _numbers(" ".join(v), np.float64)
        if pos.size != 3 * len(v):
            return None
        tokens = " ".join(f).split()
        k = len(tokens) // len(f)
        if k < 3 or k * len(f) != len(tokens) or len(f[0].split()) != k:
            return None
        first = tokens[0]
        slashes = first.count("/")
        double = "//" in first
        joined = " ".join(tokens)
        if joined.count("/") != slashes * len(tokens) or ("//" in joined) != double or \
                (double and joined.count("//") != len(tokens)):
            return None
        fields = 1 + slashes - (1 if double else 0)
        ids = _numbers(joined.replace("//", " ").replace("/", " "), np.int64)
        if ids.size != fields * len(tokens) or ids.min() < 1:
            return None       # negative or zero indices: the general parser
        ids = ids.reshape(len(f), k, fields) - 1
        tex = np.array(" ".join(t.split()[0] + " " + (t.split() + ["0"])[1] for t in vt).split(),
                       np.float64).reshape(-1, 2) if vt else np.zeros((0, 2))
        nrm = _numbers(" ".join(vn), np.float64).reshape(-1, 3) if vn else np.zeros((0, 3))
    except ValueError:
        return None
    corner = np.full((len(f), k, 3), -1, np.int64)
    corner[:, :, 0] = ids[:, :, 0]
    if double:
        corner[:, :, 2] = ids[:, :, 1]
    elif fields >= 2:
        corner[:, :, 1] = ids[:, :, 1]
        if fields == 3:
            corner[:, :, 2] = ids[:, :, 2]
    for axis, count in enumerate((len(v), len(tex), len(nrm))):
        if corner[:, :, axis].max() >= count:
            return None
    tex[:, 1] = 1.0 - tex[:, 1]
    fan = np.concatenate([corner[:, [0, j, j + 1]] for j in range(1, k - 1)], axis=0)
    face_of = np.tile(np.arange(len(f)), k - 2)

    def numbered(starts):
        names, index = ["default"], {"default": 0}
        per_face = np.zeros(len(f), np.int64)
        for n, (at, name) in enumerate(starts):
            end = starts[n + 1][0] if n + 1 < len(starts) else len(f)
            per_face[at:end] = index.setdefault(name, len(names))
            if index[name] == len(names):
                names.append(name)
        return names, per_face[face_of]
    mat_names, tri_mat = numbered(mat_starts)
    obj_names, tri_obj = numbered(obj_starts)
    order = np.argsort(face_of, kind="stable")          # triangles in file order
    fan, tri_mat, tri_obj = fan[order], tri_mat[order], tri_obj[order]
    unique, inverse = _corners(fan.reshape(-1, 3), len(v), len(tex), len(nrm))
    positions = pos.reshape(-1, 3)
    if not np.all(np.isfinite(positions)):
        return None
    obj = ObjFile(path, positions, tex, nrm, unique, inverse.reshape(-1, 3), tri_mat, tri_obj,
                  mat_names, obj_names)
    return obj, mtl_files


def read_obj(path, files: SceneFiles | None = None, read_materials: bool = True) -> ObjFile:
    """Parse an OBJ file (and its MTL files when ``read_materials``)."""
    path = Path(path)
    files = files or SceneFiles(path.parent)
    text = _read_text(path)
    fast = _read_obj_fast(text, path) if len(text) > FAST_PATH_BYTES else None
    if fast is not None:
        obj, mtl_files = fast
        _read_materials(obj, mtl_files, path, files, read_materials)
        return obj
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
                    raise SceneError(f"{path}:{lineno}: malformed face vertex {token!r}")
                ids = []
                for k, (text_id, count) in enumerate(zip(fields + ["", ""], (len(pos), len(tex), len(nrm)))):
                    if k >= len(fields) or text_id == "":
                        ids.append(-1)
                        continue
                    try:
                        i = int(text_id)
                    except ValueError:
                        raise SceneError(f"{path}:{lineno}: malformed face vertex {token!r}") from None
                    if i < 0:
                        i += count
                        if i < 0:
                            raise SceneError(f"{path}:{lineno}: relative index {text_id} reaches before "
                                             f"the first {('vertex', 'texture coordinate', 'normal')[k]}")
                    elif i == 0:
                        raise SceneError(f"{path}:{lineno}: index 0 in {token!r} (OBJ counts from 1)")
                    else:
                        i -= 1
                        if i >= count:
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
            notes.add(f"'{key}'", lineno)
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
    if read_materials:
        for name, lineno in mtl_files:
            for mtl in _mtl_names(name, path):
                try:
                    mtl_path = files.resolve(mtl, path, lineno, "material library")
                except SceneError as exc:
                    warn(f"{exc} (its materials become grey diffuse)")
                    continue
                obj.materials.update(read_mtl(mtl_path, files))


def _mtl_names(rest: str, referrer: Path) -> list[str]:
    """``mtllib`` takes several names, but some exporters write one name with spaces."""
    if (referrer.parent / rest).is_file():
        return [rest]
    return rest.split()


_MAP_OPTION_ARGS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
                    "-imfchan": 1, "-mm": 2, "-texres": 1, "-type": 1}


def _read_data_image(image_path: Path, opacity: bool) -> np.ndarray:
    """A data texture as stored (no sRGB decode): an opacity map's alpha channel where it
    has one, else its grey level; a normal map's RGB."""
    from PIL import Image

    from .diagnostics import check_image_size

    with Image.open(image_path) as im:
        check_image_size(im.size[0], im.size[1], str(image_path))
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
        raise SceneError(f"{path}:{lineno}: cannot read texture {name!r} ({exc})") from None
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
            raise SceneError(f"{path}:{lineno}: {key!r} before the first newmtl")
        if key in ("Kd", "Ks", "Ke", "Tf"):
            if len(parts) > 1 and parts[1] in ("spectral", "xyz"):
                notes.add(f"'{key} {parts[1]}'", lineno)
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
        elif key == "map_Kd":
            cur.map_Kd = _texture_map(parts, path, lineno, files)
        elif key == "map_d":
            cur.map_d = _texture_map(parts, path, lineno, files, data="opacity")
        elif key == "norm":
            cur.norm = _texture_map(parts, path, lineno, files, data="normal")
        elif key == "Ka":
            pass    # ambient colour: no meaning in a physically based renderer
        else:
            notes.add(f"'{key}'", lineno)
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
            warn(f"{path}: material {name!r} is not defined in the material libraries; "
                 f"using grey diffuse")
        mat, emission = obj_material(obj.materials.get(name), name)
        mat_ids[k] = scene.add_material(mat)
        emissions[k] = emission
    pairs = np.unique(np.stack([obj.tri_object, obj.tri_material], axis=1), axis=0)
    for obj_id, mat_id in pairs:
        select = (obj.tri_object == obj_id) & (obj.tri_material == mat_id)
        mesh = obj.mesh(select)
        scene.shapes.append(m.Shape("mesh", material=mat_ids[mat_id], vertices=mesh.vertices,
                                    triangles=mesh.triangles, normals=mesh.normals, uvs=mesh.uvs,
                                    emission=emissions[mat_id],
                                    name=f"{obj.object_names[obj_id]}/{obj.material_names[mat_id]}"))
    return finish_scene(scene, has_camera=False)
