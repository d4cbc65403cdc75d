"""glrender: a physically based renderer whose Monte Carlo core runs as GLSL compute shaders.

    import glrender
    scene = glrender.load("scenes/cornell-box/scene.toml")
    film = glrender.render(scene, spp=64, seed=1)
    film.mean        # (H, W, 3) linear RGB
    film.save("out.png")
"""
from __future__ import annotations

from .errors import DeviceError, GlrenderError, SceneError, ShaderError, UsageError
from .film import Film
from .render.renderer import Renderer, RenderSettings, settings_from_scene
from .scene import Scene, load

__version__ = "0.1.0"
__all__ = ["load", "render", "Renderer", "RenderSettings", "Film", "Scene", "GlrenderError",
           "SceneError", "ShaderError", "DeviceError", "UsageError"]


def render(scene, spp: int | None = None, *, integrator: str | None = None, seed: int | None = None,
           sampler: str | None = None, max_depth: int | None = None, strategy: str | None = None,
           aovs: bool = False, device=None, callback=None, **options) -> Film:
    """Render a scene (or a scene file path) and return its :class:`Film`.

    Arguments override the scene's own settings; ``callback(done, total)`` is called
    after every pass.
    """
    if not isinstance(scene, Scene):
        scene = load(scene)
    settings = settings_from_scene(scene, integrator=integrator, spp=spp, seed=seed, sampler=sampler,
                                   max_depth=max_depth, strategy=strategy, aovs=aovs, **options)
    renderer = Renderer(scene, settings, device=device)
    try:
        renderer.step(settings.sampler.spp, callback=callback)
        return renderer.film()
    finally:
        renderer.release()
