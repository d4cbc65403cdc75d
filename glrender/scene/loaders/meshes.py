"""Triangle meshes from files: the format by extension (OBJ, PLY, and STL/OFF/... through
trimesh), then the checks every mesh gets: finite vertices, indices in range, zero-area
triangles dropped (with a count in a warning), vertex normals when the file has none."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...accel import disk_cache
from ...errors import SceneError
from .. import model as m
from .diagnostics import warn

# The version of what vertex_normals computes: recomputed normals of large meshes are kept in
# the BVH cache (accel/disk_cache.py) under it, so bump it with any change that alters a bit
# of the result.
NORMALS_VERSION = 1
# below this many triangles the normals cost less than reading a cache file
CACHE_MIN_TRIANGLES = 1 << 15
# The version of what finish_mesh returns for given arrays: the finished meshes of mesh files
# of CACHE_MIN_FILE_BYTES or more are kept in the BVH cache under it (keyed by the file's
# bytes and its reader's version, finish_mesh_cached), so bump it with any change to the
# checks, the drop of zero-area triangles or the arrays' types.
FINISH_VERSION = 1
CACHE_MIN_FILE_BYTES = 1 << 20
_MESH_ARRAYS = ("vertices", "triangles", "normals", "uvs")


@dataclass
class MeshData:
    """One mesh in object space: vertices (V,3), triangles (T,3), optional normals (V,3)
    and uvs (V,2) in Mitsuba's convention (v = 0 at the first image row)."""

    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None


def _length(x: list[np.ndarray]) -> np.ndarray:
    return np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Mitsuba's recomputed vertex normals: face normals weighted by the angle of each
    face at the vertex (Thürmer and Wüthrich 1998), normalized; 0 where undefined."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(triangles, np.int64).reshape(-1, 3)
    e = m.triangle_edges(v, f)
    return _angle_weighted_normals(len(v), f, e, m.face_normals(e))


def _angle_weighted_normals(count: int, f: np.ndarray, e: list[list[np.ndarray]],
                            face_normal: list[np.ndarray]) -> np.ndarray:
    """:func:`vertex_normals` from the triangles' edges ``e`` (``model.triangle_edges``) and their
    unnormalized face normals ``(p1 - p0) x (p2 - p0)``."""
    # divisions, not products with 1 / length, and dot products summed as np.einsum sums
    # them here ((x0 y0 + x2 y2) + x1 y1): the normals of the per-corner formulation bit
    # for bit. Each edge is normalized once: corner k lies between e_k and -e_{k-1}.
    length = np.maximum(_length(face_normal), 1e-300)
    n = [x / length for x in face_normal]
    unit = []
    for edge in e:
        length = np.maximum(_length(edge), 1e-300)
        unit.append([x / length for x in edge])
    out = np.zeros((3, count))
    corners = np.ascontiguousarray(f.T)      # bincount copies a strided index array
    for k in range(3):
        a, b = unit[k], unit[k - 1]
        cos = -((a[0] * b[0] + a[2] * b[2]) + a[1] * b[1])
        angle = np.arccos(np.clip(cos, -1.0, 1.0, out=cos), out=cos)
        for axis in range(3):   # bincount: an unbuffered scatter-add, 10x faster than np.add.at
            out[axis] += np.bincount(corners[k], weights=n[axis] * angle, minlength=count)
    length = _length(out)
    positive = length > 0
    out /= np.where(positive, length, 1.0)
    out[:, ~positive] = 0.0
    return np.ascontiguousarray(out.T)


def finish_mesh(mesh: MeshData, source, compute_normals: bool = True) -> MeshData:
    """Validate a loaded mesh, drop zero-area triangles (one warning with the count) and
    compute vertex normals if the file has none."""
    finished, dropped, total = _finish(mesh, source, compute_normals)
    _warn_dropped(source, dropped, total)
    return finished


def finish_mesh_cached(read, source, origin: dict, compute_normals: bool = True) -> MeshData:
    """``finish_mesh(read(), source, compute_normals)``, from the cache when the mesh that
    ``origin`` names (JSON-able: its file's SHA-256, the reader and the reader's version)
    was finished before: no parse, no checks, no search for zero-area triangles (the
    warning about them is given again) and no normals."""
    if not disk_cache.enabled():
        return finish_mesh(read(), source, compute_normals)
    key = disk_cache.key("mesh", FINISH_VERSION, {**origin, "normals": compute_normals and NORMALS_VERSION}, [])
    entry = disk_cache.load("mesh", key, FINISH_VERSION)
    if entry is not None:
        try:
            a = entry.arrays
            mesh = MeshData(*(a.get(name) for name in _MESH_ARRAYS))
            dropped, total = int(entry.meta["dropped"]), int(entry.meta["triangles"])
            count = len(mesh.vertices)
            if mesh.vertices.shape == (count, 3) and mesh.triangles.shape == (total - dropped, 3) and \
                    all(x is None or x.shape == (count, w) for x, w in ((mesh.normals, 3), (mesh.uvs, 2))):
                _warn_dropped(source, dropped, total)
                return mesh
        except (KeyError, TypeError, ValueError, AttributeError):
            pass                # not what this function writes: finish again, and replace it
    mesh, dropped, total = _finish(read(), source, compute_normals)
    disk_cache.store("mesh", key, FINISH_VERSION,
                     {name: getattr(mesh, name) for name in _MESH_ARRAYS if getattr(mesh, name) is not None},
                     {"dropped": dropped, "triangles": total})
    _warn_dropped(source, dropped, total)
    return mesh


