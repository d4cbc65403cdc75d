"""The reference of benchmarks/many_lights.py, checked against Mitsuba 3.

The reference is glrender's path tracer with power selection on scenes/many-lights/scene.toml
at the benchmark's size, k independent seeds for a fixed time each: their mean is the
reference and the spread between them its per-pixel standard error. It is glrender's because
Mitsuba's path tracer (llvm_ad_rgb, emitters by power) draws about 6 samples per pixel per
second there on 2 cores against glrender's 75, for about the same error per sample: a
Mitsuba reference whose noise is under a tenth of the benchmark's best MSE would take hours.
Mitsuba checks it instead: its renders of the XML twin (k seeds, emitters picked in
proportion to glrender's power weights) must agree with the reference within their noise,
on the image mean and on every block of 10 x 10 pixels (a Sidak-corrected threshold over the
blocks and channels); the check's figures go into the JSON, and a failed check stops the
script before it writes anything.

Writes benchmarks/refs/many-lights-ref.npy, many-lights-ref-stderr.npy and
many-lights-ref.json (renderer, spp, seconds, the check against Mitsuba).

    .venv/bin/python benchmarks/many_lights_reference.py [--seconds 300] [--mitsuba-seconds 150] [--seeds 4]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from statistics import NormalDist

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cornell_vs_mitsuba import LLVM, run  # noqa: E402
from many_lights import (GLRENDER_SCRIPT, HEIGHT, MITSUBA_SCRIPT, REFERENCE, SCENE, WIDTH, XML,  # noqa: E402
                         mitsuba_weights)

BLOCK = 10


def renders(commands, seeds: int, tmp: Path, name: str) -> tuple[np.ndarray, np.ndarray, list, dict]:
    """(mean, per-pixel standard error of the mean, spp per seed, the last run's JSON) of
    ``seeds`` runs of ``commands`` (a command that takes SEED OUT)."""
    images, spps, info = [], [], {}
    for seed in range(seeds):
        out = tmp / f"{name}-{seed}.npy"
        cmd, env = commands
        info = run(cmd + [str(1000 + seed), str(out)], env=env, cwd=XML.parent)
        images.append(np.load(out).astype(np.float64)[..., :3])
        spps.append(info["spp"])
        print(f"{name} seed {seed}: {info['spp']} spp", flush=True)
    stack = np.stack(images)
    return stack.mean(axis=0), stack.std(axis=0, ddof=1) / np.sqrt(seeds), spps, info


def agreement(a, a_se, b, b_se) -> dict:
    """Image means and 10 x 10-pixel block means of two estimates with their per-pixel
    standard errors (independent pixels): the relative difference of the means with its
    standard error, the largest block |z| and the Sidak threshold it must stay under
    (alpha 0.01 over the blocks and channels)."""
    h, w = a.shape[0] // BLOCK * BLOCK, a.shape[1] // BLOCK * BLOCK

    def blocks(x):
        return x[:h, :w].reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, 3).mean(axis=(1, 3))

    def block_se(se):
        return np.sqrt(blocks(se ** 2) / BLOCK ** 2)

    # blocks without noise (the sky's) agree to a few float32 ulps
    z = (blocks(a) - blocks(b)) / np.maximum(np.sqrt(block_se(a_se) ** 2 + block_se(b_se) ** 2),
                                             1e-5 * np.abs(blocks(b)) + 1e-30)
    threshold = NormalDist().inv_cdf(1 - 0.01 / (2 * z.size))
    mean_se = np.sqrt((a_se ** 2).sum() + (b_se ** 2).sum()) / a.size
    return {"mean_difference": float(a.mean() / b.mean() - 1), "mean_difference_stderr": float(mean_se / b.mean()),
            "max_block_z": float(np.abs(z).max()), "block_z_threshold": threshold, "blocks": int(z.size)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=300.0, help="glrender's render time per seed")
    ap.add_argument("--mitsuba-seconds", type=float, default=150.0, help="Mitsuba's render time per seed")
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="glrender-many-lights-ref-") as tmp:
        tmp = Path(tmp)
        weights = tmp / "weights.npy"
        np.save(weights, mitsuba_weights(XML))
        ref, ref_se, spp, info = renders(
            ([sys.executable, "-c", GLRENDER_SCRIPT, str(SCENE), "power", str(WIDTH), str(HEIGHT),
              str(args.seconds)], {}), args.seeds, tmp, "glrender")
        mi, mi_se, mi_spp, mi_info = renders(
            ([sys.executable, "-c", MITSUBA_SCRIPT, str(XML), str(weights), str(WIDTH), str(HEIGHT),
              str(args.mitsuba_seconds)], {"DRJIT_LIBLLVM_PATH": LLVM}), args.seeds, tmp, "mitsuba")
    check = agreement(ref, ref_se, mi, mi_se)
    print(json.dumps(check), flush=True)
    if check["max_block_z"] > check["block_z_threshold"] or \
            abs(check["mean_difference"]) > 4 * check["mean_difference_stderr"]:
        raise SystemExit("glrender and Mitsuba disagree on scenes/many-lights: no reference written")
    REFERENCE.parent.mkdir(parents=True, exist_ok=True)
    np.save(REFERENCE, ref.astype(np.float32))
    np.save(REFERENCE.with_name("many-lights-ref-stderr.npy"), ref_se.astype(np.float32))
    REFERENCE.with_suffix(".json").write_text(json.dumps({
        "renderer": "glrender path (power selection, sobol)", "device": info["device"], "width": WIDTH,
        "height": HEIGHT, "seeds": args.seeds, "spp": spp, "seconds_per_seed": args.seconds,
        "check": {"renderer": f"Mitsuba {mi_info['version']} path (llvm_ad_rgb, independent, emitters by "
                              f"power)", "spp": mi_spp, "seconds_per_seed": args.mitsuba_seconds, **check}},
        indent=1) + "\n")


if __name__ == "__main__":
    main()
