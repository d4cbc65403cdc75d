"""A render job, start to end: settings -> driver -> progress -> checkpoints -> stats.

:class:`Job` is the one runner the command line, :func:`glrender.render`, the preview and
the cluster worker use. From a scene and its :class:`JobOptions` it

- builds the settings (:func:`job_settings`: the scene's, with the job's overrides) and
  the sample target (open-ended under a time budget without a sample count);
- plans the sample count from an independent pilot (``noise_threshold``), then makes the
  driver through the factory it is given (:func:`make_driver`);
- continues a checkpoint (``resume``: refused for another scene or other settings);
- runs :class:`RenderJob`'s passes, drawing the progress bar and calling ``on_pass``,
  writing a checkpoint every ``checkpoint_every`` seconds (one that cannot be written is
  warned of once, and the render goes on);
- hands the film to the caller's ``outputs`` while the driver still holds the
  accumulation, writes the last checkpoint (always after a stop) and gathers the
  statistics (``--stats``, ``film.stats``): timings, samples, samples/s, memory, and the
  driver's own entries. When ``outputs`` cannot write its files (a
  :class:`~glrender.film.io.WriteError`), the checkpoint is written all the same, so no
  sample is lost, and the error says where they are kept;
- renders ``--denoise``'s seen-emission pass for a film (:meth:`Job.seen_emission`): the
  job's settings at the film's sample count, its crop, its driver's scene data.

:class:`UnitsJob` is the same assembly for a render whose samples run elsewhere, in units
that come back as finished bands (``glrender render --workers/--scheduler/--frames``, on
the Dask cluster of :mod:`glrender.distributed`): the caller runs the units, reporting
their progress to the job's bar (:meth:`UnitsJob.units_bar`) and their result to
:meth:`UnitsJob.finish`, which writes the checkpoint of the finished bands (after a stop;
at the end with ``keep_checkpoint``), hands the films to the caller's ``outputs`` and
gathers the statistics; :meth:`UnitsJob.resume` takes a checkpoint's bands back. The bands
are the cluster's objects (``Partial``), which the job reads by attribute and makes again
with the ``make_band`` it is given: the cluster sits above ``render/``.

The job makes its driver with a factory it receives (:func:`glrender.drivers.create_driver`
for every caller): the driver table sits above the drivers, which this module is one of
(``render/``), so the dependency points down, as the layers in ``pyproject.toml`` want.

:class:`RenderJob` is the pass loop itself:

- it stops at ``spp_target``, or before a pass that would end past ``seconds`` (judged by
  the last pass's duration), so a time budget ends within one pass of its mark; a pass
  that runs past the budget anyway is undone between dispatches (the first pass of a run
  always completes, so a run adds samples even when one pass outlasts the budget);
- ``stop()`` is asked between dispatches (at most ~``time_target``, 0.1 s, apart): when it
  answers True the pass in progress is undone and the run ends, the accumulation at a
  whole pass, ready for a checkpoint;
- ``checkpoint()`` is called after the pass that ends ``checkpoint_every`` seconds after
  the last one; it returns False when it could not write one (not counted).
"""
from __future__ import annotations

import sys
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterator, Protocol

from .. import integrators
from ..errors import UsageError
from ..film import Film
from ..film.io import WriteError
from ..gpu.capacity import device_limits
from .checkpoint import (BandLayout, Checkpoint, band_checkpoint_unit_size,
                         load_band_checkpoint, restore_checkpoint, save_band_checkpoint,
                         save_checkpoint)
from .driver import RenderDriver
from .emission_pass import render_seen_emission
from .noise import crop_band, crop_rows, mean_relative_stderr
from .progress import ProgressBar, UnitsBar
from .renderer import RenderSettings, settings_from_scene

#: ``create_driver(scene, settings, options=None, *, ctx=None, device=None, share=None)``:
#: the driver of ``settings.integrator.kind`` (:func:`glrender.drivers.create_driver`)
DriverFactory = Callable[..., RenderDriver]

# sample indices are 32-bit on the device: the open-ended target of a time budget
SPP_LIMIT = 1 << 31
# the phases of a job's stats["seconds"], in order
PHASES = ("load", "context", "pack", "build", "compile", "render", "checkpoint", "denoise",
          "write", "total")


