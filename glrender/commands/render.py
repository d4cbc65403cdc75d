"""The ``glrender render`` command: options -> scene, job (glrender.render.job), outputs, stats.

Everything a user can get wrong is checked before the render starts (output format, every
output path written to by a probe, scene file, option values, the checkpoint and the
options it saved, memory), so a mistake costs no render time. A new render does not replace
a checkpoint that is there (unless --overwrite), and a stopped render's image does not
replace a complete one (it goes beside it, OUT-STEM.partial.EXT).
"""
from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from pathlib import Path

import numpy as np

from .. import integrators
from ..errors import DeviceError, UsageError
from .options import (AOV_NAMES, FIRST_HIT_AOVS, RESUMABLE, check_memory, check_options,
                      check_scene_file, parse_aovs, parse_crop, parse_defines)
from .outputs import check_checkpoint, partial_path, write_outputs, write_stats


def _denoise(film, job, say) -> tuple[np.ndarray, dict]:
    """The film's mean denoised (--denoise), and what the statistics record about it: the
    seen emission kept out of the filter and rendered again by the job's own pass
    (Job.seen_emission, at the film's samples per pixel)."""
    from ..denoise import Denoiser, aovs_are_clean

    clean = aovs_are_clean(job.scene)
    t0 = time.perf_counter()
    seen = job.seen_emission(film)
    pass_spp = None if seen is None else seen.spp
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
    if not integrators.get(integrator).strategies:
        have = [n for n in integrators.names() if integrators.get(n).strategies]
        raise UsageError(f"--strategy-images: only the {' and '.join(have)} integrators have "
                         f"strategies (s, t), not {integrator} (add --integrator {have[0]})")
    from ..film.io import check_writable

    check_writable(folder, "strategy images", "--strategy-images", folder=True)
    if depth is None:
        max_depth = options.get("max_depth", scene.integrator.max_depth)
        depth = DEFAULT_DEPTH if max_depth < 0 else min(DEFAULT_DEPTH, max_depth)
    return int(depth)


def _saved_kinds() -> dict:
    """What each option a checkpoint saves holds, as the command line parses it: a type,
    or a tuple of the choices."""
    from ..render.params import STRATEGIES
    from ..scene.model import INTEGRATORS, LIGHT_SELECTIONS, SAMPLER_KINDS
    from ..vcm.vcm import MODES

    kinds: dict = dict.fromkeys(("spp", "seed", "max_depth", "width", "height", "rr_depth",
                                 "light_samples", "split", "strategy_depth",
                                 "photons_per_iteration", "iterations", "caustic_photons",
                                 "knn", "light_paths", "light_vertex_cache"), int)
    kinds.update(dict.fromkeys(("clamp", "initial_radius", "alpha", "radius", "volume_radius"), float))
    kinds.update(rr=str, strategy_images=str, crop=str | list, final_gather=bool,
                 sampler=tuple(SAMPLER_KINDS), integrator=tuple(INTEGRATORS),
                 strategy=tuple(STRATEGIES), kernel=("uniform", "cone", "epanechnikov"),
                 light_selection=tuple(LIGHT_SELECTIONS),
                 vcm_mode=tuple(MODES))
    return kinds


def _saved_ok(kind, value) -> bool:
    if kind in (int, bool):
        return type(value) is kind              # JSON's: not a bool for an int, nor 4.0
    if kind is float:
        return type(value) in (int, float) and math.isfinite(value)
    if isinstance(kind, tuple):
        return isinstance(value, str) and value in kind
    return isinstance(value, kind)


def _refused_option(ckpt, what: str) -> UsageError:
    """The one line refusing an option value ``ckpt`` saved (``what``: the option and why)."""
    return UsageError(f"{ckpt.path}: the checkpoint's option {what}: render without --resume "
                      f"to start afresh")


def _saved_options(args, ckpt, resumable) -> dict:
    """The options ``ckpt`` saved that a resume takes back, each checked as the command
    line checks it (its type or choices, then :func:`check_options`); one line naming the
    checkpoint and the option refuses a value it would not take."""
    import json

    kinds = _saved_kinds()
    saved = {k: v for k, v in ckpt.meta.get("options", {}).items() if k in resumable}
    for name, value in saved.items():
        kind = kinds.get(name, object)
        if not _saved_ok(kind, value):
            want = ("one of " + ", ".join(kind) if isinstance(kind, tuple) else
                    {int: "an integer", float: "a finite number", bool: "true",
                     str: "text"}.get(kind, "X0,Y0,X1,Y1"))
            shown = json.dumps(value)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            raise _refused_option(ckpt, f"{name} is {shown}, expected {want}")
    merged = argparse.Namespace(**{**vars(args), **{k: v for k, v in saved.items()
                                                    if getattr(args, k, None) is None}})
    try:
        check_options(merged)
    except UsageError as exc:
        raise _refused_option(ckpt, str(exc)) from None
    return saved


