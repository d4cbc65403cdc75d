"""A user's script, type-checked with ``mypy --strict`` by test_typing.py (not run): every
public name used the way the documentation shows, so an untyped or Any-returning public
function fails the check here."""
from __future__ import annotations

import numpy as np

import glrender


def build() -> glrender.Scene:
    scene = glrender.Scene(camera=glrender.Camera(world_from_camera=glrender.look_at((0, 1, 5), (0, 0, 0), (0, 1, 0)),
                                                  fov=35.0),
                           film=glrender.FilmSettings(width=64, height=48),
                           integrator=glrender.Integrator(kind="path", max_depth=4),
                           sampler=glrender.Sampler(kind="independent", spp=4, seed=1))
    red = scene.add_material(glrender.Material("diffuse", reflectance=(0.8, 0.1, 0.1)))
    scene.shapes.append(glrender.Shape("sphere", material=red, radius=1.0))
    scene.shapes.append(glrender.Shape("rectangle", material=red,
                                       world_from_object=glrender.translate((0, 3, 0))
                                       @ glrender.rotate((1, 0, 0), 90) @ glrender.scale(2),
                                       emission=glrender.Emission(radiance=(5.0, 5.0, 5.0))))
    scene.lights.append(glrender.Light("constant", radiance=(0.1, 0.1, 0.1)))
    return scene


def use(path: str) -> float:
    scene = glrender.load(path, spp=4)
    film: glrender.Film = glrender.render(scene, spp=4, time=1.0, integrator="path", seed=3,
                                          device="auto", progress=lambda spp, s: None)
    mean: np.ndarray = film.mean
    noise: np.ndarray = film.stderr + film.variance + film.aov("variance")
    film.save("out.exr", half=True)
    png: bytes = film._repr_png_()
    with glrender.Renderer(build(), spp=8) as renderer:
        added: int = renderer.step(8, callback=lambda done, total: None)
        renderer.set_camera(glrender.Camera(fov=20.0))
        image: glrender.Image = renderer.image()
        state = renderer.state()
        renderer.restore(state)
        renderer.reset()
    try:
        glrender.render(build(), spp=0)
    except glrender.UsageError as exc:
        print(exc, glrender.GlrenderError.exit_code)
    settings: glrender.RenderSettings = glrender.settings_from_scene(scene, spp=2)
    return float(mean.mean() + noise.mean() + len(png) + added + image.spp + settings.sampler.spp)
