"""Renders on a 2-worker LocalCluster (spawned processes) against one process."""
import os
import signal
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.distributed import local_cluster, render
from glrender.render.renderer import Renderer, settings_from_scene

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.toml"


@pytest.fixture(scope="module")
def cluster():
    cluster, client = local_cluster(2, dashboard=False)
    yield cluster, client
    client.close()
    cluster.close()


@pytest.fixture(scope="module")
def scene():
    s = glrender.load(CORNELL)
    s.film.width, s.film.height = 72, 52     # 9 x 7 tiles, the last row 4 pixels high
    return s


@pytest.fixture(scope="module")
def larger():
    """16 tile rows of 128 pixels at 64 spp: ~1 s of work for two single-threaded workers,
    far longer than the client takes to see the first unit finish."""
    s = glrender.load(CORNELL)
    s.film.width, s.film.height = 128, 128
    return s


def single_process(scene, settings):
    r = Renderer(scene, settings)
    r.step(settings.sampler.spp)
    f = r.film()
    r.release()
    return f


def assert_same(a, b):
    for name in ("mean", "m2", "count", "nonfinite"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), name)
    assert a.aovs.keys() == b.aovs.keys()
    for name in a.aovs:
        np.testing.assert_array_equal(a.aovs[name], b.aovs[name], name)


