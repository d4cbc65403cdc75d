"""The job runner (glrender/render/job.py): settings -> driver -> passes -> checkpoints -> stats,
on a small Cornell box."""
from __future__ import annotations

import io
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from types import SimpleNamespace

import moderngl
import numpy as np
import pytest

import glrender
from glrender.drivers import create_driver
from glrender.errors import UsageError
from glrender.render.checkpoint import load_checkpoint
from glrender.render.emission_pass import emission_spp, render_seen_emission
from glrender.render.job import PHASES, Job, JobOptions, UnitsJob, job_settings, make_driver
from glrender.render.renderer import Renderer, settings_from_scene

CORNELL = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"
PASS = {"samples_per_pass": 4}      # four passes to 16 spp


@pytest.fixture(scope="module")
def scene():
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=16, height=12)
    return scene


def run(scene, **options):
    with Job(scene, JobOptions(**options), create_driver) as job:
        return job.run()


def assert_same_accumulation(a, b):
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.m2, b.m2)
    np.testing.assert_array_equal(a.count, b.count)


def test01_runs_to_the_sample_target(scene, gl_ctx):
    """The job's image is a Renderer's stepped to the same spp, bitwise; on_pass follows it."""
    seen = []
    outcome = run(scene, spp=16, seed=5, settings=PASS, ctx=gl_ctx,
                  on_pass=lambda spp, seconds: seen.append(spp))
    assert outcome.stopped == "complete" and outcome.film.spp == 16
    assert outcome.run.passes == 4 and seen == [4, 8, 12, 16]
    assert outcome.checkpoint is None and outcome.samples_per_second > 0
    with Renderer(scene, settings_from_scene(scene, spp=16, seed=5), ctx=gl_ctx) as r:
        r.step(16)
        assert_same_accumulation(outcome.film, r.film())


def test02_checkpoint_then_resume_equals_one_run(scene, gl_ctx, tmp_path):
    """A stop after the first pass writes a checkpoint of it; the resumed job ends bitwise
    where the uninterrupted one does."""
    whole = run(scene, spp=16, seed=5, settings=PASS, ctx=gl_ctx).film
    path, passes = tmp_path / "job.ckpt", []
    stopped = run(scene, spp=16, seed=5, settings=PASS, ctx=gl_ctx, checkpoint=path,
                  stop=lambda: bool(passes), stopped_by=lambda: "test",
                  on_pass=lambda spp, seconds: passes.append(spp))
    assert stopped.stopped == "interrupted" and stopped.film.spp == 4
    assert stopped.checkpoint == str(path) and stopped.stats["signal"] == "test"
    ckpt = load_checkpoint(path)
    assert ckpt.spp_done == 4 and ckpt.meta["spp_target"] == 16
    assert ckpt.meta["device"] == gl_ctx.renderer
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # the same device: no warning
        resumed = run(scene, spp=16, seed=5, settings=PASS, ctx=gl_ctx, resume=ckpt)
    assert resumed.stats["resumed_from_spp"] == 4 and resumed.stats["spp_this_run"] == 12
    assert_same_accumulation(resumed.film, whole)
    with pytest.raises(UsageError, match="other settings"):
        run(scene, spp=16, seed=6, settings=PASS, ctx=gl_ctx, resume=ckpt)


def test03_stats(scene, gl_ctx):
    """The statistics open with the caller's entries, hold the timings of every phase, the
    samples and their rate, take the outputs' entries in their places and end with the
    driver's own."""
    def outputs(film):
        assert film.spp == 8
        return {"outputs": ["a.exr"], "denoise": {"seconds": 0.0}}

    with Job(scene, JobOptions(spp=8, seed=1, ctx=gl_ctx, info={"glrender": "x"}),
             create_driver) as job:
        outcome = job.run(outputs)
    stats = outcome.stats
    keys = list(stats)
    assert keys[:3] == ["glrender", "outputs", "checkpoint"] and stats["outputs"] == ["a.exr"]
    assert keys.index("denoise") == keys.index("seconds") + 1
    assert list(stats["seconds"]) == list(PHASES)
    assert stats["seconds"]["render"] > 0 and stats["seconds"]["total"] >= stats["seconds"]["render"]
    assert stats["spp"] == 8 and stats["spp_target"] == 8 and stats["stopped"] == "complete"
    assert stats["samples_per_second"] == outcome.samples_per_second > 0
    assert stats["width"] == 16 and stats["height"] == 12 and stats["signal"] is None
    assert stats["device"]["GL_RENDERER"] == gl_ctx.renderer
    assert run(scene, spp=1, ctx=gl_ctx, stats=False).stats is None


