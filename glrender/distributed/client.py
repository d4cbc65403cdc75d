"""The client's side of a distributed render: clusters, task graph, progress, assembly.

Every unit of the plan is one Dask task (``render_unit``); the ranges of a band are
merged by tasks on the workers along the plan's tree (``merge_partials``), so only
each band's final partial reaches the client. Task keys are pure functions of the
job and the unit, so a resubmitted render finds what the cluster still holds. Dask
reschedules the tasks of a worker that dies (its results are recomputed elsewhere),
and since a unit's pixels depend only on the job and the unit, the image stays
bitwise the same.
"""
from __future__ import annotations

import hashlib
import logging
import os
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path

from .. import integrators
from ..errors import MissingExtra, UsageError
from .merge import FrameImage
from .plan import NOMINAL_UNIT_SIZE, Plan, default_unit_size
from .worker import Job, hold, merge_partials, render_unit



def _dask():
    try:
        import distributed
    except ImportError:
        raise MissingExtra("rendering on a cluster", "distributed (Dask)", "distributed") from None
    return distributed


def local_cluster(workers: int, *, threads: int | None = None, dashboard: bool = True):
    """A LocalCluster of ``workers`` spawned processes, one task thread each, listening on
    127.0.0.1 only; llvmpipe gets ``threads`` threads per worker (default: the cores
    shared out). Returns (cluster, client)."""
    distributed = _dask()
    import dask

    if not isinstance(workers, int) or workers < 1:
        raise UsageError(f"--workers {workers}: expected a positive number of worker processes")
    if dask.config.get("distributed.worker.multiprocessing-method") != "spawn":
        raise UsageError("Dask's distributed.worker.multiprocessing-method must be 'spawn' "
                         "(a forked worker hangs in llvmpipe)")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    lp = threads or max(1, (cores or 1) // workers)
    if dashboard:
        try:
            import bokeh  # noqa: F401   the dashboard's dependency
        except ImportError:
            dashboard = False
    cluster = distributed.LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
        # The scheduler's HTTP server (metrics, and the dashboard when asked for) binds
        # a free port: a fixed one (Dask's 8787) warns when two renders run at once.
        dashboard_address="127.0.0.1:0", scheduler_kwargs={"dashboard": dashboard},
        env={"LP_NUM_THREADS": str(lp)}, silence_logs=logging.CRITICAL)
    return cluster, distributed.Client(cluster)


