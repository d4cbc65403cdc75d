"""Triangle meshes from files (PLY, OBJ, STL, ...) through trimesh."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import SceneError


def load_mesh(path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(vertices (V,3), triangles (T,3), vertex normals or None, uvs or None) of one mesh file.

    Files holding several objects are concatenated. Vertex normals come from the file
    when it has them, else they are computed from the faces.
    """
    import trimesh

    path = Path(path)
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise SceneError(f"{path}: cannot read mesh ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise SceneError(f"{path}: no triangles found")
    vertices = np.asarray(loaded.vertices, np.float64)
    faces = np.asarray(loaded.faces, np.int64)
    # Vertex normals from the file, else computed (area-weighted), as Mitsuba does for
    # meshes without face_normals; Shape.face_normals asks for flat shading instead.
    normals = np.asarray(loaded.vertex_normals, np.float64)
    uvs = None
    visual = getattr(loaded, "visual", None)
    if visual is not None and getattr(visual, "uv", None) is not None and len(visual.uv) == len(vertices):
        uvs = np.asarray(visual.uv, np.float64)
    if not np.all(np.isfinite(vertices)):
        raise SceneError(f"{path}: vertices contain NaN or infinite coordinates")
    return vertices, faces, normals, uvs
