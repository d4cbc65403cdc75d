"""``glrender compare``: two renders' error and efficiency against a reference, as heat maps,
a JSON record and a Markdown table (the numbers from :func:`glrender.lab.compare.compare_images`)."""
from __future__ import annotations

import json
from pathlib import Path

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


def run_compare_command(args) -> int:
    from ..film.io import read_image

    images = {}
    for key, path in (("a", args.a), ("b", args.b), ("ref", args.ref)):
        if not Path(path).is_file():
            raise UsageError(f"{path}: no such image")
        images[key] = read_image(path)
    if args.block < 1:
        raise UsageError(f"--block {args.block}: expected a positive block size")
    time_a = _time_of(args.time_a, args.stats_a, "a")
    time_b = _time_of(args.time_b, args.stats_b, "b")
    equal = time_a is None or time_b is None
    result = compare_images(images["a"], images["b"], images["ref"],
                            1.0 if equal else time_a, 1.0 if equal else time_b, args.block)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    heat_maps(result, out / "compare.png")
    summary = {k: v for k, v in result.items() if k != "maps"}
    summary.update({"a": str(args.a), "b": str(args.b), "ref": str(args.ref),
                    "times_given": not equal})
    (out / "compare.json").write_text(json.dumps(summary, indent=1) + "\n")
    note = "" if not equal else " (no times given: equal times assumed, so this is the MSE ratio)"
    (out / "compare.md").write_text(
        f"# {Path(args.a).name} vs {Path(args.b).name} (reference {Path(args.ref).name})\n\n"
        "| | A | B |\n|---|---|---|\n"
        f"| MSE | {result['mse']['a']:.4g} | {result['mse']['b']:.4g} |\n"
        f"| relative MSE | {result['relative_mse']['a']:.4g} | {result['relative_mse']['b']:.4g} |\n"
        f"| time (s) | {'–' if equal else f'{time_a:.4g}'} | {'–' if equal else f'{time_b:.4g}'} |\n\n"
        f"Efficiency ratio B/A = (MSE_A·t_A)/(MSE_B·t_B) = "
        f"{result['efficiency_ratio_b_over_a']:.4g}{note}.\n\n![heat maps](compare.png)\n")
    print(f"MSE A {result['mse']['a']:.4g}, B {result['mse']['b']:.4g}; efficiency B/A "
          f"{result['efficiency_ratio_b_over_a']:.4g}{note}")
    print(out.resolve() / "compare.md")
    return 0