@dataclass
class JobResult:
    stopped: str                 # "complete", "time" or "interrupted"
    spp_start: int
    spp_done: int
    passes: int
    seconds: float               # wall time of the run, checkpoints included
    checkpoint_seconds: float
    pass_seconds_max: float
    checkpoints: int = 0
    pass_seconds: list = field(default_factory=list)

    @property
    def render_seconds(self) -> float:
        return self.seconds - self.checkpoint_seconds


class RenderJob:
    """Run ``renderer`` from its current sample count up to ``spp_target`` samples per
    pixel, within ``seconds`` if given. ``progress(spp_done, elapsed)`` after each pass."""

    def __init__(self, renderer, spp_target: int, *, seconds: float | None = None,
                 stop=None, checkpoint=None, checkpoint_every: float | None = None,
                 progress=None, clock=time.perf_counter):
        self.renderer = renderer
        self.spp_target = int(spp_target)
        self.seconds = seconds
        self.stop = stop or (lambda: False)
        self.checkpoint = checkpoint
        self.checkpoint_every = checkpoint_every
        self.progress = progress
        self.clock = clock

    def run(self) -> JobResult:
        r, clock = self.renderer, self.clock
        start = clock()
        spp_start = r.spp_done
        result = JobResult("complete", spp_start, spp_start, 0, 0.0, 0.0, 0.0)
        last_checkpoint = start

        def past_budget() -> bool:
            # only once this run has a pass: a run always adds samples
            return (self.seconds is not None and r.spp_done > spp_start
                    and clock() - start >= self.seconds)

        def should_stop() -> bool:
            return self.stop() or past_budget()

        while r.spp_done < self.spp_target:
            if self.stop():
                result.stopped = "interrupted"
                break
            if self.seconds is not None and result.pass_seconds and \
                    clock() - start + result.pass_seconds[-1] > self.seconds:
                result.stopped = "time"
                break
            k = min(r.samples_per_pass, self.spp_target - r.spp_done)
            t0 = clock()
            if r.step(k, should_stop=should_stop) == 0:
                result.stopped = "interrupted" if self.stop() else "time"
                break
            now = clock()
            result.pass_seconds.append(now - t0)
            result.passes += 1
            if self.progress is not None:
                self.progress(r.spp_done, now - start)
            if self.checkpoint is not None and self.checkpoint_every is not None and \
                    now - last_checkpoint >= self.checkpoint_every and r.spp_done < self.spp_target:
                written = self.checkpoint()
                last_checkpoint = clock()
                result.checkpoint_seconds += last_checkpoint - now
                result.checkpoints += written is not False
        result.spp_done = r.spp_done
        result.seconds = clock() - start
        result.pass_seconds_max = max(result.pass_seconds, default=0.0)
        return result


class Timings(dict):
    """Seconds by phase; ``with timings("write"): ...`` adds the block's time to "write"."""

    @contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self[name] = self.get(name, 0.0) + time.perf_counter() - t0


