"""What the render commands write besides the render itself: the image and its AOV side files,
the names of the denoised and of a partial image, and the statistics file."""
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


def check_checkpoint(args, path: Path) -> None:
    """Before any work: the checkpoint ``path`` can be written (and --stats), and a render
    without --resume does not replace one that is there unless --overwrite says so."""
    from ..errors import UsageError
    from ..film.io import check_writable
    from ..render.checkpoint import describe_checkpoint

    check_writable(path, "checkpoint", "--checkpoint" if args.checkpoint else None)
    if args.stats is not None:
        check_writable(args.stats, "statistics", "--stats")
    overwrite = getattr(args, "overwrite", False)
    if args.resume and overwrite:
        raise UsageError("--resume and --overwrite: give one (continue the checkpoint, or "
                         "replace it with a new render)")
    if not args.resume and not overwrite and path.exists():
        raise UsageError(f"{path}: {describe_checkpoint(path)} is there: continue it with "
                         f"--resume, or start afresh with --overwrite (which replaces it)")


def partial_path(output: Path) -> Path:
    """Where a stopped render writes its image when ``output`` already holds one:
    OUT-STEM.partial.EXT beside OUT.EXT (a partial image never replaces a complete one)."""
    return output.with_name(f"{output.stem}.partial{output.suffix}")


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