def test04_time_budget_without_spp_is_open_ended(scene, gl_ctx):
    outcome = run(scene, seconds=0.2, ctx=gl_ctx)
    assert outcome.stopped == "time" and outcome.film.spp > 0
    assert outcome.stats["spp_target"] is None and outcome.stats["time_budget"] == 0.2
    capped = run(scene, spp=2, seconds=30.0, ctx=gl_ctx)
    assert capped.stopped == "complete" and capped.film.spp == 2


def test05_settings_and_driver(scene, gl_ctx):
    """The options override the scene's settings; the driver comes from the factory given,
    and a device that cannot allocate the image's buffers is a UsageError."""
    settings = job_settings(scene, JobOptions(integrator="direct", spp=3, seed=9,
                                              settings={"max_depth": 2}))
    assert (settings.integrator.kind, settings.sampler.spp, settings.sampler.seed,
            settings.integrator.max_depth) == ("direct", 3, 9, 2)
    made = []

    def factory(*args, **kwargs):
        made.append(args[1].integrator.kind)
        return create_driver(*args, **kwargs)

    with Job(scene, JobOptions(integrator="ao", spp=1, ctx=gl_ctx), factory) as job:
        assert job.run().film.spp == 1
    assert made == ["ao"]

    def no_memory(*args, **kwargs):
        raise moderngl.Error("out of memory")

    with pytest.raises(UsageError, match="cannot allocate the device buffers of a 16x12 image"):
        make_driver(scene, settings, no_memory, ctx=gl_ctx)


def test06_crop(scene, gl_ctx):
    """A crop renders its tile rows and keeps its pixels; light paths that splat onto the
    whole film cannot be cropped."""
    whole = run(scene, spp=4, seed=2, ctx=gl_ctx).film
    part = run(scene, spp=4, seed=2, ctx=gl_ctx, crop=[3, 2, 11, 9])
    assert part.film.shape == (7, 8) and part.stats["crop"] == [3, 2, 11, 9]
    np.testing.assert_array_equal(part.film.mean, whole.mean[2:9, 3:11])
    with pytest.raises(UsageError, match="not available with the lighttrace integrator"):
        run(scene, integrator="lighttrace", spp=1, ctx=gl_ctx, crop=[0, 0, 8, 8])


def test07_seen_emission(scene, gl_ctx):
    """--denoise's seen-emission pass: the job's settings at the film's spp (a stopped run's,
    not the target's), the crop's pixels with a crop, None where the pass adds nothing."""
    passes = []
    with Job(scene, JobOptions(spp=20, seed=3, settings=PASS, ctx=gl_ctx,
                               stop=lambda: bool(passes),
                               on_pass=lambda spp, seconds: passes.append(spp)),
             create_driver) as job:
        film = job.run().film
        seen = job.seen_emission(film)
    assert film.spp == 4 and seen.spp == emission_spp(4) != emission_spp(20)
    whole = render_seen_emission(scene, settings_from_scene(scene, spp=4, seed=3, **PASS),
                                 ctx=gl_ctx)
    np.testing.assert_array_equal(seen.mean, whole.mean)
    crop = [3, 2, 11, 9]
    with Job(scene, JobOptions(spp=4, seed=3, settings=PASS, ctx=gl_ctx, crop=crop),
             create_driver) as job:
        part = job.seen_emission(job.run().film)
    assert part.shape == (7, 8)
    np.testing.assert_array_equal(part.mean, whole.mean[2:9, 3:11])
    with Job(scene, JobOptions(integrator="ao", spp=1, ctx=gl_ctx), create_driver) as job:
        assert job.seen_emission(job.run().film) is None


@dataclass
class Band:
    """A finished band as a cluster reports it (glrender.distributed.merge.Partial)."""

    sums: np.ndarray
    squares: np.ndarray
    aov: np.ndarray | None
    samples: tuple
    splat: np.ndarray | None = None


class Plan:
    pixel_samples = 16 * 12 * 8

    def record(self):
        return {"unit_size": 4096, "units": 3}


def units(complete=True, bands=1):
    band = Band(np.arange(32, dtype=np.uint32).reshape(2, 4, 4),
                np.ones((2, 3, 4), np.uint32), None, (0, 8))
    return SimpleNamespace(films={None: SimpleNamespace(nonfinite_total=2, truncated_total=0)} if complete else {},
                           bands={(None, b): band for b in range(bands)}, complete=complete,
                           seconds=0.5, unit_seconds=0.8, bytes_to_client=100, plan=Plan())