@dataclass
class JobOptions:
    """What a job is asked for besides its scene; None keeps the scene's value."""

    # -- settings ---------------------------------------------------------------------------
    integrator: str | None = None
    spp: int | None = None                  # None with ``seconds``: until the budget ends
    seed: int | None = None
    #: further keywords of settings_from_scene (sampler, max_depth, strategy, aovs, clamp, ...)
    settings: dict[str, Any] = field(default_factory=dict)
    #: the integrator's own settings (PhotonSettings, SppmSettings; None: its defaults)
    integrator_options: Any = None
    # -- the run ----------------------------------------------------------------------------
    seconds: float | None = None            # time budget of the passes
    stop: Callable[[], bool] | None = None  # asked between dispatches: True ends the run
    stopped_by: Callable[[], str] | None = None   # names what stopped it (stats["signal"])
    crop: list[int] | None = None           # [x0, y0, x1, y1]: render and keep these pixels
    noise_threshold: float | None = None    # plan the spp from a pilot (glrender.render.noise)
    ctx: Any = None                         # the GL context (None: the device's default one)
    device: str | int | None = None
    # -- checkpoints ------------------------------------------------------------------------
    checkpoint: Path | None = None          # where checkpoints go (None: none are written)
    checkpoint_every: float | None = None   # seconds between periodic checkpoints
    keep_checkpoint: bool = False           # periodic ones and one at the end (else: on a stop)
    resume: Checkpoint | None = None        # continue this checkpoint
    #: JSON the checkpoints carry (the command: the options a resume takes back); the job
    #: adds the device (unless given) and the sample target
    record: dict[str, Any] = field(default_factory=dict)
    # -- reports ----------------------------------------------------------------------------
    name: str = "scene"                     # the scene in messages
    say: Callable[[str], None] | None = None    # one line of news (pilot, start, resume)
    progress_bar: bool = False              # a bar on standard error when it is a terminal
    on_pass: Callable[[int, float], None] | None = None   # (spp_done, seconds) after a pass
    stats: bool = True                      # gather the statistics
    info: dict[str, Any] = field(default_factory=dict)   # entries that open the statistics
    timings: Timings = field(default_factory=Timings)    # phases timed before (load); the
                                                         # job adds its own
    started: float | None = None            # perf_counter() at the start, for "total"


def job_settings(scene: Any, options: JobOptions) -> RenderSettings:
    """The scene's render settings with the job's overrides."""
    return settings_from_scene(scene, integrator=options.integrator, spp=options.spp,
                               seed=options.seed, **options.settings)


def make_driver(scene: Any, settings: RenderSettings, create_driver: DriverFactory,
                integrator_options: Any = None, *, ctx: Any = None,
                device: str | int | None = None, share: Any = None) -> RenderDriver:
    """The driver of ``settings`` for ``scene``, from ``create_driver``; an image whose
    buffers the device cannot allocate is refused with what to change."""
    import moderngl

    try:
        return create_driver(scene, settings, integrator_options, ctx=ctx, device=device,
                             share=share)
    except moderngl.Error as exc:
        raise UsageError(f"cannot allocate the device buffers of a {scene.film.width}x"
                         f"{scene.film.height} image ({str(exc).strip()}): render fewer pixels "
                         f"(--width/--height)") from exc


@dataclass
class JobOutcome:
    """What a job made: the film (cropped), the pass loop's account, the statistics."""

    film: Film
    run: JobResult
    samples_per_second: float | None        # new samples of this run over its render time
    checkpoint: str | None = None           # the checkpoint written at the end
    outputs: dict[str, Any] = field(default_factory=dict)   # what ``outputs`` returned
    stats: dict[str, Any] | None = None
    #: the depth cap (segments) that could end this render's paths: max depth unbounded or
    #: beyond the integrator's cap (IntegratorSpec.depth_cap); None otherwise
    depth_cap: int | None = None

    @property
    def stopped(self) -> str:
        return self.run.stopped


