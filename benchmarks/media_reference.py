"""The media scenes' reference images, k independent seeds rendered for a fixed time each;
their mean is the reference and the spread between them its per-pixel standard error.
cornell-fog, volumetric-caustic and window-fog: Mitsuba 3's volpath (llvm_ad_rgb,
independent sampler; volpathmis where the scene's XML names it) on its Mitsuba XML.
smoke: glrender's path tracer (Sobol'), checked against Mitsuba's volpath by the parity
suite's grid case: Mitsuba takes about 1 s per sample per pixel on the smoke at 256x256 on
2 cores, so a reference of many times the benchmark's samples would take hours. Writes
benchmarks/refs/NAME-ref.npy, NAME-ref-stderr.npy and NAME-ref.json (renderer, spp,
seconds).

    .venv/bin/python benchmarks/media_reference.py [--seconds 90] [--seeds 4] [--scenes cornell-fog,smoke]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cornell_vs_mitsuba import GLRENDER_SCRIPT, LLVM, MITSUBA_SCRIPT, ROOT, run  # noqa: E402

OUT = ROOT / "benchmarks" / "refs"
SCENES = {name: ROOT / "scenes" / name / "scene.xml"
          for name in ("cornell-fog", "smoke", "volumetric-caustic", "window-fog")}
MITSUBA_REFERENCE = {"cornell-fog", "volumetric-caustic", "window-fog"}   # smoke: glrender's path tracer


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=90.0, help="render time per seed")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--scenes", default=",".join(SCENES))
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="glrender-media-ref-") as tmp:
        for name in args.scenes.split(","):
            xml = SCENES[name]
            # Mitsuba reads the scene's files (grids) beside it: render a copy there
            images, spps, version = [], [], None
            for seed in range(args.seeds):
                out = Path(tmp) / f"{name}-{seed}.npy"
                if name in MITSUBA_REFERENCE:
                    info = run([sys.executable, "-c", MITSUBA_SCRIPT, str(xml), "independent",
                                str(args.seconds), "16", str(1000 + seed), str(out)],
                               env={"DRJIT_LIBLLVM_PATH": LLVM}, cwd=xml.parent)
                else:
                    info = run([sys.executable, "-c", GLRENDER_SCRIPT, str(xml.with_suffix(".toml")),
                                "sobol", str(args.seconds), str(1000 + seed), str(out)])
                    info["version"] = "glrender path, " + info["device"]
                images.append(np.load(out).astype(np.float64))
                spps.append(info["spp"])
                version = info["version"]
                print(f"{name} seed {seed}: {info['spp']} spp", flush=True)
            stack = np.stack(images)
            np.save(OUT / f"{name}-ref.npy", stack.mean(axis=0).astype(np.float32))
            np.save(OUT / f"{name}-ref-stderr.npy",
                    (stack.std(axis=0, ddof=1) / np.sqrt(len(images))).astype(np.float32))
            (OUT / f"{name}-ref.json").write_text(json.dumps({
                "renderer": "Mitsuba 3 volpath (llvm_ad_rgb, independent)" if name in MITSUBA_REFERENCE
                else "glrender path (sobol)", "version": version, "seeds": len(images), "spp": spps,
                "seconds_per_seed": args.seconds}, indent=1) + "\n")


if __name__ == "__main__":
    main()
