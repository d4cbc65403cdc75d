"""Compare two ways of computing the same image by their Monte Carlo efficiency.

Global illumination of the Cornell box two ways with the ``path`` integrator: next-event
estimation with multiple importance sampling (a light sample and a BSDF sample per hit,
power heuristic) against BSDF sampling alone (paths score only when they hit the light).
Both estimate the same image; the better one is the one with less variance per second of
rendering:

    efficiency = 1 / (mean pixel variance of the estimate x render seconds)

The independent sampler makes ``film.stderr`` an exact standard error, so the variances
are unbiased estimates and the two images' difference can be checked against them.

    python examples/compare_integrators.py --spp 64 --size 96
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

import glrender


@dataclass
class Result:
    name: str
    film: glrender.Film
    variance: float      # mean over pixels and channels of the pixel estimate's variance
    seconds: float       # render seconds (setup and compilation excluded)

    @property
    def efficiency(self) -> float:
        return 1.0 / (self.variance * self.seconds)


def measure(scene: glrender.Scene, name: str, spp: int, seed: int, **options: object) -> Result:
    film = glrender.render(scene, spp=spp, sampler="independent", seed=seed, progress=False,
                           **options)  # type: ignore[arg-type]
    return Result(name, film, float(np.mean(film.stderr.astype(np.float64) ** 2)),
                  float(film.stats["seconds"]["render"]))


def main(argv: list[str] | None = None) -> tuple[Result, Result]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="scenes/cornell-box/scene.toml")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel of each render")
    parser.add_argument("--size", type=int, default=96, help="image width and height in pixels")
    args = parser.parse_args(argv)

    scene = glrender.load(args.scene)
    scene.film.width = scene.film.height = args.size
    a = measure(scene, "NEE + MIS", args.spp, 1, integrator="path", strategy="mis-power")
    b = measure(scene, "BSDF sampling", args.spp, 2, integrator="path", strategy="bsdf")
    for r in (a, b):
        print(f"{r.name:>20}: variance {r.variance:.4g}, {r.seconds:.3f} s, "
              f"efficiency {r.efficiency:.4g}")
    # same estimand (independent seeds): the images' means differ by about their standard error
    n = a.film.mean.size
    diff = float(np.mean(a.film.mean.astype(np.float64) - b.film.mean))
    z = diff / math.sqrt((a.variance + b.variance) / n)
    print(f"image means differ by {diff:.3g} ({z:+.2f} standard errors)")
    print(f"efficiency ratio {a.name} / {b.name}: {a.efficiency / b.efficiency:.2f}")
    return a, b


if __name__ == "__main__":
    main()
