"""Reading one mesh file by its extension: OBJ and PLY through glrender's own readers, other
formats through trimesh (whatever those files refer to read through the scene's
:class:`~.scene_files.SceneFiles`, so the same folders are allowed)."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ...errors import SceneError
from .diagnostics import cause
from .meshes import MeshData, finish_mesh
from .obj import read_obj
from .ply import read_ply
from .scene_files import SceneFiles, read_bytes

MAX_FILE_BYTES = 1 << 31


def read_mesh(path, files: SceneFiles | None = None) -> MeshData:
    """One mesh file as a single mesh (every object and group of an OBJ together); the
    files it refers to resolve through ``files`` (default: its own folder's)."""
    path = Path(path)
    files = files or SceneFiles(path.parent)
    ext = path.suffix.lower()
    if ext == ".obj":
        return read_obj(path, files, read_materials=False).merged()
    if ext == ".ply":
        return read_ply(path)
    if ext == ".serialized":
        raise SceneError(f"{path}: Mitsuba's .serialized meshes are not supported "
                         f"(convert the mesh to PLY or OBJ)")
    return _read_trimesh(path, files)


def _read_trimesh(path: Path, files: SceneFiles) -> MeshData:
    import trimesh
    from trimesh.resolvers import Resolver

    class PolicyResolver(Resolver):
        """trimesh's access to the files a mesh refers to (glTF buffers, textures, ...),
        through the scene's path policy."""

        def __init__(self, referrer: Path):
            self.referrer = referrer

        def get(self, key):
            return read_bytes(files.resolve(str(key), self.referrer, what="file"))

        def write(self, name, data):
            raise SceneError(f"{path}: a mesh file cannot write files")

        def namespaced(self, namespace):
            return PolicyResolver(self.referrer.parent / str(namespace) / self.referrer.name)

        def keys(self):
            return []

    data = read_bytes(path, MAX_FILE_BYTES)
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=path.suffix.lower().lstrip("."),
                              resolver=PolicyResolver(path), force="mesh", process=False,
                              maintain_order=True)
    except SceneError:
        raise           # a referenced file refused or missing: the resolver's own line
    except Exception as exc:  # trimesh raises many types for malformed files
        raise SceneError(f"{path}: cannot read mesh ({cause(exc)})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise SceneError(f"{path}: no triangles found")
    return finish_mesh(MeshData(np.asarray(loaded.vertices, np.float64),
                                np.asarray(loaded.faces, np.int64)), path)
