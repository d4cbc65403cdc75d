"""Render a scene file from Python and save the image.

    python examples/render_file.py scenes/cornell-box/scene.toml -o cornell.png --spp 64

Any format glrender loads works (.toml, Mitsuba .xml, .gltf/.glb, .obj, .ply); the output
format follows the extension of -o (.png, .jpg, .exr, .pfm, .hdr, .npy).
"""
from __future__ import annotations

import argparse

import glrender


def main(argv: list[str] | None = None) -> glrender.Film:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="scene file")
    parser.add_argument("-o", "--output", default="render.png", help="image file to write")
    parser.add_argument("--spp", type=int, default=None, help="samples per pixel")
    parser.add_argument("--width", type=int, default=None, help="image width in pixels")
    parser.add_argument("--height", type=int, default=None, help="image height in pixels")
    args = parser.parse_args(argv)

    scene = glrender.load(args.scene)
    # another size of the same view: one of --width/--height keeps the aspect ratio
    scene.film = scene.film.resized(args.width, args.height)
    film = glrender.render(scene, spp=args.spp, seed=1)
    film.save(args.output)

    stats = film.stats
    print(f"{args.scene}: {film.shape[1]}x{film.shape[0]}, {film.spp} spp in "
          f"{stats['seconds']['render']:.2f} s on {stats['device']}")
    print(f"mean radiance (linear RGB): {film.mean.reshape(-1, 3).mean(0).round(4)}")
    print(f"mean standard error per pixel: {float(film.stderr.mean()):.4g} (an upper bound "
          f"for the {film.sampler} sampler)")
    print(f"image -> {args.output}")
    return film


if __name__ == "__main__":
    main()