def _warn_dropped(source, dropped: int, total: int) -> None:
    if dropped:
        warn(f"{source}: dropped {dropped} zero-area triangle{'s' if dropped > 1 else ''} "
             f"of {total}")


def _finish(mesh: MeshData, source, compute_normals: bool) -> tuple[MeshData, int, int]:
    """:func:`finish_mesh` without the warning: the mesh, and how many of its triangles
    were dropped of how many."""
    v = np.asarray(mesh.vertices, np.float64).reshape(-1, 3)
    f = np.asarray(mesh.triangles, np.int64).reshape(-1, 3)
    if not np.all(np.isfinite(v)):
        bad = int(np.flatnonzero(~np.isfinite(v).all(axis=1))[0])
        raise SceneError(f"{source}: vertex {bad} has a NaN or infinite coordinate")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        bad = int(np.flatnonzero((f < 0).any(axis=1) | (f >= len(v)).any(axis=1))[0])
        raise SceneError(f"{source}: triangle {bad} refers to vertex {f[bad].tolist()}, "
                         f"outside [0, {len(v)})")
    e = face_normal = None
    total, dropped = len(f), 0
    if len(f):
        e = m.triangle_edges(v, f)
        face_normal = m.face_normals(e)
        keep = _length(face_normal) > 0
        dropped = int(len(f) - np.count_nonzero(keep))
        if dropped:
            f = f[keep]
            e = [[x[keep] for x in edge] for edge in e]
            face_normal = [x[keep] for x in face_normal]
    if len(f) == 0:
        raise SceneError(f"{source}: no triangles with non-zero area")
    normals = _per_vertex(mesh.normals, len(v), 3, "normals", source)
    if normals is None and compute_normals:
        normals = _cached_normals(v, f, e, face_normal)
    return MeshData(v, f, normals, _per_vertex(mesh.uvs, len(v), 2, "texture coordinates", source)), \
        dropped, total


def _cached_normals(v: np.ndarray, f: np.ndarray, e, face_normal) -> np.ndarray:
    """:func:`_angle_weighted_normals`, from the cache when the mesh is large and was seen
    before (keyed by the vertex and triangle arrays)."""
    if len(f) < CACHE_MIN_TRIANGLES or not disk_cache.enabled():
        return _angle_weighted_normals(len(v), f, e, face_normal)
    key = disk_cache.key("normals", NORMALS_VERSION, {}, [v, f])
    entry = disk_cache.load("normals", key, NORMALS_VERSION)
    if entry is not None and entry.arrays.get("normals", np.zeros(0)).shape == v.shape:
        return entry.arrays["normals"]
    normals = _angle_weighted_normals(len(v), f, e, face_normal)
    disk_cache.store("normals", key, NORMALS_VERSION, {"normals": normals}, {})
    return normals


def _per_vertex(values, count: int, width: int, what: str, source) -> np.ndarray | None:
    """An optional per-vertex attribute, checked against the vertex count; non-finite
    entries become 0 (the renderer falls back to the face normal / uv 0 there)."""
    if values is None:
        return None
    arr = np.asarray(values, np.float64).reshape(-1, width)
    if len(arr) != count:
        raise SceneError(f"{source}: {len(arr)} {what} for {count} vertices")
    return np.where(np.isfinite(arr), arr, 0.0)


DISK_SEGMENTS = 32


def disk_shape(shape):
    """Mitsuba's ``disk`` (the unit disk at z = 0 facing +z) as a mesh the renderer takes:
    a fan of DISK_SEGMENTS triangles whose radius is scaled so that the polygon keeps the
    disk's area (and an area light its power). uv as Mitsuba's disk: (r, phi / 2 pi)."""
    import math
    from dataclasses import replace

    n = DISK_SEGMENTS
    r = math.sqrt(math.pi / (0.5 * n * math.sin(2 * math.pi / n)))
    phi = np.arange(n + 1) * (2 * math.pi / n)
    ring = np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros(n + 1)], axis=1)
    vertices = np.concatenate([np.zeros((n + 1, 3)), ring])       # centre copies keep the uv seam
    uvs = np.concatenate([np.stack([np.zeros(n + 1), phi / (2 * math.pi)], axis=1),
                          np.stack([np.ones(n + 1), phi / (2 * math.pi)], axis=1)])
    k = np.arange(n)
    triangles = np.stack([k, n + 1 + k, n + 2 + k], axis=1)
    normals = np.tile([0.0, 0.0, 1.0], (len(vertices), 1))
    return replace(shape, kind="mesh", vertices=vertices, triangles=triangles, normals=normals,
                   uvs=uvs, face_normals=True)
