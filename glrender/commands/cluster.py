"""``glrender render`` on a Dask cluster: ``--workers N``, ``--scheduler ADDRESS``, ``--frames A:B``.

Everything is checked before the cluster starts (options, every output path written to by
a probe, the checkpoint, scene file); the
scene is loaded here once (its errors and warnings read as in a single-process render),
then sent to the workers. Outputs are written when the whole frame is merged, so an
error or an interrupt leaves no partial image; Ctrl-C (or SIGTERM) writes a checkpoint
of the finished bands, which ``--resume`` continues (bitwise the same final image). The
job runner (:class:`glrender.render.job.UnitsJob`) makes the settings, draws the units
bar, writes and reads the checkpoints and gathers the statistics; this module checks the
options, runs the cluster and says what happened.
"""
from __future__ import annotations

import logging
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

from ..errors import UsageError
from ..distributed.merge import Partial, band_layout

UNSUPPORTED = (("time", "--time"), ("checkpoint_every", "--checkpoint-every"))


def uses_cluster(args) -> bool:
    return any(getattr(args, k, None) is not None for k in ("workers", "scheduler", "frames"))


def _outputs(args, frames, output: str) -> dict:
    from ..film.io import check_output

    if frames == [None]:
        if "{frame" in output:
            raise UsageError(f"-o {output}: {{frame}} names frames: render with --frames A:B")
        return {None: check_output(output)}
    if "{frame" not in output:
        raise UsageError(f"-o {output}: several frames need a {{frame}} pattern in the name, "
                         f"e.g. -o 'out/frame{{frame:04d}}.exr'")
    try:
        names = {f: output.format(frame=f) for f in frames}
    except (KeyError, IndexError, ValueError) as exc:
        raise UsageError(f"-o {output}: a bad pattern ({exc}); use {{frame}} or {{frame:04d}}") \
            from None
    return {f: check_output(n) for f, n in names.items()}