def connect(address: str, *, tls: tuple | None = None, timeout: float = 10.0):
    """A Client of the scheduler at ``address`` (tcp:// or tls://); ``tls`` is
    (ca, cert, key) files for a tls:// scheduler."""
    distributed = _dask()
    security = None
    if tls is not None:
        from distributed.security import Security

        ca, cert, key = tls
        for path, what in ((ca, "--tls-ca"), (cert, "--tls-cert"), (key, "--tls-key")):
            if not Path(path).is_file():
                raise UsageError(f"{what} {path}: no such file")
        security = Security(tls_ca_file=str(ca), tls_client_cert=str(cert),
                            tls_client_key=str(key), require_encryption=True)
    elif address.startswith("tls://"):
        raise UsageError(f"--scheduler {address}: a tls:// scheduler needs --tls-ca, --tls-cert "
                         f"and --tls-key")
    try:
        return distributed.Client(address, security=security, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise UsageError(f"--scheduler {address}: cannot reach the scheduler "
                         f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") \
            from None
    except ValueError as exc:
        raise UsageError(f"--scheduler {address}: {str(exc).splitlines()[0]}") from None


@dataclass
class Result:
    """A distributed render's outcome: ``films`` per frame (None: a still), the plan,
    and what it cost."""

    films: dict
    plan: Plan
    bands: dict = field(default_factory=dict)    # (frame, band) -> final Partial
    complete: bool = True
    seconds: float = 0.0
    unit_seconds: float = 0.0                     # render time summed over the units
    bytes_to_client: int = 0
    calibration: dict | None = None               # how the default unit size was found


def check_integrator(settings, photon=None) -> None:
    kind = settings.integrator.kind
    if not integrators.get(kind).distributed:
        raise UsageError(f"--integrator {kind} does not run on a cluster yet (its iterations "
                         f"depend on each other): render it in one process")
    if getattr(photon, "photon_view", False):
        raise UsageError("--aov photons does not run on a cluster (every worker traces the "
                         "maps and would draw the view again): render it in one process")


def make_plan(width: int, height: int, settings, unit_size: int | None, frames,
              largest: int | None = None) -> Plan:
    """The plan of a render (unit_size None: plan.default_unit_size, with ``largest`` the
    calibrated size). Integrators that splat onto the whole film get whole-frame bands;
    SPPM's renders do not split (the photon integrator's do: each worker traces the maps)."""
    check_integrator(settings)
    kind = settings.integrator.kind
    spp = settings.sampler.spp
    if unit_size is None:
        unit_size = default_unit_size(width, height, spp, len(frames),
                                      largest or NOMINAL_UNIT_SIZE)
    return Plan(width, height, spp, unit_size, tuple(frames), whole_frame=integrators.get(kind).splatting)


def job_hash(job: Job) -> str:
    return hashlib.sha256(pickle.dumps(job.key(None), protocol=4)).hexdigest()[:16]


def job_future(client, job: Job):
    """The task whose result is the job (with the scene's bytes), not scattered data: the
    scheduler keeps its recipe, so a copy lost with a worker is made again; workers fetch
    it from a peer. Its key is a function of the job: every call gets the same task."""
    return client.submit(hold, job, key=f"glrender-{job_hash(job)}-job", pure=False)


def job_id(job: Job, plan: Plan) -> str:
    h = hashlib.sha256(pickle.dumps((job.key(None), plan.record()), protocol=4))
    return h.hexdigest()[:16]


def render(scene, *, client, settings=None, spp: int | None = None, frames=None,
           unit_size: int | None = None, device=None, params: dict | None = None,
           width: int | None = None, height: int | None = None, source=None,
           scene_on_workers: str | None = None, done: dict | None = None, stop=None,
           progress=None, poll: float = 0.2, photon=None) -> Result:
    """Render ``scene`` (a scene file's path, sent to the workers by value, or a Scene,
    sent pickled) on the Dask cluster of ``client``.

    ``params``: the scene file's parameters (-D); ``width``/``height`` override the
    film's size. ``settings`` (RenderSettings; default: the scene's, with ``spp``), ``frames``
    (frame numbers of an animated scene, None: a still), ``unit_size`` (pixel-samples
    per unit; None: calibrated once per device and scene kind, glrender.distributed.calibrate,
    recorded in ``Result.plan`` and ``Result.calibration``; any unit size gives the same
    image), ``device`` (each worker's --device), ``done`` (finished bands
    {(frame, band): Partial} of an earlier run with the same plan, e.g. a checkpoint),
    ``source`` (the SceneSource workers load, when ``scene`` is that source's Scene),
    ``stop()`` (asked while waiting: True ends the render early, with the finished
    bands in the result), ``progress(units_done, units, pixel_samples_done, seconds)``,
    ``photon`` (the integrator's own settings: PhotonSettings, VcmSettings; None: its
    defaults): every worker traces the same photon maps (vcm: the same light passes) from
    the seed, so the image is the one process's.
    """
    distributed = _dask()
    from ..render.job import JobOptions, job_settings
    from ..drivers import options_class
    from . import source as src

    if source is not None:        # a SceneSource of `scene` (a Scene) made by the caller
        scene_obj = scene
    elif isinstance(scene, (str, Path)):
        scene_obj, source = src.from_file(scene, params or {}, scene_on_workers)
    else:
        scene_obj, source = scene, src.from_scene(scene)
    if settings is None:
        settings = job_settings(scene_obj, JobOptions(spp=spp))
    width = scene_obj.film.width if width is None else int(width)
    height = scene_obj.film.height if height is None else int(height)
    frame_list = (None,) if frames is None else tuple(int(f) for f in frames)
    if frames is not None and scene_obj.animation is None:
        raise UsageError(f"{scene_obj.source} has no [animation]: render it without frames")
    if settings.integrator.kind == "photon" and photon is None:
        from ..photon import PhotonSettings

        photon = PhotonSettings()
    check_integrator(settings, photon)
    job = Job(source, settings, width, height, device,
              photon if options_class(settings.integrator.kind) is not None else None)
    done = dict(done or {})
    t0 = time.perf_counter()

    jobf = job_future(client, job)
    calibration = None
    largest = None
    if unit_size is None:
        from . import calibrate

        largest, calibration = calibrate.unit_size(client, job, jobf)
    plan = make_plan(width, height, settings, unit_size, frame_list, largest)
    jid = job_id(job, plan)
    finals, unit_futures = {}, []
    tree = plan.merge_tree()
    for frame in frame_list:
        for band in range(len(plan.bands)):
            if (frame, band) in done:
                continue
            leaves = []
            for unit in plan.band_units(frame, band):
                fut = client.submit(render_unit, jobf, unit, key=f"glrender-{jid}-{unit.name}",
                                    pure=False)
                leaves.append(fut)
                unit_futures.append((fut, plan.unit_pixel_samples(unit)))
            finals[(frame, band)] = _submit_tree(client, tree, leaves,
                                                 f"glrender-{jid}-merge-{frame}-{band}")
    units_total = len(plan.units())
    units_before = units_total - len(unit_futures)
    result = Result({}, plan, bands=done, calibration=calibration)
    pending = dict(finals)
    try:
        while pending:
            try:
                distributed.wait(list(pending.values()), timeout=poll, return_when="FIRST_COMPLETED")
            except (TimeoutError, distributed.TimeoutError):
                pass
            # units counted before bands are collected: a counted unit's band, when it was
            # the band's last, is in the result (a stop keeps every band it reported)
            finished = [ps for f, ps in unit_futures if f.status == "finished"]
            for key, fut in list(pending.items()):
                if fut.status == "finished":
                    part = fut.result()
                    result.bands[key] = part
                    result.bytes_to_client += part.nbytes
                    del pending[key]
                elif fut.status in ("error", "cancelled"):
                    _raise_failure(fut)
            if progress is not None:
                progress(units_before + len(finished), units_total, sum(finished),
                         time.perf_counter() - t0)
            if pending and stop is not None and stop():
                result.complete = False
                break
    finally:
        for fut in list(pending.values()) + [f for f, _ in unit_futures]:
            fut.release()
    result.seconds = time.perf_counter() - t0
    result.unit_seconds = sum(p.seconds for p in result.bands.values())
    if result.complete:
        for frame in frame_list:
            image = FrameImage(width, height, settings.aovs)
            for band, (first, _) in enumerate(plan.bands):
                image.place(band, first, result.bands[(frame, band)])
            result.films[frame] = image.film(settings.sampler.spp, settings.sampler.kind)
    return result


def _raise_failure(fut):
    """A unit's or merge's failure, as the error of the worker (a GlrenderError: a scene
    a worker cannot read, ...) or one line naming what the cluster reported."""
    from ..errors import GlrenderError

    try:
        fut.result()
    except GlrenderError:
        raise
    except Exception as exc:
        text = str(exc).splitlines()[0] if str(exc) else ""
        raise UsageError(f"the cluster failed a task ({type(exc).__name__}{': ' + text if text else ''})"
                         f"; its workers' logs tell why") from exc


def _submit_tree(client, tree, leaves: list, prefix: str):
    """Futures of the merge tree's nodes (merges run on the workers)."""
    if isinstance(tree, int):
        return leaves[tree]
    a = _submit_tree(client, tree[0], leaves, prefix + "a")
    b = _submit_tree(client, tree[1], leaves, prefix + "b")
    return client.submit(merge_partials, a, b, key=prefix, pure=False)
