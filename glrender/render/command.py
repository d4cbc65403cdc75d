"""The ``glrender render`` command: options -> scene, renderer, run, outputs, checkpoint, stats.

Everything a user can get wrong is checked before the render starts (output format and
folder, scene file, option values, memory), so a mistake costs no render time.
"""
from __future__ import annotations

import json
import math
import os
import signal
import sys
import time
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import DeviceError, SceneError, UsageError
from ..scene.model import SPLIT_LIMIT, parse_rr

AOV_NAMES = ("albedo", "normal", "depth", "emission", "variance", "radius", "photons")   # the last two: photon, sppm
FIRST_HIT_AOVS = ("albedo", "normal", "depth", "emission")
# sample indices are 32-bit on the device: the open-ended target of a time budget
SPP_LIMIT = 1 << 31
# the options a checkpoint remembers; --resume takes those not given again
RESUMABLE = ("spp", "seed", "sampler", "integrator", "strategy", "max_depth", "width", "height",
             "clamp", "crop", "strategy_images", "strategy_depth", "rr", "rr_depth",
             "light_samples", "split")


def parse_defines(items: list[str]) -> dict[str, str]:
    """``-D key=value`` pairs -> {key: value} (values stay strings; the loader types them)."""
    params = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise UsageError(f"-D {item}: expected KEY=VALUE with KEY a name (letters, digits, _)")
        params[key] = value
    return params


def parse_aovs(text: str | None) -> list[str]:
    if text is None:
        return []
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in AOV_NAMES]
    if unknown or not names:
        raise UsageError(f"--aov {text}: unknown AOV {', '.join(unknown) or '(none)'} "
                         f"(choose from {','.join(AOV_NAMES)})")
    return list(dict.fromkeys(names))


def _check_options(args) -> None:
    def need(name, value, ok, what):
        if value is not None and not ok(value):
            raise UsageError(f"{name} {value}: expected {what}")

    need("--spp", args.spp, lambda v: 1 <= v < SPP_LIMIT, "a positive number of samples per pixel")
    need("--time", args.time, lambda v: math.isfinite(v) and v > 0, "a positive number of seconds")
    need("--checkpoint-every", args.checkpoint_every, lambda v: math.isfinite(v) and v > 0,
         "a positive number of seconds")
    need("--width", args.width, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--height", args.height, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--threads", args.threads, lambda v: v >= 1, "a positive number of threads")
    need("--exposure", args.exposure, math.isfinite, "a finite number of stops")
    need("--seed", args.seed, lambda v: 0 <= v < 1 << 32, "an integer in 0..2^32-1")
    need("--max-depth", args.max_depth, lambda v: v == -1 or v >= 1,
         "-1 (unbounded) or a number of path segments >= 1")
    need("--rr-depth", args.rr_depth, lambda v: 1 <= v <= 1 << 20, "a number of path segments >= 1")
    for name, value in (("--light-samples", args.light_samples), ("--split", args.split)):
        need(name, value, lambda v: 1 <= v <= SPLIT_LIMIT, f"an integer in 1..{SPLIT_LIMIT}")
    if args.rr is not None:
        try:
            parse_rr(args.rr)
        except SceneError as exc:
            want = str(exc).split("expected ", 1)[1].rsplit(", got", 1)[0]
            raise UsageError(f"--rr {args.rr}: expected {want}") from None
    need("--clamp", args.clamp, lambda v: math.isfinite(v) and v > 0,
         "a positive number (the largest RGB component a sample keeps)")
    need("--noise-threshold", args.noise_threshold, lambda v: 0 < v < 1,
         "a relative error in (0, 1), e.g. 0.02 for 2%")
    if args.crop is not None:
        parse_crop(args.crop)


