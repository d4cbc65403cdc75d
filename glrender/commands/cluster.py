"""``glrender render`` on a Dask cluster: ``--workers N``, ``--scheduler ADDRESS``, ``--frames A:B``.

Everything is checked before the cluster starts (options, outputs, scene file); the
scene is loaded here once (its errors and warnings read as in a single-process render),
then sent to the workers. Outputs are written when the whole frame is merged, so an
error or an interrupt leaves no partial image; Ctrl-C (or SIGTERM) writes a checkpoint
of the finished bands, which ``--resume`` continues (bitwise the same final image).
"""
from __future__ import annotations

import json
import logging
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..distributed.merge import Partial

CHECKPOINT_FORMAT = "glrender-distributed-checkpoint"
CHECKPOINT_VERSION = 2    # 2: exact fixed-point sums per band (1: float32 means and M2)
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


def _save_checkpoint(path: Path, meta: dict, bands: dict) -> None:
    from ..film.io import atomic_write

    arrays = {}
    for (frame, band), p in bands.items():
        tag = f"{'s' if frame is None else frame}_{band}"
        arrays[f"sums_{tag}"] = p.sums
        arrays[f"squares_{tag}"] = p.squares
        if p.aov is not None:
            arrays[f"aov_{tag}"] = p.aov
        if p.splat is not None:
            arrays[f"splat_{tag}"] = p.splat
    meta = {**meta, "format": CHECKPOINT_FORMAT, "version": CHECKPOINT_VERSION,
            "bands": [[frame, band, list(p.samples)] for (frame, band), p in bands.items()]}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)

    atomic_write(path, write)


def _open_checkpoint(path: Path):
    """A distributed checkpoint of this version: (its record, its arrays: an open npz)."""
    import zipfile

    if not path.is_file():
        raise UsageError(f"{path}: no checkpoint to resume (render without --resume to start, "
                         f"or name the file with --checkpoint)")
    try:
        z = np.load(path, allow_pickle=False)
        meta = json.loads(str(z["meta"]))
        if not isinstance(meta, dict) or meta.get("format") != CHECKPOINT_FORMAT:
            raise ValueError("not a distributed render's checkpoint")
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise UsageError(f"{path}: not a readable checkpoint ({exc})") from None
    if meta.get("version") != CHECKPOINT_VERSION:
        z.close()
        raise UsageError(f"{path}: a distributed checkpoint of version {meta.get('version')}, "
                         f"this glrender reads version {CHECKPOINT_VERSION} (render without "
                         f"--resume)")
    return meta, z


def _checkpoint_unit_size(path: Path) -> int:
    """The unit size a checkpoint's render used (its plan record)."""
    meta, z = _open_checkpoint(path)
    z.close()
    try:
        return int(meta["plan"]["unit_size"])
    except (KeyError, TypeError, ValueError) as exc:
        raise UsageError(f"{path}: not a readable checkpoint (no unit size: {exc})") from None


def _load_checkpoint(path: Path, job: str) -> dict:
    meta, z = _open_checkpoint(path)
    with z:
        if meta.get("job") != job:
            raise UsageError(f"{path}: the checkpoint belongs to another scene, other "
                             f"settings or another unit size (render without --resume)")
        try:
            bands = {}
            for frame, band, samples in meta["bands"]:
                tag = f"{'s' if frame is None else frame}_{band}"
                aov = z[f"aov_{tag}"] if f"aov_{tag}" in z.files else None
                splat = z[f"splat_{tag}"] if f"splat_{tag}" in z.files else None
                bands[(frame, band)] = Partial(z[f"sums_{tag}"], z[f"squares_{tag}"], aov,
                                               tuple(samples), splat=splat)
            return bands
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise UsageError(f"{path}: not a readable checkpoint ({exc})") from None


class _UnitsBar:
    """One aggregated line: units finished of all, samples/s over the cluster."""

    def __init__(self, stream):
        from ..render.progress import format_seconds

        self.stream, self.fmt, self.last = stream, format_seconds, 0.0

    def update(self, done, total, pixel_samples, seconds, force=False):
        now = time.monotonic()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        width = 30
        filled = int(round(width * done / max(total, 1)))
        rate = pixel_samples / seconds / 1e6 if seconds > 0 else 0.0
        self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} units  "
                          f"{rate:.2f} Msamples/s  {self.fmt(seconds)} elapsed\033[K")
        self.stream.flush()

    def close(self):
        self.stream.write("\n")
        self.stream.flush()