class Job:
    """One render of ``scene`` as ``options`` ask, its driver made by ``create_driver``.
    Construction builds the settings and the driver and resumes; :meth:`run` renders;
    leaving the ``with`` block (or :meth:`release`) frees the driver."""

    def __init__(self, scene: Any, options: JobOptions, create_driver: DriverFactory):
        self.scene, self.options = scene, options
        self.timings = options.timings
        self.started = time.perf_counter() if options.started is None else options.started
        self.say = options.say or (lambda text: None)
        #: how the last run ended ("complete", "time", "interrupted"), known before
        #: ``outputs`` is called (a stopped run's image is partial)
        self.stopped: str | None = None
        self._checkpoint_failed = False
        self.settings = job_settings(scene, options)
        spec = integrators.get(self.settings.integrator.kind)
        open_ended = options.spp is None and options.seconds is not None and spec.open_ended
        self.target = SPP_LIMIT if open_ended else self.settings.sampler.spp
        if options.crop is not None and spec.splatting:
            raise UsageError(f"--crop: not available with the {self.settings.integrator.kind} "
                             f"integrator (its light paths reach every pixel of the film)")
        self.noise_plan, pilot = None, None
        if options.noise_threshold is not None and options.resume is None:
            pilot = self._pilot()
        try:
            self.driver = make_driver(scene, self.settings, create_driver,
                                      options.integrator_options, ctx=options.ctx,
                                      device=options.device, share=pilot)
        finally:
            if pilot is not None:
                pilot.release()
        self.ctx = self.driver.ctx
        self.timings.update(self.driver.timings)
        try:
            if options.crop is not None:   # the tile rows the crop covers; columns are cut in film()
                self.driver.reset(rows=crop_rows(options.crop))
            self.spp_resumed = self._resume(options.resume) if options.resume is not None \
                else None
        except BaseException:
            self.release()
            raise

    def _pilot(self) -> RenderDriver:
        """Plan the sample count from an independent pilot; the pilot's driver, whose scene
        data the render shares."""
        from .noise import run_pilot

        o = self.options
        ctx = o.ctx
        if ctx is None:
            from ..gl.context import default_context

            ctx = default_context(o.device)
        plan, pilot = run_pilot(self.scene, self.settings, o.noise_threshold, ctx=ctx,
                                max_spp=o.spp, region=o.crop)
        self.say(f"glrender: pilot of {plan.pilot_spp} spp ({plan.pilot_seconds:.2f} s): "
                 f"{plan.spp} spp for a mean relative error of {plan.threshold:g}")
        self.noise_plan, self.target = plan, plan.spp
        self.settings = replace(self.settings, sampler=replace(self.settings.sampler,
                                                               spp=plan.spp))
        return pilot

    def _resume(self, ckpt: Checkpoint) -> int:
        spp = restore_checkpoint(ckpt, self.driver)
        if ckpt.meta.get("device") != self.ctx.renderer:
            warnings.warn(f"{ckpt.path} was rendered on {ckpt.meta.get('device')!r}, this run on "
                          f"{self.ctx.renderer!r}: the image will not be bitwise the same as one "
                          f"uninterrupted render", stacklevel=1)
        return spp

    # -- the render -------------------------------------------------------------------------
    @property
    def spp_target(self) -> int | None:
        """The sample target; None: open-ended (until the time budget ends)."""
        return None if self.target == SPP_LIMIT else self.target

    def film(self) -> Film:
        """The accumulation so far (the crop's pixels with a crop)."""
        film = self.driver.film()
        crop = self.options.crop
        return crop_band(film, crop, self.driver.rows) if crop is not None else film

    def seen_emission(self, film: Film) -> Film | None:
        """The seen-emission pass of a denoised render of ``film``
        (:func:`~glrender.render.emission_pass.render_seen_emission`): the job's settings at
        the film's samples per pixel (which a time budget or a resume may make other than
        the target), the job's crop, the scene data its driver holds. Its film (the crop's
        pixels with a crop), or None where the pass has nothing to add."""
        settings = replace(self.settings, sampler=replace(self.settings.sampler, spp=film.spp))
        crop = self.options.crop
        rows = crop_rows(crop) if crop is not None else None
        seen = render_seen_emission(self.scene, settings, ctx=self.ctx, rows=rows,
                                    share=self.driver)
        return crop_band(seen, crop, rows) if seen is not None and crop is not None else seen

    def write_checkpoint(self) -> None:
        """The accumulation (whole passes) and the record to ``options.checkpoint``, with
        the device (a resume elsewhere is warned of) and the sample target."""
        record = dict(self.options.record)
        record.setdefault("device", self.ctx.renderer)
        with self.timings("checkpoint"):
            save_checkpoint(self.options.checkpoint, self.driver, **record,
                            spp_target=self.spp_target)

    def _periodic_checkpoint(self) -> bool:
        """A checkpoint between passes; one that cannot be written is warned of (the first
        time, in one line) and the render goes on. Whether it was written."""
        try:
            self.write_checkpoint()
            return True
        except WriteError as exc:
            if not self._checkpoint_failed:
                warnings.warn(f"{exc}: the render goes on, trying again every "
                              f"{self.options.checkpoint_every:g} s", stacklevel=1)
            self._checkpoint_failed = True
            return False

    def run(self, outputs: Callable[[Film], dict[str, Any]] | None = None) -> JobOutcome:
        """Passes until the target, the time budget or a stop; then ``outputs(film)`` (the
        caller's files; the entries it returns join the statistics) when the film has
        samples, the last checkpoint and the statistics."""
        o, r = self.options, self.driver
        width, height = self.scene.film.width, self.scene.film.height
        budget = f", at most {o.seconds:g} s" if o.seconds is not None else ""
        goal = f"{self.target} spp" if self.spp_target is not None else "open-ended spp"
        self.say(f"glrender: rendering {o.name} ({width}x{height}, {goal}{budget}, "
                 f"{self.settings.integrator.kind}, {self.settings.sampler.kind} sampler, seed "
                 f"{self.settings.sampler.seed}) on {self.ctx.renderer}")
        if self.spp_resumed is not None:
            self.say(f"glrender: resuming {o.resume.path} at {self.spp_resumed} spp")
        bar = None
        if o.progress_bar and sys.stderr is not None and sys.stderr.isatty():
            bar = ProgressBar(sys.stderr, pixels=width * height, spp_start=r.spp_done,
                              spp_target=self.spp_target, seconds=o.seconds)
            bar.update(r.spp_done, 0.0, force=True)

        def after_pass(spp_done: int, seconds: float) -> None:
            if bar is not None:
                bar.update(spp_done, seconds)
            if o.on_pass is not None:
                o.on_pass(spp_done, seconds)

        keep = o.keep_checkpoint and o.checkpoint is not None
        job = RenderJob(r, self.target, seconds=o.seconds, stop=o.stop,
                        checkpoint=self._periodic_checkpoint if keep else None,
                        checkpoint_every=o.checkpoint_every, progress=after_pass)
        try:
            result = job.run()
            if bar is not None:
                bar.update(r.spp_done, result.seconds, force=True)
        finally:
            if bar is not None:
                bar.close()
        self.timings["render"] = result.render_seconds
        self.stopped = result.stopped

        film = self.film()
        new_samples = (result.spp_done - result.spp_start) * r.width * r.band_height
        rate = new_samples / result.render_seconds if result.render_seconds > 0 else None
        spec = integrators.get(self.settings.integrator.kind)
        cap = spec.depth_cap if spec.cap_binds(self.settings.integrator.max_depth) else None
        outcome = JobOutcome(film, result, rate, depth_cap=cap)
        if film.spp > 0:
            if outputs is not None:
                try:
                    outcome.outputs = outputs(film)
                except WriteError as exc:
                    raise _kept(exc, o.checkpoint, self.write_checkpoint) from exc
            if o.checkpoint is not None and (result.stopped == "interrupted" or o.keep_checkpoint):
                self.write_checkpoint()
                outcome.checkpoint = str(o.checkpoint)
        self.timings["total"] = time.perf_counter() - self.started
        if o.stats:
            outcome.stats = self.stats(outcome)
        return outcome

    def stats(self, outcome: JobOutcome) -> dict[str, Any]:
        """The statistics of a run (``--stats``, ``film.stats``): ``options.info``, then what
        the job knows, the entries ``outputs`` returned, and the driver's own."""
        o, r, s, ctx = self.options, self.driver, self.settings, self.ctx
        film, result, plan = outcome.film, outcome.run, self.noise_plan
        interrupted = result.stopped == "interrupted"
        stats = {
            **o.info, "outputs": [], "checkpoint": outcome.checkpoint,
            "device": {"GL_RENDERER": ctx.renderer, "GL_VERSION": ctx.gl.info["GL_VERSION"],
                       "index": ctx.device.index, "kind": ctx.device.kind},
            "scene_hash": r.fingerprint(),
            "width": self.scene.film.width, "height": self.scene.film.height,
            "integrator": s.integrator.kind, "strategy": s.integrator.strategy,
            "max_depth": s.integrator.max_depth, "sampler": s.sampler.kind,
            "seed": s.sampler.seed, "spp": film.spp, "spp_target": self.spp_target,
            "spp_this_run": result.spp_done - result.spp_start,
            "resumed_from_spp": self.spp_resumed, "time_budget": o.seconds,
            "samples_per_pass": r.samples_per_pass, "passes": result.passes,
            "pass_seconds_max": result.pass_seconds_max, "checkpoints_written": result.checkpoints,
            "stopped": result.stopped,
            "signal": o.stopped_by() if interrupted and o.stopped_by is not None else None,
            "seconds": {k: self.timings.get(k, 0.0) for k in PHASES},
            "denoise": None,
            "crop": o.crop, "clamp": s.clamp, "biased": s.clamp is not None,
            "memory": {"device_bytes_per_pixel": r.device_bytes_per_pixel(),
                       "device_accumulation_bytes": r.device_bytes_per_pixel()
                       * r.width * r.band_height,
                       "slices": len(r.slices()),
                       "texture_bytes": r.texture_bytes},
            "bvh_cache": r.bvh_cache,
            "mesh": r.mesh_capacity,
            "device_limits": device_limits(ctx.gl.info),
            "noise_threshold": None if plan is None else {
                "threshold": plan.threshold, "pilot_spp": plan.pilot_spp,
                "pilot_error": plan.pilot_error, "pilot_seconds": plan.pilot_seconds,
                "planned_spp": plan.spp, "predicted_error": plan.predicted_error()},
            "samples_per_second": outcome.samples_per_second,
            "nonfinite_samples": film.nonfinite_total,
            "depth_cap": outcome.depth_cap, "truncated_paths": film.truncated_total,
            "mean_relative_stderr": mean_relative_stderr(film),
            "stderr_is_upper_bound": s.sampler.kind != "independent",
            "mean": [float(v) for v in film.mean.reshape(-1, 3).mean(0)],
        }
        stats.update(outcome.outputs)
        stats.update(r.stats())         # photon, sppm: maps, radii, lookups, memory
        return stats

    def release(self) -> None:
        """Free the driver's device resources."""
        if getattr(self, "driver", None) is not None:
            self.driver.release()
            self.driver = None

    def __enter__(self) -> "Job":
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _kept(error: WriteError, checkpoint: Path | None, write: Callable[[], None]) -> WriteError:
    """``error`` (an output that could not be written) after keeping the render in
    ``checkpoint`` with ``write``: the error to raise, saying where the samples are."""
    if checkpoint is None:
        return error
    try:
        write()
    except WriteError as again:
        return WriteError(f"{error}, nor the checkpoint ({again}): the render is lost")
    return WriteError(f"{error}; the render is kept in {checkpoint}: when the file can be "
                      f"written, --resume writes it")