def parse_crop(text, width: int | None = None, height: int | None = None) -> list[int]:
    """``X0,Y0,X1,Y1`` (or the list a checkpoint saved) -> [x0, y0, x1, y1] (pixels, x1 and
    y1 excluded), inside the film when its size is given."""
    if isinstance(text, (list, tuple)):
        text = ",".join(map(str, text))
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 4 or not all(p.lstrip("-").isdigit() for p in parts):
        raise UsageError(f"--crop {text}: expected X0,Y0,X1,Y1 in whole pixels")
    x0, y0, x1, y1 = map(int, parts)
    if not (0 <= x0 < x1 and 0 <= y0 < y1):
        raise UsageError(f"--crop {text}: expected 0 <= X0 < X1 and 0 <= Y0 < Y1")
    if width is not None and height is not None and (x1 > width or y1 > height):
        raise UsageError(f"--crop {text}: outside the {width}x{height} film (X1 <= {width}, "
                         f"Y1 <= {height})")
    return [x0, y0, x1, y1]


def _check_scene_file(path: Path) -> None:
    if path.is_dir():
        hint = f" (e.g. {path / 'scene.toml'})" if (path / "scene.toml").is_file() else ""
        raise UsageError(f"{path}: is a folder; give the scene file inside it{hint}")
    if not path.exists():
        raise UsageError(f"{path}: no such scene file (check the path)")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{path}: cannot read the scene file (permission denied)")


def _available_memory() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _check_memory(width: int, height: int, aovs: bool, on_host_device: bool) -> None:
    """Refuse images whose buffers cannot fit, before allocating them."""
    pixels = width * height
    from .renderer import AOV_BYTES, SQUARE_BYTES, SUM_BYTES

    accumulation = SUM_BYTES + SQUARE_BYTES
    device = pixels * (accumulation + (AOV_BYTES if aovs else 0)) * 2   # and the undo copy
    host = pixels * (accumulation + 76 + 24)               # read-back, Film arrays, encoding
    need = host + (device if on_host_device else 0)
    have = _available_memory()
    if have is not None and need > have:
        raise UsageError(f"a {width}x{height} image needs about {need / 2**30:.1f} GiB of memory "
                         f"for its buffers, more than the {have / 2**30:.1f} GiB available: render "
                         f"fewer pixels (--width/--height){' or without --aov' if aovs else ''}")


class _Timer(dict):
    @contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self[name] = self.get(name, 0.0) + time.perf_counter() - t0


def _aov_sidecar(output: Path, name: str) -> Path:
    ext = ".npy" if output.suffix.lower() == ".npy" else ".pfm"
    return output.with_name(f"{output.stem}.{name}{ext}")


def denoised_path(output: Path) -> Path:
    """Where --denoise writes the denoised image: OUT.denoised.EXT beside OUT.EXT."""
    return output.with_name(f"{output.stem}.denoised{output.suffix}")


