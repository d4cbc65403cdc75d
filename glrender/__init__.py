"""glrender: a physically based renderer whose Monte Carlo core runs as GLSL compute shaders.

The public API is what this module exports; everything else is private by convention::

    import glrender
    scene = glrender.load("scenes/cornell-box/scene.toml")
    film = glrender.render(scene, spp=64, seed=1)
    film.mean        # (H, W, 3) linear RGB radiance, rows top to bottom
    film.stderr      # (H, W, 3) standard error of each pixel's mean
    film.save("out.png")

Scenes can be built and edited in code with the dataclasses exported here (:class:`Scene`,
:class:`Camera`, :class:`Shape`, :class:`Material`, ...). Conventions are Mitsuba 3's:
world-space metres (any unit, used consistently), 4x4 ``world_from_object`` matrices acting on
column vectors, cameras looking along +z of camera space with +y up, linear RGB radiance in
W/(m^2 sr) per channel.
"""
from __future__ import annotations

from ._render import ProgressCallback, render
from .errors import DeviceError, GlrenderError, SceneError, ShaderError, UsageError
from .film import Film
from .render.renderer import Renderer, RenderSettings, settings_from_scene
from .scene import load
from .scene.model import (Camera, Emission, Integrator, Light, Material, Medium, Sampler, Scene,
                          Shape, Shutter, Texture, Volume, look_at, rotate, scale, translate)
from .scene.model import Film as FilmSettings

__version__ = "0.1.0"

#: The rendered image (an alias of :class:`Film`).
Image = Film

__all__ = ["load", "render", "Renderer", "RenderSettings", "Film", "Image", "Scene", "Camera",
           "settings_from_scene",
           "FilmSettings", "Integrator", "Sampler", "Shutter", "Material", "Shape", "Emission",
           "Light", "Texture", "Medium", "Volume", "look_at", "translate", "rotate", "scale", "GlrenderError",
           "SceneError", "ShaderError", "DeviceError", "UsageError", "ProgressCallback",
           "__version__"]