# -- a render whose samples run elsewhere, in units ------------------------------------------

class UnitsResult(Protocol):
    """What a run of units reports (:class:`glrender.distributed.client.Result`)."""

    films: dict             # frame (None: a still) -> its merged Film; empty after a stop
    bands: dict             # (frame, band) -> the band's accumulation (a Partial): sums,
                            # squares, aov, splat, samples
    complete: bool          # False: stopped before every band finished
    seconds: float          # wall time of the run
    unit_seconds: float     # render time summed over the units
    bytes_to_client: int
    plan: Any               # .pixel_samples (all frames), .record() (JSON)


@dataclass
class UnitsOutcome:
    """What :meth:`UnitsJob.finish` made of a run of units."""

    units: UnitsResult
    samples_per_second: float | None        # the plan's pixel-samples over the run's time
    checkpoint: str | None = None           # the checkpoint written
    outputs: dict[str, Any] = field(default_factory=dict)   # what ``outputs`` returned
    stats: dict[str, Any] | None = None


class UnitsJob:
    """One render of ``scene`` as ``options`` ask whose units the caller runs elsewhere
    (``frames``: an animation's frame numbers, None: a still). Of the options it reads the
    settings, ``checkpoint``, ``keep_checkpoint`` and ``record``, ``progress_bar``,
    ``stats``, ``info``, ``timings`` and ``started``."""

    def __init__(self, scene: Any, options: JobOptions, frames: list[int] | None = None):
        self.scene, self.options, self.frames = scene, options, frames
        self.timings = options.timings
        self.started = time.perf_counter() if options.started is None else options.started
        self.settings = job_settings(scene, options)
        self.resumed_bands = 0

    def checkpoint_unit_size(self) -> int:
        """The unit size the render in ``options.checkpoint`` used (a resume plans the same
        units)."""
        return band_checkpoint_unit_size(self.options.checkpoint)

    def resume(self, job_id: str, make_band: Callable[..., Any],
               expect: BandLayout | None = None) -> dict:
        """The finished bands of ``options.checkpoint`` (refused unless it holds ``job_id``,
        the same scene, settings and plan, and unless each band's arrays are those
        ``expect(frame, band)`` describes), made by ``make_band(sums, squares, aov,
        samples, splat=...)``."""
        bands = load_band_checkpoint(self.options.checkpoint, job_id, make_band, expect)
        self.resumed_bands = len(bands)
        return bands

    @contextmanager
    def units_bar(self) -> Iterator[Callable[[int, int, int, float], None] | None]:
        """While the units run: the progress callback (units done, units, pixel-samples
        done, seconds) that draws the units bar on standard error when it is a terminal
        (``options.progress_bar``), else None."""
        bar = None
        if self.options.progress_bar and sys.stderr is not None and sys.stderr.isatty():
            bar = UnitsBar(sys.stderr)
        try:
            yield None if bar is None else bar.update
        finally:
            if bar is not None:
                bar.close()

    def write_checkpoint(self, bands: dict, job_id: str, plan: Any) -> None:
        """The finished ``bands`` to ``options.checkpoint``, recorded as ``job_id``'s with
        ``plan``'s record and ``options.record``."""
        record = {"job": job_id, "plan": plan.record(), **self.options.record}
        save_band_checkpoint(self.options.checkpoint, record, bands)

    def finish(self, units: UnitsResult, job_id: str,
               outputs: Callable[[dict], dict[str, Any]] | None = None,
               where: dict[str, Any] | None = None) -> UnitsOutcome:
        """After the run of units: a stopped run's finished bands to the checkpoint (when
        there are some); a complete run's films to ``outputs`` (the caller's files; the
        entries it returns join the statistics), its bands to the checkpoint with
        ``keep_checkpoint``, and its statistics, with ``where`` (the entries that say where
        the units ran) after the outputs."""
        o = self.options
        rate = units.plan.pixel_samples / units.seconds if units.seconds > 0 else None
        outcome = UnitsOutcome(units, rate)
        if not units.complete:
            if units.bands and o.checkpoint is not None:
                self.write_checkpoint(units.bands, job_id, units.plan)
                outcome.checkpoint = str(o.checkpoint)
            return outcome
        if outputs is not None:
            try:
                outcome.outputs = outputs(units.films)
            except WriteError as exc:     # the bands are kept for --resume
                raise _kept(exc, o.checkpoint,
                            lambda: self.write_checkpoint(units.bands, job_id, units.plan)) \
                    from exc
        if o.keep_checkpoint and o.checkpoint is not None:
            self.write_checkpoint(units.bands, job_id, units.plan)
            outcome.checkpoint = str(o.checkpoint)
        if o.stats:
            outcome.stats = self.stats(outcome, where or {})
        return outcome

    def stats(self, outcome: UnitsOutcome, where: dict[str, Any]) -> dict[str, Any]:
        """The statistics of a complete run of units: ``options.info``, the outputs,
        ``where``, then what the job knows and what the run reported."""
        s, units = self.settings, outcome.units
        stats = {
            **self.options.info, "outputs": [], **where,
            "width": self.scene.film.width, "height": self.scene.film.height,
            "integrator": s.integrator.kind, "sampler": s.sampler.kind, "seed": s.sampler.seed,
            "spp": s.sampler.spp, "frames": self.frames, "resumed_bands": self.resumed_bands,
            "seconds": {"render": units.seconds, "units": units.unit_seconds,
                        "total": time.perf_counter() - self.started},
            "samples_per_second": outcome.samples_per_second,
            "bytes_to_client": units.bytes_to_client,
            "nonfinite_samples": int(sum(f.nonfinite_total for f in units.films.values())),
            "truncated_paths": int(sum(f.truncated_total for f in units.films.values())),
        }
        stats.update(outcome.outputs)
        return stats
