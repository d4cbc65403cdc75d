"""Render the Mitsuba 3 references of the parity suite (tests/parity).

For every scene of tests/parity/catalog.toml (or the NAMES given) Mitsuba 3 renders
tests/parity/scenes/NAME.xml in ``ref_passes`` independent passes of ``ref_spp``
samples per pixel (pass i uses seed 1000 + i: each pass is a full, independent
randomization of the scene's sampler), and this script writes

    tests/parity/refs/NAME.npy          the mean over the passes, (H, W, 3) float32 linear RGB
    tests/parity/refs/NAME-stderr.npy   its per-pixel standard error: std over passes / sqrt(passes)

and records in tests/parity/refs/manifest.json the Mitsuba and Dr.Jit versions, the
variant, the sampler, the spp and passes and the render time of each reference. The
test suite reads only these files: it does not need Mitsuba.

The variant is ``llvm_ad_rgb`` when Dr.Jit finds an LLVM (Debian 12's LLVM 15 crashes it:
install ``libllvm19``; DRJIT_LIBLLVM_PATH defaults to its library), else ``scalar_rgb``
(the same images, about 3x slower).

    .venv/bin/python tools/make_parity_refs.py                 # every scene
    .venv/bin/python tools/make_parity_refs.py light-spot ...  # some scenes
    .venv/bin/python tools/make_parity_refs.py --quick --preview DIR   # 1/16 of the passes,
                                                   # PNGs of Mitsuba | glrender, refs untouched
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PARITY = ROOT / "tests" / "parity"
SCENES = PARITY / "scenes"
REFS = PARITY / "refs"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
FIRST_SEED = 1000


def load_catalog() -> tuple[dict, dict]:
    try:
        import tomllib
    except ModuleNotFoundError:          # Python 3.10
        import tomli as tomllib
    data = tomllib.loads((PARITY / "catalog.toml").read_text())
    return data["defaults"], data["scenes"]


def mitsuba(variant: str | None):
    """Import Mitsuba with the fastest variant that works here."""
    if os.path.exists(LLVM):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    import mitsuba as mi

    for name in ([variant] if variant else ["llvm_ad_rgb", "scalar_rgb"]):
        try:
            mi.set_variant(name)
            mi.load_dict({"type": "scene"})
            return mi
        except Exception as exc:            # no LLVM found: the next variant
            print(f"variant {name} unavailable ({exc})", file=sys.stderr)
    raise SystemExit("no usable Mitsuba variant")


def render_reference(mi, name: str, spp: int, passes: int) -> tuple[np.ndarray, np.ndarray, dict]:
    scene = mi.load_file(str(SCENES / f"{name}.xml"))
    sensor = scene.sensors()[0]
    mi.render(scene, spp=1, seed=2 ** 31 - 1)                 # compiles the kernels; discarded
    t0 = time.perf_counter()
    total = None
    total2 = None
    for i in range(passes):
        img = np.asarray(mi.render(scene, spp=spp, seed=FIRST_SEED + i), np.float64)[..., :3]
        total = img if total is None else total + img
        total2 = img * img if total2 is None else total2 + img * img
    seconds = time.perf_counter() - t0
    mean = total / passes
    var = np.maximum(total2 / passes - mean * mean, 0.0) * passes / (passes - 1)
    stderr = np.sqrt(var / passes)
    info = {
        "spp_per_pass": spp,
        "passes": passes,
        "seeds": f"{FIRST_SEED} .. {FIRST_SEED + passes - 1}",
        "sampler": sensor.sampler().class_name(),
        "shape": list(mean.shape),
        "mean": float(mean.mean()),
        "mean_relative_stderr": float(np.sqrt((stderr ** 2).sum()) / mean.size / max(mean.mean(), 1e-30)),
        "render_seconds": round(seconds, 1),
    }
    return mean.astype(np.float32), stderr.astype(np.float32), info


def preview(folder: Path, name: str, mean: np.ndarray, spp: int) -> None:
    """mitsuba | glrender side by side, 4x enlarged, clamped sRGB."""
    import glrender
    from glrender.film.io import linear_to_srgb
    from PIL import Image

    ours = glrender.render(glrender.load(SCENES / f"{name}.xml"), spp=spp, seed=1, sampler="sobol").mean
    both = np.concatenate([mean, np.zeros((mean.shape[0], 2, 3)), ours], axis=1)
    img = (linear_to_srgb(np.clip(both, 0, 1)) * 255 + 0.5).astype(np.uint8)
    Image.fromarray(img).resize((img.shape[1] * 4, img.shape[0] * 4), Image.NEAREST).save(folder / f"{name}.png")
    print(f"  preview: mean mitsuba {mean.mean():.5g} glrender {ours.mean():.5g}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="scenes to render (default: all in catalog.toml)")
    ap.add_argument("--variant", help="Mitsuba variant (default: llvm_ad_rgb, else scalar_rgb)")
    ap.add_argument("--quick", action="store_true", help="1/16 of the passes, refs not written")
    ap.add_argument("--preview", type=Path, help="write mitsuba | glrender PNGs into this folder")
    args = ap.parse_args(argv)

    defaults, scenes = load_catalog()
    # a case that names another's `scene` uses that scene's reference
    names = args.names or sorted(n for n in scenes if "scene" not in scenes[n])
    unknown = [n for n in names if n not in scenes]
    if unknown:
        raise SystemExit(f"not in catalog.toml: {', '.join(unknown)}")
    borrowed = [n for n in names if "scene" in scenes[n]]
    if borrowed:
        raise SystemExit(f"these use another scene's reference (catalog key `scene`): {', '.join(borrowed)}")
    mi = mitsuba(args.variant)
    manifest_path = REFS / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {"scenes": {}}
    if args.preview:
        args.preview.mkdir(parents=True, exist_ok=True)
    for name in names:
        entry = {**defaults, **scenes[name]}
        passes = max(2, entry["ref_passes"] // 16) if args.quick else entry["ref_passes"]
        print(f"{name}: {passes} passes x {entry['ref_spp']} spp ({mi.variant()})", flush=True)
        mean, stderr, info = render_reference(mi, name, entry["ref_spp"], passes)
        print(f"  mean {info['mean']:.6g}, relative stderr of the mean {info['mean_relative_stderr']:.2e}, "
              f"{info['render_seconds']} s", flush=True)
        if args.preview:
            preview(args.preview, name, mean, entry["spp"] * entry["seeds"])
        if args.quick:
            continue
        REFS.mkdir(parents=True, exist_ok=True)
        np.save(REFS / f"{name}.npy", mean)
        np.save(REFS / f"{name}-stderr.npy", stderr)
        manifest["renderer"] = {"mitsuba": mi.__version__, "drjit": __import__("drjit").__version__,
                                "variant": mi.variant()}
        manifest["scenes"][name] = {**info, "mitsuba": mi.__version__, "variant": mi.variant(),
                                    "date": datetime.date.today().isoformat()}
        manifest["scenes"] = dict(sorted(manifest["scenes"].items()))
        manifest_path.write_text(json.dumps(manifest, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
