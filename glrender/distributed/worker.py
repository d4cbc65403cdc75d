"""What runs on a Dask worker: one unit of a render, and the merges of partials.

A worker renders on the thread that runs its tasks. EGL contexts are current on one
thread, so each task thread makes its own context once, lazily, on its first unit
(Dask's executor threads live as long as the worker; glrender starts workers with one
thread each). Renderers (the scene on the device: BVH, buffers, compiled kernel) are
kept per thread under the job's key (scene content hash, settings, image size, frame,
device), so the units of one frame after the first cost no setup.

Workers must be processes of their own (spawned, never forked from a process that
holds a GL context: llvmpipe hangs); ``dask worker`` and glrender's LocalCluster are.
"""
from __future__ import annotations

import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, replace

from .. import integrators
from .merge import Partial, from_state, merge

RENDERERS_PER_THREAD = 2

_local = threading.local()


@dataclass(frozen=True)
class Job:
    """Everything but the unit that decides a unit's pixels."""

    source: object               # glrender.distributed.source.SceneSource
    settings: object             # glrender.render.renderer.RenderSettings
    width: int
    height: int
    device: str | int | None = None
    photon: object = None        # glrender.photon.PhotonSettings (--integrator photon)

    def key(self, frame) -> tuple:
        return (self.source.digest, repr(self.settings), self.width, self.height,
                str(self.device), frame, repr(self.photon))


def _context(device):
    from ..gl.context import create_context, parse_device

    contexts = getattr(_local, "contexts", None)
    if contexts is None:
        contexts = _local.contexts = {}
    key = str(parse_device(device))
    if key not in contexts:
        contexts[key] = create_context(device)
    return contexts[key]


def _renderer(job: Job, frame):
    from ..drivers import create_driver
    from ..render.job import make_driver
    from ..scene.animation import scene_at_frame
    from .source import load_source

    cache = getattr(_local, "renderers", None)
    if cache is None:
        cache = _local.renderers = OrderedDict()
    key = job.key(frame)
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    scene = load_source(job.source)
    if frame is not None:
        scene = scene_at_frame(scene, frame)
    if (scene.film.width, scene.film.height) != (job.width, job.height):
        scene = replace(scene, film=replace(scene.film, width=job.width, height=job.height))
    # photon mapping: every worker traces the same maps from the seed (sorted into one
    # order), so each renders its pixels as one process would
    renderer = make_driver(scene, job.settings, create_driver, job.photon,
                           ctx=_context(job.device))
    cache[key] = renderer
    while len(cache) > RENDERERS_PER_THREAD:
        cache.popitem(last=False)[1].release()
    return renderer


def render_unit(job: Job, unit) -> Partial:
    """Samples ``unit.samples`` of tile rows ``unit.rows`` of frame ``unit.frame``."""
    r = _renderer(job, unit.frame)
    start, stop = unit.samples
    t0 = time.perf_counter()
    r.reset(start=start, rows=unit.rows)
    r.step(stop - start)
    state = r.state()
    seconds = time.perf_counter() - t0
    return from_state(state, r.width * r.band_height, job.settings.aovs, unit.samples, seconds,
                      splat=integrators.get(job.settings.integrator.kind).splatting)


def hold(job: Job) -> Job:
    """The task whose result is the job, on the workers that need it."""
    return job


def merge_partials(a: Partial, b: Partial) -> Partial:
    """A merge-tree node (runs on a worker: partial images never pass through the client)."""
    return merge(a, b)


def worker_info() -> dict:
    """The worker's process and device (for tests and messages)."""
    import os

    ctx = _context(None)
    return {"pid": os.getpid(), "renderer": ctx.renderer,
            "lp_num_threads": os.environ.get("LP_NUM_THREADS")}