def _write_outputs(film, output: Path, aov_names: list[str], args,
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
        side = _aov_sidecar(output, name)
        write_image(side, film.aov(name))
        written.append(str(side))
    return written


def _denoise(film, scene, settings, ctx, crop, say, share=None) -> tuple[np.ndarray, dict]:
    """The film's mean denoised (--denoise), and what the statistics record about it: the
    seen emission kept out of the filter and rendered again by its own pass (at the
    film's samples per pixel, which a time budget or a resume may change)."""
    from ..denoise import Denoiser, aovs_are_clean, render_seen_emission
    from .noise import crop_band, crop_rows

    clean = aovs_are_clean(scene)
    t0 = time.perf_counter()
    settings = replace(settings, sampler=replace(settings.sampler, spp=film.spp))
    rows = crop_rows(crop) if crop is not None else None
    seen = render_seen_emission(scene, settings, ctx=ctx, rows=rows, share=share)
    pass_spp = None if seen is None else seen.spp
    if seen is not None and crop is not None:
        seen = crop_band(seen, crop, rows)
    t1 = time.perf_counter()
    with Denoiser() as denoiser:
        image = denoiser.denoise_film(film, clean_aux=clean,
                                      seen_emission=None if seen is None else seen.mean)
        info = {"library": "Open Image Denoise", "device": denoiser.device_name,
                "threads": denoiser.threads, "quality": denoiser.quality, "clean_aux": clean,
                "aux": [n for n in ("albedo", "normal") if n in film.aovs],
                "emission_kept": "emission" in film.aovs, "emission_pass_spp": pass_spp,
                "emission_pass_seconds": t1 - t0}
    info["seconds"] = time.perf_counter() - t0
    say(f"glrender: denoised in {info['seconds']:.2f} s (Open Image Denoise, "
        f"{denoiser.device_name}, albedo and normal{', cleanAux' if clean else ''}"
        f"{f'; the seen emission apart, {pass_spp} spp' if pass_spp else ''})")
    return image, info


def _mean_relative_stderr(film) -> float | None:
    from .noise import mean_relative_stderr

    return mean_relative_stderr(film)


def _write_stats(path: Path, stats: dict) -> None:
    from ..film.io import atomic_write

    def write(tmp: Path) -> None:
        tmp.write_text(json.dumps(stats, indent=2) + "\n")

    atomic_write(path, write)


def _strategy_depth(options: dict, scene) -> int:
    """--strategy-images' path length (0 without it): --strategy-depth, else 5 or the max
    depth if smaller."""
    from .strategies import DEFAULT_DEPTH

    depth = options.get("strategy_depth")
    folder = options.get("strategy_images")
    if folder is None:
        if depth is not None:
            raise UsageError(f"--strategy-depth {depth}: only with --strategy-images DIR")
        return 0
    if Path(folder).exists() and not Path(folder).is_dir():
        raise UsageError(f"--strategy-images {folder}: is a file, expected a folder (created if "
                         f"missing)")
    integrator = options.get("integrator") or scene.integrator.kind
    if integrator != "bdpt":
        raise UsageError(f"--strategy-images: only the bdpt integrator has strategies (s, t), "
                         f"not {integrator} (add --integrator bdpt)")
    if depth is None:
        max_depth = options.get("max_depth", scene.integrator.max_depth)
        depth = DEFAULT_DEPTH if max_depth < 0 else min(DEFAULT_DEPTH, max_depth)
    return int(depth)


def run_render(args, signals) -> int:
    """Run ``glrender render`` with parsed ``args``; ``signals`` is the command's
    :class:`~glrender.cli.StopSignals`. Returns the exit code."""
    import moderngl

    from .. import __version__, load
    from ..film.io import check_folder, check_output
    from ..gl.context import create_context
    from .checkpoint import check_resumable, load_checkpoint, save_checkpoint
    from .job import RenderJob
    from .progress import ProgressBar
    from .noise import crop_band, crop_rows
    from .renderer import SPLATTING, Renderer, settings_from_scene

    from ..distributed.command import run_distributed, uses_cluster

    if uses_cluster(args):          # --workers, --scheduler, --frames: on a Dask cluster
        if getattr(args, "strategy_images", None):
            raise UsageError("--strategy-images: not available on a cluster (render on one "
                             "machine)")
        return run_distributed(args, signals)
    say = (lambda *a: None) if args.quiet else (lambda text: print(text, file=sys.stderr))
    timer = _Timer()
    t_start = time.perf_counter()

    # -- options, files, checkpoint: everything checked before any work --------------------
    _check_options(args)
    if getattr(args, "denoise", False):
        from ..denoise import load_oidn

        load_oidn()        # without the extra: one line naming it, before any work
    params = parse_defines(args.define)
    aov_names = parse_aovs(args.aov)
    output = check_output(args.output)
    scene_path = Path(args.scene)
    _check_scene_file(scene_path)
    ckpt_path = Path(args.checkpoint) if args.checkpoint else Path(str(output) + ".ckpt")
    for path, what in ((ckpt_path, "checkpoint"), (args.stats, "statistics")):
        if path is not None:
            check_folder(path, what)
            if Path(path).is_dir():
                raise UsageError(f"{path}: is a folder, expected a file name for the {what}")
    keep_checkpoint = bool(args.checkpoint or args.checkpoint_every or args.resume)
    ckpt = load_checkpoint(ckpt_path) if args.resume else None
    from ..photon.command import OPTIONS as PHOTON_OPTIONS

    resumable = RESUMABLE + PHOTON_OPTIONS
    options = {k: getattr(args, k) for k in resumable if getattr(args, k, None) is not None}
    if ckpt is not None:
        saved = ckpt.meta.get("options", {})
        options = {**{k: v for k, v in saved.items() if k in resumable}, **options}
        if not args.define:
            params = dict(ckpt.meta.get("params", {}))
        if args.aov is None:
            aov_names = [n for n in ckpt.meta.get("aov_names", []) if n in AOV_NAMES]

    # -- scene and renderer ------------------------------------------------------------------
    with timer("load"):
        scene = load(scene_path, **params)
    scene.film = scene.film.resized(options.get("width"), options.get("height"))
    # --denoise guides the denoiser with the albedo and normal AOVs
    first_hit = any(n in FIRST_HIT_AOVS for n in aov_names) or getattr(args, "denoise", False)
    settings = settings_from_scene(scene, integrator=options.get("integrator"),
                                   spp=options.get("spp"), seed=options.get("seed"),
                                   sampler=options.get("sampler"),
                                   max_depth=options.get("max_depth"),
                                   rr=options.get("rr"), rr_depth=options.get("rr_depth"),
                                   light_samples=options.get("light_samples"),
                                   split=options.get("split"),
                                   strategy=options.get("strategy"), aovs=first_hit,
                                   clamp=options.get("clamp"),
                                   strategy_depth=_strategy_depth(options, scene))
    from ..photon.command import photon_settings

    for name in PHOTON_OPTIONS:       # a checkpoint's photon options, unless given again
        if getattr(args, name, None) is None and name in options:
            setattr(args, name, options[name])
    settings, photon = photon_settings(args, settings)   # --integrator sppm: iterations as spp
    sppm = photon if settings.integrator.kind == "sppm" else None
    if "spp" in options or args.time is None or sppm is not None:
        target = settings.sampler.spp
    else:
        target = SPP_LIMIT
    width, height = scene.film.width, scene.film.height
    with timer("context"):
        try:
            ctx = create_context(args.device, threads=args.threads)
        except DeviceError as exc:
            raise DeviceError(f"{exc}; `glrender info` lists the devices (choose with --device "
                              f"or $GLRENDER_DEVICE)") from exc
    _check_memory(width, height, first_hit, ctx.is_llvmpipe)
    crop = parse_crop(options["crop"], width, height) if options.get("crop") else None
    if crop is not None:
        options["crop"] = crop
        if settings.integrator.kind in SPLATTING:
            raise UsageError(f"--crop: not available with the {settings.integrator.kind} "
                             f"integrator (its light paths reach every pixel of the film)")
    noise_plan = pilot = None
    if args.noise_threshold is not None and ckpt is None:
        from .noise import run_pilot

        # the render shares the pilot's scene data (packed arrays, BVH, textures)
        noise_plan, pilot = run_pilot(scene, settings, args.noise_threshold, ctx=ctx,
                                      max_spp=options.get("spp"), region=crop)
        say(f"glrender: pilot of {noise_plan.pilot_spp} spp ({noise_plan.pilot_seconds:.2f} s): "
            f"{noise_plan.spp} spp for a mean relative error of {noise_plan.threshold:g}")
        options["spp"] = target = noise_plan.spp
        settings = replace(settings, sampler=replace(settings.sampler, spp=noise_plan.spp))
    try:
        if sppm is not None:
            from ..photon import SppmRenderer

            renderer = SppmRenderer(scene, settings, sppm, ctx=ctx)
        elif photon is not None:
            from ..photon import PhotonRenderer

            renderer = PhotonRenderer(scene, settings, photon, ctx=ctx, share=pilot)
        else:
            renderer = Renderer(scene, settings, ctx=ctx, share=pilot)
    except moderngl.Error as exc:
        raise UsageError(f"cannot allocate the device buffers of a {width}x{height} image "
                         f"({str(exc).strip()}): render fewer pixels (--width/--height)") from exc
    finally:
        if pilot is not None:
            pilot.release()
    timer.update(renderer.timings)
    if crop is not None:      # the tile rows the crop covers; columns are cut at the end
        renderer.reset(rows=crop_rows(crop))
    if ckpt is not None:
        saved_crop = ckpt.meta.get("options", {}).get("crop")
        if saved_crop != crop:
            def held(c):
                return "crop " + ",".join(map(str, c)) if c else "the whole film"
            raise UsageError(f"{ckpt_path}: the checkpoint holds {held(saved_crop)}, this render "
                             f"{held(crop)}: resume with the same --crop, or render without "
                             f"--resume")
        check_resumable(ckpt, renderer)
        renderer.restore(ckpt.state)
        if ckpt.meta.get("device") != ctx.renderer:
            import warnings

            warnings.warn(f"{ckpt_path} was rendered on {ckpt.meta.get('device')!r}, this run on "
                          f"{ctx.renderer!r}: the image will not be bitwise the same as one "
                          f"uninterrupted render", stacklevel=1)
    spp_resumed = renderer.spp_done if ckpt is not None else None
    record = {"options": options, "params": params, "aov_names": aov_names,
              "scene": str(scene_path.resolve()), "device": ctx.renderer,
              "glrender": __version__,
              "spp_target": None if target == SPP_LIMIT else target}

    def write_checkpoint():
        with timer("checkpoint"):
            save_checkpoint(ckpt_path, renderer, **record)

    # -- render: from here on a stop signal ends the run cleanly -----------------------------
    signals.defer(True)
    budget = f", at most {args.time:g} s" if args.time is not None else ""
    goal = f"{target} spp" if target != SPP_LIMIT else "open-ended spp"
    say(f"glrender: rendering {scene_path} ({width}x{height}, {goal}{budget}, "
        f"{settings.integrator.kind}, {settings.sampler.kind} sampler, seed "
        f"{settings.sampler.seed}) on {ctx.renderer}")
    if spp_resumed is not None:
        say(f"glrender: resuming {ckpt_path} at {spp_resumed} spp")
    bar = None
    if not args.quiet and sys.stderr.isatty():
        bar = ProgressBar(sys.stderr, pixels=width * height, spp_start=renderer.spp_done,
                          spp_target=None if target == SPP_LIMIT else target, seconds=args.time)
        bar.update(renderer.spp_done, 0.0, force=True)
    job = RenderJob(renderer, target, seconds=args.time, stop=signals.requested,
                    checkpoint=write_checkpoint if keep_checkpoint else None,
                    checkpoint_every=args.checkpoint_every,
                    progress=bar.update if bar is not None else None)
    try:
        result = job.run()
        if bar is not None:
            bar.update(renderer.spp_done, result.seconds, force=True)
    finally:
        if bar is not None:
            bar.close()
    timer["render"] = result.render_seconds

    # -- outputs -----------------------------------------------------------------------------
    film = renderer.film()
    if crop is not None:
        film = crop_band(film, crop, renderer.rows)
    interrupted = result.stopped == "interrupted"
    written, ckpt_written, denoised, denoise_info = [], None, None, None
    if film.spp > 0:
        if getattr(args, "denoise", False):
            with timer("denoise"):
                denoised, denoise_info = _denoise(film, scene, settings, ctx, crop, say, share=renderer)
        with timer("write"):
            written = _write_outputs(film, output, aov_names, args, denoised)
            if settings.strategy_depth:
                from . import strategies

                written += strategies.write(Path(options["strategy_images"]),
                                            renderer.strategy_images(), settings.strategy_depth,
                                            exposure=args.exposure, curve=args.tonemap,
                                            srgb=args.srgb)
        if interrupted or keep_checkpoint:
            write_checkpoint()
            ckpt_written = str(ckpt_path)
    new_samples = (result.spp_done - result.spp_start) * renderer.width * renderer.band_height
    rate = new_samples / result.render_seconds if result.render_seconds > 0 else None
    timer["total"] = time.perf_counter() - t_start
    stats = {
        "glrender": __version__, "scene": str(scene_path), "params": params,
        "output": str(output), "outputs": written, "checkpoint": ckpt_written,
        "device": {"GL_RENDERER": ctx.renderer, "GL_VERSION": ctx.gl.info["GL_VERSION"],
                   "index": ctx.device.index, "kind": ctx.device.kind},
        "scene_hash": renderer.fingerprint(),
        "width": width, "height": height, "integrator": settings.integrator.kind,
        "strategy": settings.integrator.strategy, "max_depth": settings.integrator.max_depth,
        "sampler": settings.sampler.kind, "seed": settings.sampler.seed,
        "spp": film.spp, "spp_target": record["spp_target"],
        "spp_this_run": result.spp_done - result.spp_start,
        "resumed_from_spp": spp_resumed, "time_budget": args.time,
        "samples_per_pass": renderer.samples_per_pass, "passes": result.passes,
        "pass_seconds_max": result.pass_seconds_max, "checkpoints_written": result.checkpoints,
        "stopped": result.stopped,
        "signal": signal.Signals(signals.received).name if interrupted else None,
        "seconds": {k: timer.get(k, 0.0) for k in ("load", "context", "pack", "build", "compile",
                                                    "render", "checkpoint", "denoise", "write",
                                                    "total")},
        "denoise": denoise_info,
        "crop": crop, "clamp": settings.clamp, "biased": settings.clamp is not None,
        "memory": {"device_bytes_per_pixel": renderer.device_bytes_per_pixel(),
                   "device_accumulation_bytes": renderer.device_bytes_per_pixel()
                   * renderer.width * renderer.band_height,
                   "slices": len(renderer._slices()),
                   "texture_bytes": renderer.texture_bytes},
        "noise_threshold": None if noise_plan is None else {
            "threshold": noise_plan.threshold, "pilot_spp": noise_plan.pilot_spp,
            "pilot_error": noise_plan.pilot_error, "pilot_seconds": noise_plan.pilot_seconds,
            "planned_spp": noise_plan.spp, "predicted_error": noise_plan.predicted_error()},
        "samples_per_second": rate,
        "nonfinite_samples": film.nonfinite_total,
        "mean_relative_stderr": _mean_relative_stderr(film),
        "stderr_is_upper_bound": settings.sampler.kind != "independent",
        "mean": [float(v) for v in film.mean.reshape(-1, 3).mean(0)],
    }
    if hasattr(renderer, "photon_stats"):     # photon, sppm: maps, radii, lookups, memory
        stats["photon"] = renderer.photon_stats()
        stats["biased"] = True
    if args.stats:
        _write_stats(Path(args.stats), stats)
    renderer.release()

    # -- summary -----------------------------------------------------------------------------
    speed = f"{rate / 1e6:.2f} Mpaths/s" if rate else "no new samples"
    if interrupted:
        name = stats["signal"]
        if film.spp == 0:
            say(f"glrender: stopped by {name} before the first pass: nothing written")
        else:
            say(f"glrender: stopped by {name} at {film.spp} spp ({speed}, "
                f"{film.nonfinite_total} non-finite samples): image -> {', '.join(written)}; "
                f"checkpoint -> {ckpt_path} (continue with --resume)")
        return 128 + signals.received
    why = f" (time budget {args.time:g} s)" if result.stopped == "time" else ""
    say(f"glrender: {film.spp} spp in {result.render_seconds:.2f} s{why} ({speed}), "
        f"{film.nonfinite_total} non-finite samples -> {', '.join(written)}"
        + (f"; checkpoint -> {ckpt_written}" if ckpt_written else ""))
    return 0
