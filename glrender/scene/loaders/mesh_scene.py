"""A lone mesh file (PLY) as a scene: one grey diffuse shape, a default camera framing it,
and a warning that nothing emits light."""
from __future__ import annotations

from pathlib import Path

from .. import model as m
from .mesh_files import read_mesh


def load_mesh_scene(path, **params) -> m.Scene:
    from .finish import finish_scene

    path = Path(path)
    mesh = read_mesh(path)
    scene = m.Scene(source=str(path))
    mat = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5), name="default"))
    scene.shapes.append(m.Shape("mesh", material=mat, vertices=mesh.vertices, triangles=mesh.triangles,
                                normals=mesh.normals, uvs=mesh.uvs, name=path.stem))
    return finish_scene(scene, has_camera=False)