def _resumed(args, ckpt, params: dict, aov_names: list) -> tuple[dict, dict, list]:
    """The render's options, -D parameters and AOVs: those given, else the checkpoint's
    (--resume); a checkpoint's photon options land on ``args`` unless given again."""
    from .photon_options import OPTIONS as PHOTON_OPTIONS

    resumable = RESUMABLE + PHOTON_OPTIONS
    options = {k: getattr(args, k) for k in resumable if getattr(args, k, None) is not None}
    if ckpt is not None:
        saved = _saved_options(args, ckpt, resumable)
        options = {**saved, **options}
        if not args.define:
            params = dict(ckpt.meta.get("params", {}))
        if args.aov is None:
            aov_names = [n for n in ckpt.meta.get("aov_names", []) if n in AOV_NAMES]
    for name in PHOTON_OPTIONS:
        if getattr(args, name, None) is None and name in options:
            setattr(args, name, options[name])
    return options, params, aov_names


def _context(args, timings):
    """The device of --device and --threads; a failure says how to list and choose one."""
    from ..gl.context import create_context

    with timings("context"):
        try:
            return create_context(args.device, threads=args.threads)
        except DeviceError as exc:
            raise DeviceError(f"{exc}; `glrender info` lists the devices (choose with --device "
                              f"or $GLRENDER_DEVICE)") from exc


def _crop(options: dict, film, ckpt) -> list[int] | None:
    """--crop (or the checkpoint's) inside the film; a resume keeps the checkpoint's crop."""
    crop = parse_crop(options["crop"], film.width, film.height) if options.get("crop") else None
    if crop is not None:
        options["crop"] = crop
    saved = ckpt.meta.get("options", {}).get("crop") if ckpt is not None else crop
    if saved != crop:
        def held(c):
            return "crop " + ",".join(map(str, c)) if c else "the whole film"
        raise UsageError(f"{ckpt.path}: the checkpoint holds {held(saved)}, this render "
                         f"{held(crop)}: resume with the same --crop, or render without --resume")
    return crop


def _settings(args, options: dict, scene, first_hit: bool) -> dict:
    """The job options that decide the render settings: the integrator, the spp (sppm: its
    --iterations), the seed, the further overrides and the photon integrators' own settings."""
    from .photon_options import photon_options

    settings = {k: options.get(k) for k in ("sampler", "max_depth", "rr", "rr_depth",
                                            "light_samples", "split", "strategy", "clamp",
                                            "light_selection")}
    settings.update(aovs=first_hit, strategy_depth=_strategy_depth(options, scene))
    kind = options.get("integrator") or scene.integrator.kind
    iterations, photon = photon_options(args, kind)   # --integrator sppm: iterations as spp
    spp = iterations if iterations is not None else options.get("spp")
    return dict(integrator=options.get("integrator"), spp=spp, seed=options.get("seed"),
                settings=settings, integrator_options=photon)


def _write(args, job, film, output: Path, aov_names: list, options: dict, say) -> dict:
    """The image, its AOVs, the denoised image and bdpt's strategy images; the entries
    they add to the statistics."""
    denoised = denoise_info = None
    if getattr(args, "denoise", False):
        with job.timings("denoise"):
            denoised, denoise_info = _denoise(film, job, say)
    partial = job.stopped == "interrupted"
    stale = partial_path(output)
    if partial and output.exists():
        output = stale                      # a partial image never replaces one that is there
    with job.timings("write"):
        written = write_outputs(film, output, aov_names, args, denoised)
        if not partial and stale.is_file():
            stale.unlink()                  # the complete image supersedes an earlier partial one
        if job.settings.strategy_depth:
            from ..render import strategies

            folder = Path(options["strategy_images"])
            if partial and folder.is_dir() and any(folder.iterdir()):
                folder = partial_path(folder)   # nor partial strategy images complete ones
            merges = getattr(job.driver, "merge_strategy_images", None)
            written += strategies.write(folder, job.driver.strategy_images(), job.settings.strategy_depth,
                                        exposure=args.exposure, curve=args.tonemap, srgb=args.srgb,
                                        merge_images=merges() if merges is not None else None)
    return {"outputs": written, "denoise": denoise_info}