def test01_workers_are_spawned_with_one_thread(cluster):
    _, client = cluster
    info = client.run(lambda: __import__("glrender.distributed.worker").distributed.worker.worker_info())
    assert len(info) == 2
    assert len({i["pid"] for i in info.values()}) == 2 and os.getpid() not in {i["pid"] for i in info.values()}
    assert all(n == 1 for n in client.nthreads().values())
    cores = len(os.sched_getaffinity(0))
    assert all(i["lp_num_threads"] == str(max(1, cores // 2)) for i in info.values())
    assert all(w.contact_address is None or "127.0.0.1" in w.contact_address
               for w in cluster[0].workers.values()) and "127.0.0.1" in cluster[0].scheduler_address


def test02_bitwise_the_single_process_image(gl_ctx, cluster, scene):
    """Bands at the full sample count: every pixel accumulates as in one process."""
    _, client = cluster
    settings = settings_from_scene(scene, spp=16, seed=11, aovs=True)
    ref = single_process(scene, settings)
    res = render(CORNELL, client=client, settings=settings, unit_size=72 * 8 * 16 * 2,
                 width=72, height=52)       # the scene file, sent by value
    assert res.plan.bands == ((0, 2), (2, 2), (4, 2), (6, 1)) and len(res.plan.ranges) == 1
    assert_same(res.films[None], ref)
    assert res.bytes_to_client == 72 * 52 * (64 + 48 + 160)   # sums, squares, AOV sums


def test03_sample_ranges_are_bitwise_the_single_process_image(gl_ctx, cluster, scene):
    """A unit size that splits every band's samples into ranges (three of 8, merged on the
    workers), AOVs included: bitwise the single-process image, since every pixel's sums
    are exact; the same for ranges of another size."""
    _, client = cluster
    settings = settings_from_scene(scene, spp=24, seed=2, aovs=True)
    ref = single_process(scene, settings)
    res = render(scene, client=client, settings=settings, unit_size=72 * 8 * 8)
    assert res.plan.ranges == ((0, 8), (8, 16), (16, 24)) and len(res.plan.bands) == 7
    assert_same(res.films[None], ref)
    res = render(scene, client=client, settings=settings, unit_size=72 * 8 * 16)
    assert res.plan.ranges == ((0, 16), (16, 24))
    assert_same(res.films[None], ref)


@pytest.mark.slow
def test04_a_killed_worker_changes_nothing(gl_ctx, cluster, larger):
    """A worker process killed by its PID while units run: Dask reruns its units on the
    other worker (and the nanny restarts it); the image is bitwise the same."""
    _, client = cluster
    settings = settings_from_scene(larger, spp=64, seed=4)
    ref = single_process(larger, settings)
    killed = []

    def progress(done, total, pixel_samples, seconds):
        if killed or done == total:
            return
        busy = [w for w, tasks in client.processing().items() if tasks]
        if busy:
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    res = render(larger, client=client, settings=settings, unit_size=128 * 8 * 64,
                 progress=progress, poll=0.02)
    assert killed, "the render ended before a worker could be killed"
    assert len(res.plan.units()) == 16
    assert_same(res.films[None], ref)
    client.wait_for_workers(2, timeout=60)


@pytest.mark.slow
def test05_stop_checkpoint_resume(gl_ctx, cluster, larger, tmp_path):
    """A render stopped after some units (as Ctrl-C stops it) keeps its finished bands;
    saved to a checkpoint and given back, the render runs only the rest, and the image is
    bitwise the uninterrupted one."""
    from glrender.distributed.merge import Partial
    from glrender.render.checkpoint import load_band_checkpoint, save_band_checkpoint

    _, client = cluster
    settings = settings_from_scene(larger, spp=64, seed=9)
    ref = single_process(larger, settings)
    seen = []

    def progress(done, total, pixel_samples, seconds):
        seen.append((done, total))

    # stopped once a unit has finished (waiting for it, not for a time)
    res = render(larger, client=client, settings=settings, unit_size=128 * 8 * 64,
                 progress=progress, stop=lambda: bool(seen) and seen[-1][0] >= 1, poll=60)
    assert not res.complete and res.films == {}
    assert 1 <= len(res.bands) < 16
    path = tmp_path / "render.ckpt"
    save_band_checkpoint(path, {"job": "the job"}, res.bands)
    with pytest.raises(glrender.errors.UsageError, match="another scene"):
        load_band_checkpoint(path, "another job", Partial)
    done = load_band_checkpoint(path, "the job", Partial)
    assert done.keys() == res.bands.keys()
    seen.clear()
    res2 = render(larger, client=client, settings=settings, unit_size=128 * 8 * 64, done=done,
                  progress=progress)
    assert res2.complete and seen[0][0] >= len(done)        # the finished units count as done
    assert_same(res2.films[None], ref)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["lighttrace", "bdpt"])
def test06_splatting_integrators_render_whole_frames(gl_ctx, cluster, kind):
    """Light tracing and BDPT splat onto the whole film: units are whole frames over sample
    ranges. One range: bitwise the single-process film. Several: the splats' fixed-point
    sums are exactly the single process's (integers add in any order), the camera side
    merges as sample ranges do."""
    from glrender.render.accumulation import SPLAT_SCALE

    _, client = cluster
    s = glrender.load(CORNELL)
    s.film.width, s.film.height = 40, 32
    settings = settings_from_scene(s, spp=16, seed=3, integrator=kind, max_depth=4)
    r = Renderer(s, settings)
    r.step(16)
    ref = r.film()
    words = r.state()["splat"].reshape(-1, 2).astype(np.uint64)
    ref_sums = ((words[:, 1] << np.uint64(32)) | words[:, 0]).view(np.int64).reshape(-1, 3)
    r.release()
    assert np.count_nonzero(ref_sums) > ref_sums.size // 2     # the splats are there
    one = render(s, client=client, settings=settings, unit_size=40 * 32 * 16)
    assert one.plan.bands == ((0, 4),) and one.plan.ranges == ((0, 16),)
    assert_same(one.films[None], ref)
    split = render(s, client=client, settings=settings, unit_size=40 * 32 * 8)
    assert split.plan.bands == ((0, 4),) and split.plan.ranges == ((0, 8), (8, 16))
    np.testing.assert_array_equal(split.bands[(None, 0)].splat, ref_sums)
    assert_same(split.films[None], ref)


@pytest.mark.slow
def test06b_photon_integrator_bitwise_the_single_process_image(gl_ctx, cluster, scene):
    """The photon integrator: every worker traces the same maps from the seed (sorted into
    one order), so bands and sample ranges give the single process's image bit for bit;
    kNN lookups too."""
    from glrender.photon import PhotonRenderer, PhotonSettings

    _, client = cluster
    settings = settings_from_scene(scene, spp=16, seed=4, integrator="photon")
    for photon in (PhotonSettings(photons=1 << 14), PhotonSettings(photons=1 << 14, knn=8)):
        r = PhotonRenderer(scene, settings, photon)
        r.step(16)
        ref = r.film()
        r.release()
        bands = render(scene, client=client, settings=settings, photon=photon,
                       unit_size=72 * 8 * 16 * 3)
        assert len(bands.plan.bands) == 3 and bands.plan.ranges == ((0, 16),)
        assert_same(bands.films[None], ref)
        ranges = render(scene, client=client, settings=settings, photon=photon, unit_size=72 * 8 * 8)
        assert ranges.plan.ranges == ((0, 8), (8, 16))
        assert_same(ranges.films[None], ref)


def test07_default_unit_size_is_calibrated_once(gl_ctx, cluster, scene, tmp_path, monkeypatch):
    """The Python API without a unit size: the first render measures on a worker and
    writes the cache, the second reads it; both plan with the recorded size and give
    the single-process image."""
    from glrender.distributed import calibrate
    from glrender.distributed.plan import default_unit_size

    monkeypatch.setenv("GLRENDER_CACHE_DIR", str(tmp_path))
    _, client = cluster
    settings = settings_from_scene(scene, spp=8, seed=6)
    ref = single_process(scene, settings)
    first = render(scene, client=client, settings=settings)
    assert first.calibration["source"] == "calibrated" and first.calibration["rate"] > 0
    written = calibrate.cache_path().read_bytes()
    second = render(scene, client=client, settings=settings)
    assert second.calibration["source"] == "cache"
    assert second.calibration["unit_size"] == first.calibration["unit_size"]
    assert calibrate.cache_path().read_bytes() == written
    size = default_unit_size(72, 52, 8, largest=first.calibration["unit_size"])
    assert first.plan.unit_size == second.plan.unit_size == size
    info = client.run(lambda: __import__("glrender.distributed.worker").distributed.worker.worker_info())
    assert first.calibration["key"] == calibrate.kind_key(
        next(iter(info.values()))["renderer"], None, "path")     # the workers' device
    assert_same(first.films[None], ref)
    assert_same(second.films[None], ref)
