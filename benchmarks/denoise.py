"""Denoising with Open Image Denoise: time per megapixel and MSE against the reference
before and after, at 1, 4, 16 and 64 spp, on the Cornell box (Mitsuba 3's 49,152-spp
reference) and the textured Cornell box of tests/denoise (glrender's 4,096-spp reference).

The denoised image is ``glrender render --denoise``'s: OIDN filters the beauty minus its
emission AOV and the seen-emission pass (glrender.render.emission_pass.render_seen_emission) is added
back; "own emission" adds back the beauty's own emission AOV instead (no pass), for
comparison. MSE is over the whole linear image and over the pixels whose footprint does
not reach the light (tests/denoise/denoise_scenes.away_from_light: the light's pixels,
18x brighter than any lit surface, and the ring of pixels it covers in part; 1.4% of the
Cornell box). Times: OIDN on its CPU device with all cores and the emission pass (its
renderer's set-up included), best of ``--repeats`` runs, the first (OIDN's network
set-up, the pass's kernel compile) excluded; the render's own time for scale.
The renderer's samples/s while OIDN runs in a background thread (the preview's set-up:
one OIDN thread) against samples/s alone measure how much denoising takes from llvmpipe.
Writes the "## Denoising" section of benchmarks/RESULTS.md (other sections are kept).

    .venv/bin/python benchmarks/denoise.py [--repeats 3] [--no-write]
    .venv/bin/python benchmarks/denoise.py --make-reference   # tests/data/refs/textured-cornell-ref.*
"""
from __future__ import annotations

import argparse
import datetime
import json
import re
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "denoise"))

import glrender  # noqa: E402
from denoise_scenes import REFS, away_from_light, cornell, reference, textured_cornell  # noqa: E402
from glrender.denoise import Denoiser, aovs_are_clean
from glrender.render.emission_pass import render_seen_emission  # noqa: E402
from glrender.render.renderer import Renderer, settings_from_scene  # noqa: E402

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
SECTION = "## Denoising"
SPPS = (1, 4, 16, 64)
SEED = 11
REF_SPP, REF_SEED = 4096, 1_000_003


