"""Reading one mesh file by its extension: OBJ and PLY through glrender's own readers, other
formats through trimesh."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import SceneError
from .meshes import MeshData, finish_mesh
from .obj import read_obj
from .ply import read_ply


def read_mesh(path, files=None, referrer=None) -> MeshData:
    """One mesh file as a single mesh (every object and group of an OBJ together)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".obj":
        return read_obj(path).merged()
    if ext == ".ply":
        return read_ply(path)
    if ext == ".serialized":
        raise SceneError(f"{path}: Mitsuba's .serialized meshes are not supported "
                         f"(convert the mesh to PLY or OBJ)")
    return _read_trimesh(path)


def _read_trimesh(path: Path) -> MeshData:
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="mesh", process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SceneError(f"{path}: cannot read mesh ({first})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise SceneError(f"{path}: no triangles found")
    return finish_mesh(MeshData(np.asarray(loaded.vertices, np.float64),
                                np.asarray(loaded.faces, np.int64)), path)
