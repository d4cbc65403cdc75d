"""What the render commands write besides the render itself: the image and its AOV side files,
the denoised image's name, and the statistics file."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def aov_sidecar(output: Path, name: str) -> Path:
    ext = ".npy" if output.suffix.lower() == ".npy" else ".pfm"
    return output.with_name(f"{output.stem}.{name}{ext}")


def denoised_path(output: Path) -> Path:
    """Where --denoise writes the denoised image: OUT.denoised.EXT beside OUT.EXT."""
    return output.with_name(f"{output.stem}.denoised{output.suffix}")


def write_outputs(film, output: Path, aov_names: list[str], args,
                   denoised: np.ndarray | None = None) -> list[str]:
    from ..film.io import write_image

    written = [str(output)]
    if output.suffix.lower() == ".exr":
        layers = {name: film.aov(name) for name in aov_names if name != "variance"}
        layers["variance"] = film.variance
        if denoised is not None:
            layers["denoised"] = denoised
        write_image(output, film.mean, aovs=layers, half=args.half)
        if denoised is not None:
            write_image(denoised_path(output), denoised, half=args.half)
            written.append(str(denoised_path(output)))
        return written
    write_image(output, film.mean, exposure=args.exposure, curve=args.tonemap, srgb=args.srgb)
    if denoised is not None:
        write_image(denoised_path(output), denoised, exposure=args.exposure, curve=args.tonemap,
                    srgb=args.srgb)
        written.append(str(denoised_path(output)))
    for name in aov_names:
        side = aov_sidecar(output, name)
        write_image(side, film.aov(name))
        written.append(str(side))
    return written


def write_stats(path: Path, stats: dict) -> None:
    from ..film.io import atomic_write

    def write(tmp: Path) -> None:
        tmp.write_text(json.dumps(stats, indent=2) + "\n")

    atomic_write(path, write)
