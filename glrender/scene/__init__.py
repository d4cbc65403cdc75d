"""Scenes: the in-memory model and the loaders that fill it."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Iterable

from ..errors import SceneError, UsageError
from .loaders.diagnostics import GlrenderWarning, file_hashes, printable, record_digests, record_files
from .loaders.scene_files import check_regular, current_search_path
from .loaders.scene_files import search_path as search_folders
from .model import (Camera, Emission, Film, Integrator, Light, Material, Medium, Sampler, Scene,
                    Shape, Shutter, Texture, Volume)

__all__ = ["load", "FORMATS", "Scene", "Camera", "Film", "Integrator", "Sampler", "Shutter",
           "Material", "Shape", "Light", "Emission", "Texture", "Medium", "Volume", "GlrenderWarning"]

# extension -> (module in glrender.scene.loaders, function)
FORMATS = {
    ".toml": ("toml_scene", "load_toml"),
    ".xml": ("mitsuba_xml", "load_mitsuba"),
    ".gltf": ("gltf", "load_gltf"),
    ".glb": ("gltf", "load_gltf"),
    ".obj": ("obj", "load_obj_scene"),
    ".ply": ("mesh_scene", "load_mesh_scene"),
}


def load(path: str | os.PathLike[str], *,
         search_path: Iterable[str | os.PathLike[str]] | None = None, **params: Any) -> Scene:
    """Load a scene file; the format comes from the extension: .toml (native), .xml
    (Mitsuba 3), .gltf/.glb, .obj (with its MTL files) or .ply (a mesh, with a default
    camera and material). ``params`` fill ``$name`` references (TOML ``[params]``, Mitsuba
    ``<default>``); loaders warn through :class:`GlrenderWarning`.

    Files the scene refers to must lie in the scene file's folder or in a folder of
    ``search_path`` (default: the command line's ``--search-path``); a reference leading
    anywhere else is refused (docs/scene-format.md, "Referenced files")."""
    import importlib

    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise SceneError(f"{printable(str(path))}: unsupported scene format "
                         f"{printable(ext) or '(no extension)'} (expected {', '.join(FORMATS)})")
    folders = current_search_path() if search_path is None else _folders(search_path)
    module, function = FORMATS[ext]
    loader = getattr(importlib.import_module(f".loaders.{module}", __name__), function)
    check_regular(path)
    try:
        with record_files() as files, record_digests() as digests, search_folders(folders):
            scene: Scene = loader(path, **params)
    except SceneError as exc:
        # the one door of every loader's errors: nothing non-printable reaches a terminal
        exc.args = tuple(printable(a) if isinstance(a, str) else a for a in exc.args)
        raise
    scene.files = file_hashes([path, *files], digests)
    return scene


def _folders(search_path: Iterable[str | os.PathLike[str]]) -> tuple[Path, ...]:
    """``search_path`` as folders, each checked to be one."""
    items = [search_path] if isinstance(search_path, (str, os.PathLike)) else list(search_path)
    folders = []
    for folder in items:
        if not isinstance(folder, (str, os.PathLike)) or not Path(folder).is_dir():
            raise UsageError(f"search_path: {printable(str(folder))} is not a folder")
        folders.append(Path(folder))
    return tuple(folders)