def run_distributed(args, signals) -> int:
    from .. import __version__
    from .options import (FIRST_HIT_AOVS, check_options, check_scene_file, parse_aovs,
                          parse_defines)
    from .outputs import check_checkpoint, write_outputs, write_stats
    from .photon_options import photon_options
    from ..drivers import options_class
    from ..render.job import JobOptions, UnitsJob
    from ..scene.animation import frame_range
    from ..distributed import client as cl
    from ..distributed import source as src
    from ..distributed.plan import MIN_UNIT_SIZE

    say = (lambda *a: None) if args.quiet else (lambda text: print(text, file=sys.stderr))
    t_start = time.perf_counter()
    check_options(args)
    for key, flag in UNSUPPORTED:
        if getattr(args, key, None) is not None:
            raise UsageError(f"{flag} is not available with --workers/--scheduler/--frames "
                             f"(give --spp)")
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("give --workers N (a local cluster) or --scheduler ADDRESS, not both")
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers {args.workers}: expected a positive number of worker "
                         f"processes")
    if args.unit_size is not None and args.unit_size < MIN_UNIT_SIZE:
        raise UsageError(f"--unit-size {args.unit_size}: expected at least {MIN_UNIT_SIZE} "
                         f"pixel-samples")
    tls = (args.tls_ca, args.tls_cert, args.tls_key)
    if any(tls) and not all(tls):
        raise UsageError("--tls-ca, --tls-cert and --tls-key go together")
    if any(tls) and args.scheduler is None:
        raise UsageError("--tls-ca/--tls-cert/--tls-key are for --scheduler tls://...")
    params = parse_defines(args.define)
    aov_names = parse_aovs(args.aov)
    scene_path = Path(args.scene)
    check_scene_file(scene_path)
    scene, source = src.from_file(scene_path, params, args.scene_on_workers)
    frames = [None] if args.frames is None else frame_range(scene, args.frames)
    outputs = _outputs(args, frames, args.output)
    first = outputs[frames[0]]
    ckpt_path = Path(args.checkpoint) if args.checkpoint else Path(str(first) + ".ckpt")
    check_checkpoint(args, ckpt_path)
    if args.workers is None and args.scheduler is None:
        args.workers = 1
    scene = replace(scene, film=scene.film.resized(args.width, args.height))
    width, height = scene.film.width, scene.film.height
    iterations, photon = photon_options(args, args.integrator or scene.integrator.kind)
    units_job = UnitsJob(scene, JobOptions(
        integrator=args.integrator, spp=args.spp if iterations is None else iterations,
        seed=args.seed, settings=dict(sampler=args.sampler, max_depth=args.max_depth, rr=args.rr,
                                      rr_depth=args.rr_depth, light_samples=args.light_samples,
                                      split=args.split, strategy=args.strategy,
                                      aovs=any(n in FIRST_HIT_AOVS for n in aov_names)),
        checkpoint=ckpt_path, keep_checkpoint=bool(args.checkpoint or args.resume),
        record={"scene": str(scene_path.resolve()), "glrender": __version__},
        progress_bar=not args.quiet, stats=bool(args.stats),
        info={"glrender": __version__, "scene": str(scene_path), "params": params},
        started=t_start), frames=None if frames == [None] else frames)
    settings = units_job.settings
    cl.check_integrator(settings, photon)
    job = cl.Job(source, settings, width, height, args.device,
                 photon if options_class(settings.integrator.kind) is not None else None)
    # the unit size: --unit-size, else the one the checkpoint recorded (--resume), else
    # the calibrated one (glrender.distributed.calibrate, once the cluster is up)
    unit_size, unit_from, calibration = args.unit_size, "option", None
    if unit_size is None and args.resume:
        unit_size, unit_from = units_job.checkpoint_unit_size(), "checkpoint"
        if unit_size < MIN_UNIT_SIZE:
            raise UsageError(f"{ckpt_path}: the checkpoint's unit size {unit_size} is below "
                             f"{MIN_UNIT_SIZE} pixel-samples: render without --resume to start "
                             f"afresh")

    # -- cluster -----------------------------------------------------------------------------
    for name in ("distributed", "distributed.nanny", "distributed.scheduler",
                 "distributed.worker", "distributed.core"):
        logging.getLogger(name).setLevel(logging.ERROR)
    cluster = None
    if args.scheduler is not None:
        client = cl.connect(args.scheduler, tls=tls if all(tls) else None)
        where = args.scheduler
    else:
        cluster, client = cl.local_cluster(args.workers, threads=args.threads)
        where = f"a local cluster of {args.workers} worker process" + \
                ("es" if args.workers > 1 else "")
    try:
        if unit_size is None:
            from ..distributed import calibrate

            largest, calibration = calibrate.unit_size(client, job, cl.job_future(client, job))
            unit_from = calibration["source"]
            unit_size = cl.make_plan(width, height, settings, None, frames, largest).unit_size
            say(f"glrender: unit size {unit_size} pixel-samples ("
                f"{'calibrated' if unit_from == 'calibrated' else 'from the calibration'} for "
                f"{calibration['key']}, {calibration['cache']})")
        plan = cl.make_plan(width, height, settings, unit_size, frames)
        jid = cl.job_id(job, plan)
        done = units_job.resume(jid, Partial, lambda frame, band: band_layout(
            plan, frame, band, settings.aovs)) if args.resume else {}
        n_workers = len(client.scheduler_info().get("workers", {}))
        say(f"glrender: rendering {scene_path} ({width}x{height}, {settings.sampler.spp} spp, "
            f"{len(frames) if frames != [None] else 'one'} frame{'s' if len(frames) > 1 else ''}, "
            f"{len(plan.units())} units of <= {unit_size} pixel-samples) on {where} "
            f"({n_workers} workers now)")
        if "dashboard" in client.scheduler_info().get("services", {}):
            say(f"glrender: Dask dashboard: {client.dashboard_link}")
        if done:
            say(f"glrender: resuming {ckpt_path}: {len(done)} of "
                f"{len(plan.bands) * len(frames)} bands done")
        signals.defer(True)
        with units_job.units_bar() as progress:
            result = cl.render(scene, client=client, settings=settings, frames=units_job.frames,
                               unit_size=unit_size, device=args.device, done=done,
                               stop=signals.requested, source=source, progress=progress,
                               photon=job.photon)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    def write(films: dict) -> dict:
        return {"outputs": [name for frame in frames for name in
                            write_outputs(films[frame], outputs[frame], aov_names, args)]}

    outcome = units_job.finish(result, jid, write, where={
        "cluster": where, "workers": n_workers, "plan": plan.record(), "unit_size": unit_size,
        "unit_size_from": unit_from, "calibration": calibration, "scene_by": source.mode,
        "scene_hash": source.digest})
    if not result.complete:
        name = signal.Signals(signals.received).name
        if outcome.checkpoint:
            say(f"glrender: stopped by {name}: {len(result.bands)} bands finished -> "
                f"{ckpt_path} (continue with --resume)")
        else:
            say(f"glrender: stopped by {name} before a band finished: nothing written")
        return 128 + signals.received
    if args.stats:
        write_stats(Path(args.stats), outcome.stats)
    rate = outcome.samples_per_second
    speed = f"{rate / 1e6:.2f} Mpaths/s" if rate else "no samples"
    say(f"glrender: {settings.sampler.spp} spp in {result.seconds:.2f} s ({speed}) -> "
        f"{', '.join(outcome.outputs['outputs'])}")
    return 0