def run_distributed(args, signals) -> int:
    from .. import __version__
    from .options import (FIRST_HIT_AOVS, check_options, check_scene_file, parse_aovs,
                          parse_defines)
    from .outputs import write_outputs, write_stats
    from .photon_options import photon_options
    from ..render.job import JobOptions, job_settings
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
    if args.workers is None and args.scheduler is None:
        args.workers = 1
    scene = replace(scene, film=scene.film.resized(args.width, args.height))
    width, height = scene.film.width, scene.film.height
    iterations, photon = photon_options(args, args.integrator or scene.integrator.kind)
    settings = job_settings(scene, JobOptions(
        integrator=args.integrator, spp=args.spp if iterations is None else iterations,
        seed=args.seed, settings=dict(sampler=args.sampler, max_depth=args.max_depth, rr=args.rr,
                                      rr_depth=args.rr_depth, light_samples=args.light_samples,
                                      split=args.split, strategy=args.strategy,
                                      aovs=any(n in FIRST_HIT_AOVS for n in aov_names))))
    cl.check_integrator(settings, photon)
    job = cl.Job(source, settings, width, height, args.device,
                 photon if settings.integrator.kind == "photon" else None)
    # the unit size: --unit-size, else the one the checkpoint recorded (--resume), else
    # the calibrated one (glrender.distributed.calibrate, once the cluster is up)
    unit_size, unit_from, calibration = args.unit_size, "option", None
    if unit_size is None and args.resume:
        unit_size, unit_from = _checkpoint_unit_size(ckpt_path), "checkpoint"

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
        done = _load_checkpoint(ckpt_path, jid) if args.resume else {}
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
        bar = _UnitsBar(sys.stderr) if not args.quiet and sys.stderr.isatty() else None
        signals.defer(True)
        try:
            result = cl.render(scene, client=client, settings=settings, frames=None if frames ==
                               [None] else frames, unit_size=unit_size, device=args.device,
                               done=done, stop=signals.requested, source=source,
                               progress=bar.update if bar is not None else None,
                               photon=job.photon)
        finally:
            if bar is not None:
                bar.close()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    meta = {"job": jid, "plan": plan.record(), "scene": str(scene_path.resolve()),
            "glrender": __version__}
    if not result.complete:
        name = signal.Signals(signals.received).name
        if result.bands:
            _save_checkpoint(ckpt_path, meta, result.bands)
            say(f"glrender: stopped by {name}: {len(result.bands)} bands finished -> "
                f"{ckpt_path} (continue with --resume)")
        else:
            say(f"glrender: stopped by {name} before a band finished: nothing written")
        return 128 + signals.received
    written = []
    for frame in frames:
        written += write_outputs(result.films[frame], outputs[frame], aov_names, args)
    if args.checkpoint or args.resume:
        _save_checkpoint(ckpt_path, meta, result.bands)
    rate = plan.pixel_samples / result.seconds if result.seconds > 0 else None
    if args.stats:
        write_stats(Path(args.stats), {
            "glrender": __version__, "scene": str(scene_path), "params": params,
            "outputs": written, "cluster": where, "workers": n_workers, "plan": plan.record(),
            "unit_size": unit_size, "unit_size_from": unit_from, "calibration": calibration,
            "scene_by": source.mode, "scene_hash": source.digest,
            "width": width, "height": height, "integrator": settings.integrator.kind,
            "sampler": settings.sampler.kind, "seed": settings.sampler.seed,
            "spp": settings.sampler.spp, "frames": frames if frames != [None] else None,
            "resumed_bands": len(done),
            "seconds": {"render": result.seconds, "units": result.unit_seconds,
                        "total": time.perf_counter() - t_start},
            "samples_per_second": rate, "bytes_to_client": result.bytes_to_client,
            "nonfinite_samples": int(sum(f.nonfinite_total for f in result.films.values()))})
    speed = f"{rate / 1e6:.2f} Mpaths/s" if rate else "no samples"
    say(f"glrender: {settings.sampler.spp} spp in {result.seconds:.2f} s ({speed}) -> "
        f"{', '.join(written)}")
    return 0