def make_reference() -> None:
    """The textured Cornell box at REF_SPP (Sobol'), with the per-pixel standard error from
    four independent quarter renders."""
    scene = textured_cornell()
    t0 = time.perf_counter()
    quarters = [glrender.render(scene, spp=REF_SPP // 4, seed=REF_SEED + i).mean for i in range(4)]
    seconds = time.perf_counter() - t0
    stack = np.stack(quarters)
    mean = stack.mean(0).astype(np.float32)
    stderr = (stack.std(0, ddof=1) / 2.0).astype(np.float32)
    np.save(REFS / "textured-cornell-ref.npy", mean)
    meta = {"scene": "tests/denoise/denoise_scenes.py::textured_cornell", "renderer": "glrender",
            "spp": REF_SPP, "sampler": "sobol", "seeds": [REF_SEED + i for i in range(4)],
            "note": "mean of 4 independent randomizations of spp/4 each",
            "shape": list(mean.shape), "dtype": "float32, linear RGB, top row first",
            "reference_mse_estimate": float(np.mean(stderr ** 2)),
            "render_seconds": round(seconds, 1), "benchmark": "benchmarks/denoise.py --make-reference"}
    (REFS / "textured-cornell-ref.json").write_text(json.dumps(meta, indent=1) + "\n")
    print(json.dumps(meta, indent=1))


def mse(a, b, mask=None) -> float:
    e = (np.asarray(a, np.float64) - b) ** 2
    return float(e[mask].mean() if mask is not None else e.mean())


def quality_rows(name, scene, ref, denoiser, repeats) -> list[str]:
    clean = aovs_are_clean(scene)
    lit = away_from_light(ref)
    rows = []
    for spp in SPPS:
        film = glrender.render(scene, spp=spp, seed=SEED, aovs=True)
        settings = settings_from_scene(scene, spp=spp, seed=SEED)
        times, pass_times = [], []
        for _ in range(repeats + 1):
            t0 = time.perf_counter()
            seen = render_seen_emission(scene, settings)
            t1 = time.perf_counter()
            out = denoiser.denoise_film(film, clean_aux=clean, seen_emission=seen.mean)
            times.append(time.perf_counter() - t1)
            pass_times.append(t1 - t0)
        own = denoiser.denoise_film(film, clean_aux=clean)
        mpix = film.mean.shape[0] * film.mean.shape[1] / 1e6
        noisy, den = mse(film.mean, ref), mse(out, ref)
        noisy_lit, den_lit = mse(film.mean, ref, lit), mse(out, ref, lit)
        rows.append(f"| {name} | {spp} | {film.stats['seconds']['render']:.2f} | "
                    f"{seen.spp} / {min(pass_times[1:]):.2f} | {min(times[1:]) / mpix:.2f} | "
                    f"{noisy:.3g} | {den:.3g} | **{noisy / den:.1f}** | {noisy / mse(own, ref):.2f} | "
                    f"{noisy_lit:.3g} | {den_lit:.3g} | {noisy_lit / den_lit:.1f} |")
        print(rows[-1], flush=True)
    return rows


def contention(seconds: float = 4.0) -> tuple[float, float]:
    """Cornell box samples/s with nothing else running, and with one OIDN thread
    denoising 256x256 images back to back in a background thread."""
    scene = cornell()
    film = glrender.render(scene, spp=4, seed=SEED, aovs=True)
    settings = settings_from_scene(scene, spp=1 << 20, seed=SEED)
    r = Renderer(scene, settings)
    r.step(8)

    def rate() -> float:
        start, t0 = r.spp_done, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            r.step(8)
        return (r.spp_done - start) * r.width * r.height / (time.perf_counter() - t0)

    alone = rate()
    stop = threading.Event()
    with Denoiser(threads=1) as d:
        def loop():
            while not stop.is_set():
                d.denoise_film(film)
        worker = threading.Thread(target=loop)
        worker.start()
        try:
            shared = rate()
        finally:
            stop.set()
            worker.join()
    r.release()
    return alone, shared


def write_section(text: str) -> None:
    """Replace this script's section of RESULTS.md (up to the next "## " heading), or
    append it."""
    old = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    section = re.compile(rf"^{re.escape(SECTION)}\n.*?(?=^## |\Z)", re.S | re.M)
    body = text.rstrip("\n") + "\n\n"
    new = section.sub(lambda _: body, old, count=1) if section.search(old) else \
        old.rstrip("\n") + "\n\n" + body
    RESULTS.write_text(new.rstrip("\n") + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    ap.add_argument("--make-reference", action="store_true",
                    help="render tests/data/refs/textured-cornell-ref.* and stop")
    args = ap.parse_args()
    if args.make_reference:
        make_reference()
        return
    with Denoiser() as d:
        device = f"OIDN {d.device_name} device, {d.threads} threads, quality {d.quality}"
        rows = quality_rows("Cornell box 256x256", cornell(), reference("cornell-box"), d,
                            args.repeats)
        rows += quality_rows("textured Cornell 128x128", textured_cornell(),
                             reference("textured-cornell"), d, args.repeats)
    alone, shared = contention()
    from glrender.gl.context import default_context

    gl = default_context().gl.info["GL_RENDERER"]
    text = "\n".join([
        SECTION, "",
        f"`benchmarks/denoise.py`, {datetime.date.today()}, {gl}; {device}. "
        f"Seed {SEED}, Sobol'; cleanAux as `aovs_are_clean` decides (on for both scenes). "
        "MSE in linear radiance against the reference, over the whole image; ratio = noisy / "
        "denoised; \"own emission\": the ratio when the beauty's own emission AOV is added "
        "back instead of the emission pass; \"lit\" leaves out the pixels whose footprint "
        "reaches the light (the light and a one-pixel ring). Render and pass times on the "
        "shared machine are rough.", "",
        "| scene | spp | render s | emission pass spp / s | OIDN s/Mpixel | MSE noisy "
        "| MSE denoised | ratio | ratio, own emission | lit MSE noisy | lit MSE denoised "
        "| lit ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        *rows, "",
        f"Renderer throughput (Cornell box, 8 spp passes) alone: {alone / 1e6:.2f} Msamples/s; "
        f"with one OIDN thread denoising back to back beside it: {shared / 1e6:.2f} Msamples/s "
        f"({shared / alone:.2f}x).",
    ])
    print(text)
    if not args.no_write:
        write_section(text)


if __name__ == "__main__":
    main()