def _summary(say, outcome, signals, budget: float | None, ckpt_path: Path, output: Path) -> int:
    """The last line (what was rendered, how fast, where it went) and the exit code."""
    film, run = outcome.film, outcome.run
    cut = film.truncated_total
    samples = f"{film.nonfinite_total} non-finite samples" + (
        f", {cut} paths cut at the {outcome.depth_cap}-segment cap" if cut and outcome.depth_cap else "")
    written = outcome.outputs.get("outputs", [])
    image = f"image -> {', '.join(written)}"
    if written and written[0] != str(output):
        image = f"partial image -> {', '.join(written)} ({output}, already there, is kept)"
    rate = outcome.samples_per_second
    speed = f"{rate / 1e6:.2f} Mpaths/s" if rate else "no new samples"
    if run.stopped == "interrupted":
        name = signal.Signals(signals.received).name
        if film.spp == 0:
            say(f"glrender: stopped by {name} before the first pass: nothing written")
        else:
            say(f"glrender: stopped by {name} at {film.spp} spp ({speed}, "
                f"{samples}): {image}; "
                f"checkpoint -> {ckpt_path} (continue with --resume)")
        return 128 + signals.received
    why = f" (time budget {budget:g} s)" if run.stopped == "time" else ""
    say(f"glrender: {film.spp} spp in {run.render_seconds:.2f} s{why} ({speed}), "
        f"{samples} -> {', '.join(written)}"
        + (f"; checkpoint -> {outcome.checkpoint}" if outcome.checkpoint else ""))
    return 0


def run_render(args, signals) -> int:
    """Run ``glrender render`` with parsed ``args``; ``signals`` is the command's
    :class:`~glrender.commands.cli.StopSignals`. Returns the exit code."""
    from .. import __version__, load
    from ..drivers import create_driver
    from ..film.io import check_output
    from ..render.checkpoint import load_checkpoint
    from ..render.job import Job, JobOptions, Timings
    from .cluster import run_distributed, uses_cluster

    if uses_cluster(args):          # --workers, --scheduler, --frames: on a Dask cluster
        if getattr(args, "strategy_images", None):
            raise UsageError("--strategy-images: not available on a cluster (render on one "
                             "machine)")
        return run_distributed(args, signals)
    say = (lambda *a: None) if args.quiet else (lambda text: print(text, file=sys.stderr))
    timings, t_start = Timings(), time.perf_counter()

    # -- options, files, checkpoint: everything checked before any work --------------------
    check_options(args)
    if getattr(args, "denoise", False):
        from ..denoise import load_oidn

        load_oidn()        # without the extra: one line naming it, before any work
    params, aov_names = parse_defines(args.define), parse_aovs(args.aov)
    output = check_output(args.output)
    scene_path = Path(args.scene)
    check_scene_file(scene_path)
    ckpt_path = Path(args.checkpoint) if args.checkpoint else Path(str(output) + ".ckpt")
    check_checkpoint(args, ckpt_path)
    ckpt = load_checkpoint(ckpt_path) if args.resume else None
    from .photon_options import OPTIONS as PHOTON_OPTIONS

    given = {name for name in PHOTON_OPTIONS if getattr(args, name, None) is not None}
    options, params, aov_names = _resumed(args, ckpt, params, aov_names)

    # -- scene, device, job ----------------------------------------------------------------
    with timings("load"):
        scene = load(scene_path, **params)
    scene.film = scene.film.resized(options.get("width"), options.get("height"))
    # --denoise guides the denoiser with the albedo and normal AOVs
    first_hit = any(n in FIRST_HIT_AOVS for n in aov_names) or getattr(args, "denoise", False)
    try:
        settings = _settings(args, options, scene, first_hit)
    except UsageError as exc:
        # a photon option the checkpoint saved (not given again) is named as the checkpoint's
        saved = ckpt.meta.get("options", {}) if ckpt is not None else {}
        if ckpt is None or not any(n in saved and n not in given for n in PHOTON_OPTIONS):
            raise
        raise _refused_option(ckpt, str(exc)) from None
    ctx = _context(args, timings)
    check_memory(scene.film.width, scene.film.height, first_hit, ctx.is_llvmpipe)
    job_options = JobOptions(
        **settings, seconds=args.time, stop=signals.requested,
        stopped_by=lambda: signal.Signals(signals.received).name,
        crop=_crop(options, scene.film, ckpt), noise_threshold=args.noise_threshold, ctx=ctx,
        checkpoint=ckpt_path, checkpoint_every=args.checkpoint_every,
        keep_checkpoint=bool(args.checkpoint or args.checkpoint_every or args.resume),
        resume=ckpt, record={"options": options, "params": params, "aov_names": aov_names,
                             "scene": str(scene_path.resolve()), "device": ctx.renderer,
                             "glrender": __version__},
        name=str(scene_path), say=say, progress_bar=not args.quiet, stats=bool(args.stats),
        info={"glrender": __version__, "scene": str(scene_path), "params": params,
              "output": str(output)}, timings=timings, started=t_start)
    with Job(scene, job_options, create_driver) as job:
        if job.noise_plan is not None:      # a resume continues to the planned count
            options["spp"] = job.noise_plan.spp
        signals.defer(True)     # from here on a stop signal ends the run cleanly
        outcome = job.run(lambda film: _write(args, job, film, output, aov_names, options, say))
    if args.stats:
        write_stats(Path(args.stats), outcome.stats)
    return _summary(say, outcome, signals, args.time, ckpt_path, output)
