"""Scenes: the in-memory model and the loaders that fill it."""
from __future__ import annotations

from pathlib import Path

from ..errors import SceneError
from .model import (Camera, Emission, Film, Integrator, Light, Material, Sampler, Scene, Shape,
                    Shutter, Texture)

__all__ = ["load", "Scene", "Camera", "Film", "Integrator", "Sampler", "Shutter", "Material",
           "Shape", "Light", "Emission", "Texture"]


def load(path, **params) -> Scene:
    """Load a scene file; the format comes from the extension (.toml)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".toml":
        from .loaders.toml_scene import load_toml

        return load_toml(path, **params)
    raise SceneError(f"{path}: unsupported scene format {ext or '(no extension)'} (expected .toml)")
