"""The scenes of the denoising tests and benchmark: the Cornell box (Mitsuba 3's reference in
tests/data/refs) and a textured Cornell box (its reference rendered by glrender, see
tests/data/refs/textured-cornell-ref.json)."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import glrender
from glrender.film.io import read_image
from glrender.scene import model as m

ROOT = Path(__file__).resolve().parents[2]
REFS = ROOT / "tests" / "data" / "refs"
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"
# Cesium's logo (CC-BY 4.0, from the BoxTextured glTF sample): fine detail and sharp edges
LOGO = ROOT / "tests" / "data" / "scenes" / "gltf" / "BoxTextured-glTF" / "CesiumLogoFlat.png"
TEXTURED_SIZE = 128


def cornell() -> m.Scene:
    return glrender.load(CORNELL)


def textured_cornell() -> m.Scene:
    """The Cornell box at 128x128 whose back wall, floor and two boxes show the logo
    (tiled 2x2), a texture the albedo AOV carries and the denoiser must keep."""
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=TEXTURED_SIZE, height=TEXTURED_SIZE)
    logo = m.Texture("bitmap", image=read_image(LOGO), name="logo",
                     uv_transform=np.array([[2.0, 0, 0], [0, 2.0, 0], [0, 0, 1]]))
    textured = scene.add_material(m.Material("diffuse", reflectance=logo, name="logo"))
    for shape in scene.shapes:
        if shape.name in ("back", "floor", "small box", "large box"):
            shape.material = textured
    return scene


def reference(name: str) -> np.ndarray:
    return np.load(REFS / f"{name}-ref.npy")


def away_from_light(ref: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels whose footprint does not reach the light. The light's pixels
    (reference radiance >= 1 in some channel: the emitter is 18x brighter than any lit
    surface) grown by one pixel, which takes in the pixels it covers only in part (their
    reference lies between the ceiling's and the light's)."""
    light = ref.max(-1) >= 1.0
    grown = np.pad(light, 1)
    h, w = light.shape
    near = np.zeros_like(light)
    for dy in range(3):
        for dx in range(3):
            near |= grown[dy:dy + h, dx:dx + w]
    return ~near
