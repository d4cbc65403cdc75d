"""Scenes: the in-memory model and the loaders that fill it."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..errors import SceneError
from .loaders.diagnostics import GlrenderWarning, file_hashes, record_files
from .model import (Camera, Emission, Film, Integrator, Light, Material, Sampler, Scene, Shape,
                    Shutter, Texture)

__all__ = ["load", "FORMATS", "Scene", "Camera", "Film", "Integrator", "Sampler", "Shutter",
           "Material", "Shape", "Light", "Emission", "Texture", "GlrenderWarning"]

# extension -> (module in glrender.scene.loaders, function)
FORMATS = {
    ".toml": ("toml_scene", "load_toml"),
    ".xml": ("mitsuba_xml", "load_mitsuba"),
    ".gltf": ("gltf", "load_gltf"),
    ".glb": ("gltf", "load_gltf"),
    ".obj": ("obj", "load_obj_scene"),
    ".ply": ("mesh_scene", "load_mesh_scene"),
}


def load(path: str | os.PathLike[str], **params: Any) -> Scene:
    """Load a scene file; the format comes from the extension: .toml (native), .xml
    (Mitsuba 3), .gltf/.glb, .obj (with its MTL files) or .ply (a mesh, with a default
    camera and material). ``params`` fill ``$name`` references (TOML ``[params]``, Mitsuba
    ``<default>``); loaders warn through :class:`GlrenderWarning`."""
    import importlib

    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise SceneError(f"{path}: unsupported scene format {ext or '(no extension)'} "
                         f"(expected {', '.join(FORMATS)})")
    if not path.is_file():
        raise SceneError(f"{path}: no such file")
    module, function = FORMATS[ext]
    loader = getattr(importlib.import_module(f".loaders.{module}", __name__), function)
    with record_files() as files:
        scene: Scene = loader(path, **params)
    scene.files = file_hashes([path, *files])
    return scene