def test08_units_job_checkpoints_and_stats(scene, tmp_path):
    """A render of units elsewhere: its settings; a stopped run's bands to the checkpoint,
    which a resume of the same job takes back; a complete run's outputs, checkpoint (kept)
    and statistics in the cluster command's order."""
    path = tmp_path / "units.ckpt"

    def job(**options):
        return UnitsJob(scene, JobOptions(spp=8, seed=4, checkpoint=path,
                                          record={"scene": "s.toml"}, **options))

    assert job().settings == job_settings(scene, JobOptions(spp=8, seed=4))
    assert job().finish(units(False, bands=0), "j1").checkpoint is None and not path.exists()
    called = []
    stopped = job().finish(units(False), "j1", lambda films: called.append(films))
    assert stopped.checkpoint == str(path) and stopped.stats is None and called == []
    again = job(stats=True, keep_checkpoint=True, info={"glrender": "x"})
    assert again.checkpoint_unit_size() == 4096
    with pytest.raises(UsageError, match="another scene, other settings"):
        again.resume("j2", Band)
    (band,) = again.resume("j1", Band).values()
    np.testing.assert_array_equal(band.sums, units().bands[(None, 0)].sums)
    assert band.samples == (0, 8) and band.aov is None
    path.unlink()
    outcome = again.finish(units(), "j1", lambda films: {"outputs": [f"{len(films)} film"]},
                           where={"cluster": "here", "workers": 2})
    assert outcome.checkpoint == str(path) and path.is_file()
    stats = outcome.stats
    assert list(stats) == ["glrender", "outputs", "cluster", "workers", "width", "height",
                           "integrator", "sampler", "seed", "spp", "frames", "resumed_bands",
                           "seconds", "samples_per_second", "bytes_to_client",
                           "nonfinite_samples", "truncated_paths"]
    assert stats["outputs"] == ["1 film"] and stats["resumed_bands"] == 1
    assert (stats["width"], stats["spp"], stats["seed"], stats["frames"]) == (16, 8, 4, None)
    assert list(stats["seconds"]) == ["render", "units", "total"]
    assert stats["samples_per_second"] == Plan.pixel_samples / 0.5
    assert stats["nonfinite_samples"] == 2 and stats["bytes_to_client"] == 100
    assert stats["truncated_paths"] == 0
    assert job(stats=False).finish(units(), "j1").stats is None


def test09_units_bar(scene, monkeypatch):
    """The units bar is drawn on a terminal when asked for, and ends its line."""
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal = Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    with UnitsJob(scene, JobOptions(spp=8)).units_bar() as progress:
        assert progress is None
    with UnitsJob(scene, JobOptions(spp=8, progress_bar=True)).units_bar() as progress:
        progress(3, 4, 2_000_000, 1.0)
    assert terminal.getvalue() == ("\r[######################........] 3/4 units  2.00 Msamples/s  "
                                   "0:01 elapsed\033[K\n")


def test10_a_write_that_fails_keeps_the_samples(scene, gl_ctx, tmp_path, monkeypatch):
    """A periodic checkpoint that cannot be written is warned of once and the render goes
    on; outputs that cannot be written leave the render in the checkpoint (the error says
    where), for the job and for a render of units alike."""
    from glrender.film.io import WriteError
    from glrender.render import checkpoint
    from glrender.render import job as job_module

    path, calls = tmp_path / "job.ckpt", []
    save = checkpoint.save_checkpoint

    def flaky(*args, **kwargs):         # the first two meet a full disk
        calls.append(1)
        if len(calls) <= 2:
            raise WriteError(f"{path}: cannot write (No space left on device)")
        return save(*args, **kwargs)

    monkeypatch.setattr(job_module, "save_checkpoint", flaky)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = run(scene, spp=16, seed=5, settings=PASS, ctx=gl_ctx, checkpoint=path,
                      checkpoint_every=1e-9, keep_checkpoint=True)
    assert [str(w.message) for w in caught] == [
        f"{path}: cannot write (No space left on device): the render goes on, trying again "
        f"every 1e-09 s"]
    assert outcome.stopped == "complete" and outcome.run.checkpoints == 1   # 3 tried, 1 written
    assert load_checkpoint(path).spp_done == 16                             # and at the end

    def full(film):
        raise WriteError("out.exr: cannot write (No space left on device)")

    path.unlink()
    with Job(scene, JobOptions(spp=16, seed=5, settings=PASS, ctx=gl_ctx, checkpoint=path),
             create_driver) as job:
        with pytest.raises(WriteError, match=rf"^out\.exr: cannot write \(No space left on "
                                             rf"device\); the render is kept in {path}: "):
            job.run(full)
    assert load_checkpoint(path).spp_done == 16
    with Job(scene, JobOptions(spp=4, seed=5, ctx=gl_ctx), create_driver) as job:
        with pytest.raises(WriteError, match=r"^out\.exr: cannot write \([^)]+\)$"):
            job.run(full)                       # no checkpoint asked for: nothing to say

    units_path = tmp_path / "units.ckpt"
    units_job = UnitsJob(scene, JobOptions(spp=8, seed=4, checkpoint=units_path))
    with pytest.raises(WriteError, match=rf"the render is kept in {units_path}"):
        units_job.finish(units(), "j1", full)
    (band,) = units_job.resume("j1", Band).values()
    np.testing.assert_array_equal(band.sums, units().bands[(None, 0)].sums)
