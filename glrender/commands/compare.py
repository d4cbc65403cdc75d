"""``glrender compare``: two renders' error and efficiency against a reference, as heat maps,
a JSON record and a Markdown table (the numbers from :func:`glrender.lab.compare.compare_images`)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..lab.compare import compare_images, heat_maps


def _time_of(explicit, stats_path, name: str) -> float | None:
    if explicit is not None:
        return float(explicit)
    if stats_path is None:
        return None
    try:
        stats = json.loads(Path(stats_path).read_text())
        return float(stats["seconds"]["render"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise UsageError(f"--stats-{name} {stats_path}: cannot read the render seconds ({exc})") from exc


def _read(path, name: str) -> np.ndarray:
    """The image ``path`` (A, B or R) as linear RGB, or one line saying it is not one."""
    import struct
    import zlib

    import png
    from PIL import Image

    from ..film.io import read_image

    if not Path(path).is_file():
        raise UsageError(f"{path}: no such image")
    try:
        image = read_image(path)
    except UsageError:
        raise
    except (OSError, ValueError, EOFError, SyntaxError, RuntimeError, struct.error, zlib.error,
            png.Error, Image.DecompressionBombError) as exc:   # what the decoders raise
        why = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:120]
        raise UsageError(f"{path}: {name} is not a readable image ({why}); expected EXR, PFM, "
                         f"HDR, NPY or PNG") from None
    image = np.asarray(image)
    if image.dtype.kind not in "fiub" or image.ndim not in (2, 3) or image.size == 0 or \
            (image.ndim == 3 and not 1 <= image.shape[2] <= 4):
        raise UsageError(f"{path}: {name} holds an array of shape {image.shape}, expected "
                         f"an image (height, width[, channels])")
    return image


def run_compare_command(args) -> int:
    from ..film.io import atomic_write, check_writable

    images = {key: _read(path, name) for key, path, name in
              (("a", args.a, "A"), ("b", args.b, "B"), ("ref", args.ref, "the reference"))}
    if args.block < 1:
        raise UsageError(f"--block {args.block}: expected a positive block size")
    time_a = _time_of(args.time_a, args.stats_a, "a")
    time_b = _time_of(args.time_b, args.stats_b, "b")
    equal = time_a is None or time_b is None
    out = check_writable(args.out, "comparison", "--out", folder=True)
    result = compare_images(images["a"], images["b"], images["ref"],
                            1.0 if equal else time_a, 1.0 if equal else time_b, args.block)
    atomic_write(out / "compare.png", lambda tmp: heat_maps(result, tmp))
    summary = {k: v for k, v in result.items() if k != "maps"}
    summary.update({"a": str(args.a), "b": str(args.b), "ref": str(args.ref),
                    "times_given": not equal})
    atomic_write(out / "compare.json",
                 lambda tmp: tmp.write_text(json.dumps(summary, indent=1) + "\n"))
    note = "" if not equal else " (no times given: equal times assumed, so this is the MSE ratio)"
    atomic_write(out / "compare.md", lambda tmp: tmp.write_text(
        f"# {Path(args.a).name} vs {Path(args.b).name} (reference {Path(args.ref).name})\n\n"
        "| | A | B |\n|---|---|---|\n"
        f"| MSE | {result['mse']['a']:.4g} | {result['mse']['b']:.4g} |\n"
        f"| relative MSE | {result['relative_mse']['a']:.4g} | {result['relative_mse']['b']:.4g} |\n"
        f"| time (s) | {'–' if equal else f'{time_a:.4g}'} | {'–' if equal else f'{time_b:.4g}'} |\n\n"
        f"Efficiency ratio B/A = (MSE_A·t_A)/(MSE_B·t_B) = "
        f"{result['efficiency_ratio_b_over_a']:.4g}{note}.\n\n![heat maps](compare.png)\n"))
    print(f"MSE A {result['mse']['a']:.4g}, B {result['mse']['b']:.4g}; efficiency B/A "
          f"{result['efficiency_ratio_b_over_a']:.4g}{note}")
    print(out.resolve() / "compare.md")
    return 0
