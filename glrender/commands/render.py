"""The ``glrender render`` command: options -> scene, renderer, run, outputs, checkpoint, stats.

Everything a user can get wrong is checked before the render starts (output format and
folder, scene file, option values, memory), so a mistake costs no render time.
"""
from __future__ import annotations

import signal
import sys
import time
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from .. import integrators
from ..errors import DeviceError, UsageError
from .options import (AOV_NAMES, FIRST_HIT_AOVS, RESUMABLE, SPP_LIMIT, check_memory, check_options,
                      check_scene_file, parse_aovs, parse_crop, parse_defines)
from .outputs import mean_relative_stderr_of, write_outputs, write_stats


class _Timer(dict):
    @contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self[name] = self.get(name, 0.0) + time.perf_counter() - t0


def _denoise(film, scene, settings, ctx, crop, say, share=None) -> tuple[np.ndarray, dict]:
    """The film's mean denoised (--denoise), and what the statistics record about it: the
    seen emission kept out of the filter and rendered again by its own pass (at the
    film's samples per pixel, which a time budget or a resume may change)."""
    from ..denoise import Denoiser, aovs_are_clean
    from ..render.emission_pass import render_seen_emission
    from ..render.noise import crop_band, crop_rows

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


def _strategy_depth(options: dict, scene) -> int:
    """--strategy-images' path length (0 without it): --strategy-depth, else 5 or the max
    depth if smaller."""
    from ..render.strategies import DEFAULT_DEPTH

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
    :class:`~glrender.commands.cli.StopSignals`. Returns the exit code."""
    import moderngl

    from .. import __version__, load
    from ..film.io import check_folder, check_output
    from ..gl.context import create_context
    from ..render.checkpoint import check_resumable, load_checkpoint, save_checkpoint
    from ..render.job import RenderJob
    from ..render.progress import ProgressBar
    from ..render.noise import crop_band, crop_rows
    from ..drivers import create_driver
    from ..render.renderer import settings_from_scene

    from .cluster import run_distributed, uses_cluster

    if uses_cluster(args):          # --workers, --scheduler, --frames: on a Dask cluster
        if getattr(args, "strategy_images", None):
            raise UsageError("--strategy-images: not available on a cluster (render on one "
                             "machine)")
        return run_distributed(args, signals)
    say = (lambda *a: None) if args.quiet else (lambda text: print(text, file=sys.stderr))
    timer = _Timer()
    t_start = time.perf_counter()

    # -- options, files, checkpoint: everything checked before any work --------------------
    check_options(args)
    if getattr(args, "denoise", False):
        from ..denoise import load_oidn

        load_oidn()        # without the extra: one line naming it, before any work
    params = parse_defines(args.define)
    aov_names = parse_aovs(args.aov)
    output = check_output(args.output)
    scene_path = Path(args.scene)
    check_scene_file(scene_path)
    ckpt_path = Path(args.checkpoint) if args.checkpoint else Path(str(output) + ".ckpt")
    for path, what in ((ckpt_path, "checkpoint"), (args.stats, "statistics")):
        if path is not None:
            check_folder(path, what)
            if Path(path).is_dir():
                raise UsageError(f"{path}: is a folder, expected a file name for the {what}")
    keep_checkpoint = bool(args.checkpoint or args.checkpoint_every or args.resume)
    ckpt = load_checkpoint(ckpt_path) if args.resume else None
    from .photon_options import OPTIONS as PHOTON_OPTIONS

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
    from .photon_options import photon_settings

    for name in PHOTON_OPTIONS:       # a checkpoint's photon options, unless given again
        if getattr(args, name, None) is None and name in options:
            setattr(args, name, options[name])
    settings, photon = photon_settings(args, settings)   # --integrator sppm: iterations as spp
    spec = integrators.get(settings.integrator.kind)
    if "spp" in options or args.time is None or not spec.open_ended:
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
    check_memory(width, height, first_hit, ctx.is_llvmpipe)
    crop = parse_crop(options["crop"], width, height) if options.get("crop") else None
    if crop is not None:
        options["crop"] = crop
        if spec.splatting:
            raise UsageError(f"--crop: not available with the {settings.integrator.kind} "
                             f"integrator (its light paths reach every pixel of the film)")
    noise_plan = pilot = None
    if args.noise_threshold is not None and ckpt is None:
        from ..render.noise import run_pilot

        # the render shares the pilot's scene data (packed arrays, BVH, textures)
        noise_plan, pilot = run_pilot(scene, settings, args.noise_threshold, ctx=ctx,
                                      max_spp=options.get("spp"), region=crop)
        say(f"glrender: pilot of {noise_plan.pilot_spp} spp ({noise_plan.pilot_seconds:.2f} s): "
            f"{noise_plan.spp} spp for a mean relative error of {noise_plan.threshold:g}")
        options["spp"] = target = noise_plan.spp
        settings = replace(settings, sampler=replace(settings.sampler, spp=noise_plan.spp))
    try:
        renderer = create_driver(scene, settings, photon, ctx=ctx, share=pilot)
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
            written = write_outputs(film, output, aov_names, args, denoised)
            if settings.strategy_depth:
                from ..render import strategies

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
        "mean_relative_stderr": mean_relative_stderr_of(film),
        "stderr_is_upper_bound": settings.sampler.kind != "independent",
        "mean": [float(v) for v in film.mean.reshape(-1, 3).mean(0)],
    }
    stats.update(renderer.stats())         # photon, sppm: maps, radii, lookups, memory
    if args.stats:
        write_stats(Path(args.stats), stats)
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
