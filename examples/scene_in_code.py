"""Build a scene in code (Mitsuba 3's Cornell box) and sweep a parameter: the roughness of
a metal tall box. Renders one image per value and writes them side by side, left to right
in the order given, as one image (-o).

    python examples/scene_in_code.py -o sweep.png --spp 32 --size 128
"""
from __future__ import annotations

import argparse

import numpy as np

import glrender


def matrix(*rows: float) -> np.ndarray:
    """A 4x4 world_from_object matrix from its 16 entries, row by row."""
    return np.array(rows, np.float64).reshape(4, 4)


def cornell_box(size: int = 256, spp: int = 64) -> glrender.Scene:
    """The Cornell box of Mitsuba 3 (``mitsuba.cornell_box()``), the scene of
    scenes/cornell-box/scene.toml: unit rectangles and cubes placed by matrices, a
    one-sided area light under the ceiling. Lengths in scene units, radiance in
    W/(m^2 sr) per linear RGB channel."""
    scene = glrender.Scene(
        camera=glrender.Camera(
            world_from_camera=matrix(-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1, 3.9, 0, 0, 0, 1),
            fov=39.3077, fov_axis="smaller", near_clip=0.001, far_clip=100.0),
        film=glrender.FilmSettings(width=size, height=size, filter="box"),
        integrator=glrender.Integrator(kind="path", max_depth=8),
        sampler=glrender.Sampler(kind="sobol", spp=spp))
    white = scene.add_material(glrender.Material("diffuse", reflectance=(0.885809, 0.698859, 0.666422)))
    green = scene.add_material(glrender.Material("diffuse", reflectance=(0.105421, 0.37798, 0.076425)))
    red = scene.add_material(glrender.Material("diffuse", reflectance=(0.570068, 0.0430135, 0.0443706)))

    def rectangle(name: str, material: int, m: np.ndarray, **kw: object) -> None:
        scene.shapes.append(glrender.Shape("rectangle", material=material, world_from_object=m,
                                           name=name, **kw))  # type: ignore[arg-type]

    rectangle("light", white, matrix(0.23, 0, 0, 0, 0, 0, -0.19, 0.99, 0, 0.19, 0, 0.01, 0, 0, 0, 1),
              emission=glrender.Emission(radiance=(18.387, 13.9873, 6.75357)))
    rectangle("floor", white, matrix(1, 0, 0, 0, 0, 0, 1, -1, 0, -1, 0, 0, 0, 0, 0, 1))
    rectangle("ceiling", white, matrix(1, 0, 0, 0, 0, 0, -1, 1, 0, 1, 0, 0, 0, 0, 0, 1))
    rectangle("back", white, glrender.translate((0, 0, -1)))
    rectangle("green wall", green, matrix(0, 0, -1, 1, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1))
    rectangle("red wall", red, matrix(0, 0, 1, -1, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1))
    scene.shapes.append(glrender.Shape("cube", material=white, name="small box", world_from_object=matrix(
        0.28689146041870117, 0, -0.08771151304244995, 0.33500000834465027,
        0, 0.30000001192092896, 0, -0.699999988079071,
        0.08771151304244995, 0, 0.28689146041870117, 0.3799999952316284, 0, 0, 0, 1)))
    scene.shapes.append(glrender.Shape("cube", material=white, name="large box", world_from_object=matrix(
        0.28490975499153137, 0, 0.09394913911819458, -0.33000001311302185,
        0, 0.6100000143051147, 0, -0.4000000059604645,
        -0.09394913911819458, 0, 0.28490975499153137, -0.2800000011920929, 0, 0, 0, 1)))
    return scene


def main(argv: list[str] | None = None) -> list[glrender.Film]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="sweep.png",
                        help="the one image written: every value's image side by side")
    parser.add_argument("--spp", type=int, default=32, help="samples per pixel")
    parser.add_argument("--size", type=int, default=128, help="image width and height in pixels")
    parser.add_argument("--alphas", type=float, nargs="+", default=[0.02, 0.1, 0.3],
                        help="GGX roughness values of the tall box")
    args = parser.parse_args(argv)

    scene = cornell_box(args.size, args.spp)
    tall = next(s for s in scene.shapes if s.name == "large box")
    films = []
    for alpha in args.alphas:
        # edit the scene in place: a new material for the tall box, then render again
        tall.material = scene.add_material(glrender.Material(
            "roughconductor", eta=(0.2, 0.92, 1.1), k=(3.9, 2.45, 2.14), alpha=(alpha, alpha),
            distribution="ggx", name=f"gold {alpha}"))
        film = glrender.render(scene, seed=1, progress=False)
        films.append(film)
        print(f"alpha {alpha:g}: mean radiance {film.mean.mean():.4f}, "
              f"{film.stats['samples_per_second'] / 1e6:.2f} Msamples/s")
    strip = np.concatenate([f.mean for f in films], axis=1)
    from glrender.film import write_image

    write_image(args.output, strip)
    print(f"{len(films)} images side by side -> {args.output}")
    return films


if __name__ == "__main__":
    main()
