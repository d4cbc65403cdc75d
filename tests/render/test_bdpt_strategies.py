"""BDPT strategy images (Renderer(strategy_depth=...), --strategy-images).

- The weighted images partition the render (an area light, an image environment, a
  directional light): at strategy depth = max depth they add up to the film, exactly for the splatted t = 1 part (the same fixed-point integers) and up
  to float32 summation order for the camera side (a bound from the sample count).
- The strategy images of one path length k sum to that length's contribution of the full
  render: statistically, against the path tracer's own length-k part (max depth k minus
  max depth k - 1, independent seeds), per 4x4 block at one Šidák alpha of 0.01 over every
  comparison of this file. The unweighted s = 1 image (next-event estimation alone, the
  path tracer's light sampling) estimates the same part on its own.
- The kernel without strategy images has none of their code; the PNG pyramids are
  written and labelled.
"""
import numpy as np
import pytest

from glrender.render import accum, strategies
from glrender.render.accumulation import SPLAT_SCALE
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.testing.images import compare_images

from bidir_scenes import cornell, directional, environment, renders

DEPTH = 3
SEEDS_BDPT, SEEDS_PATH = (61, 62, 63, 64), (71, 72, 73, 74)
SIZE, BLOCK = 24, 4


def strategy_render(scene, spp, seed, depth, max_depth, ctx, **options):
    r = Renderer(scene, settings_from_scene(scene, integrator="bdpt", spp=spp, seed=seed,
                                            max_depth=max_depth, strategy_depth=depth,
                                            sampler="independent", **options), ctx=ctx)
    r.step(spp)
    return r


@pytest.mark.parametrize("make", [cornell, environment, directional])
def test01_weighted_images_partition_the_render(gl_ctx, make):
    scene = make(SIZE)
    spp = 8
    r = strategy_render(scene, spp, 5, 4, 4, gl_ctx)
    film, splat = r.film(), r.splat_image()
    images = r.strategy_images()
    words = r.state()["strategies"].reshape(
        len(strategies.strategies(4)), SIZE, SIZE, strategies.WORDS_PER_PIXEL)
    splat_sums = accum.fixed_sums(r.state()["splat"])
    r.release()
    assert set(images) == set(strategies.strategies(4))
    # t = 1: every splat went to its strategy image as the same integers
    lens = [j for j, (s, t) in enumerate(strategies.strategies(4)) if t == 1]
    per = sum(accum.fixed_sums(words[j]).reshape(SIZE * SIZE, 6)[:, :3] for j in lens)
    assert np.array_equal(per.reshape(-1), splat_sums) and splat_sums.any()
    # t >= 2: float32 sums of spp samples vs the film's running mean of their total
    camera = sum(w for (s, t), (w, u) in images.items() if t >= 2)
    magnitude = sum(np.abs(w) for (s, t), (w, u) in images.items() if t >= 2)
    bound = 4 * (spp + len(images)) * 2.0 ** -24 * (magnitude + np.abs(film.mean))
    err = np.abs(camera - (film.mean - splat))
    assert np.all(err <= bound + 1e-7), float((err - bound).max())
    assert images[(1, 1)][0].max() == 0.0       # not a strategy of this bdpt
    # unweighted images are at least their weighted part (weights in [0, 1])
    for w, u in images.values():
        assert np.all(w <= u * (1 + 1e-6) + 1e-9)


def test02_kernel_without_strategy_images_has_none_of_their_code(gl_ctx):
    scene = cornell(8)
    r = Renderer(scene, settings_from_scene(scene, integrator="bdpt", spp=1), ctx=gl_ctx)
    assert "GLRENDER_STRATEGY_DEPTH" not in r.defines and r.accumulation.strategies.size == 16
    r.release()


def comparisons_in_file():
    blocks = 3 * (SIZE // BLOCK) ** 2 + 2
    return 2 * DEPTH * blocks    # weighted sum and unweighted s = 1, per length


@pytest.fixture(scope="module")
def lengths(gl_ctx):
    """Per length k: the bdpt strategy images of 4 seeds, and the path tracer's length-k
    part of 4 other seeds (k and k - 1 rendered with different seeds: independent)."""
    scene = cornell(SIZE)
    runs = []
    for seed in SEEDS_BDPT:
        r = strategy_render(scene, 32, seed, DEPTH, DEPTH, gl_ctx)
        runs.append(r.strategy_images())
        r.release()
    path = {k: renders(scene, "path", 64, [s + 100 * k for s in SEEDS_PATH], max_depth=k)
            for k in range(1, DEPTH + 1)}
    return scene, runs, path


@pytest.mark.slow
@pytest.mark.parametrize("k", range(1, DEPTH + 1))
def test03_one_length_sums_to_its_part_of_the_render(lengths, k):
    scene, runs, path = lengths
    part = path[k] - (path[k - 1] if k > 1 else 0.0)
    ref = part.mean(axis=0)
    # the difference of two independent means: their variances add
    se2 = path[k].var(axis=0, ddof=1) / len(SEEDS_PATH)
    if k > 1:
        se2 = se2 + path[k - 1].var(axis=0, ddof=1) / len(SEEDS_PATH)
    extra = comparisons_in_file() - (3 * (SIZE // BLOCK) ** 2 + 2)
    weighted = np.stack([sum(w for (s, t), (w, u) in run.items() if s + t - 1 == k) for run in runs])
    c = compare_images(weighted, ref, np.sqrt(se2), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)
    nee = np.stack([run[(1, k)][1] for run in runs])
    if k == 1:   # (1, 1) is not a strategy here: its image stays black
        assert not nee.any()
        return
    c = compare_images(nee, ref, np.sqrt(se2), block=BLOCK, extra_tests=extra)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test04_pyramid_pngs(gl_ctx, tmp_path):
    from PIL import Image

    scene = cornell(16)
    r = strategy_render(scene, 2, 1, 3, 3, gl_ctx)
    written = strategies.write(tmp_path, r.strategy_images(), 3)
    r.release()
    assert [p.split("/")[-1] for p in written] == ["weighted.png", "unweighted.png", "strategies.npz"]
    grid = np.asarray(Image.open(tmp_path / "weighted.png"))
    tile = 16 * 3   # films under 40 pixels wide are magnified to fit their label
    assert grid.shape[1] == 4 * (tile + 4) and grid.shape[0] == 3 * (tile + 14 + 4)
    data = np.load(tmp_path / "strategies.npz")
    assert sorted(data.files) == sorted(f"{p}_{s}_{t}" for s, t in strategies.strategies(3) for p in "wu")


def test05_refusals(gl_ctx):
    from glrender.errors import UsageError

    scene = cornell(8)
    with pytest.raises(UsageError, match="only bdpt and vcm have strategies"):
        Renderer(scene, settings_from_scene(scene, integrator="path", strategy_depth=2), ctx=gl_ctx)
    with pytest.raises(UsageError, match="--strategy-depth 6: expected a path length in 1..5"):
        Renderer(scene, settings_from_scene(scene, integrator="bdpt", max_depth=5, strategy_depth=6),
                 ctx=gl_ctx)


def test06_command_line(tmp_path):
    """glrender render --strategy-images: the pyramids and floats beside the image, whose
    weighted images add up to it; wrong uses refused with one line, exit code 2."""
    import subprocess
    import sys

    from bidir_scenes import ROOT

    scene = ROOT / "scenes" / "cornell-box" / "scene.toml"

    def run(*args):
        return subprocess.run([sys.executable, "-m", "glrender", "render", str(scene), "--quiet",
                               "--width", "16", "--height", "16", "--spp", "4", *map(str, args)],
                              capture_output=True, text=True, timeout=300)

    out = tmp_path / "img.npy"
    r = run("-o", out, "--integrator", "bdpt", "--max-depth", "3", "--strategy-images", tmp_path / "st")
    assert r.returncode == 0, r.stderr
    assert {p.name for p in (tmp_path / "st").iterdir()} == {"weighted.png", "unweighted.png",
                                                              "strategies.npz"}
    data = np.load(tmp_path / "st" / "strategies.npz")
    assert sorted(data.files) == sorted(f"{p}_{s}_{t}" for s, t in strategies.strategies(3) for p in "wu")
    total = sum(data[f"w_{s}_{t}"].astype(np.float64) for s, t in strategies.strategies(3))
    np.testing.assert_allclose(total, np.load(out), rtol=1e-4, atol=1e-5)
    for args, message in [
            (("--strategy-images", tmp_path / "x"), "--strategy-images: only the bdpt and vcm integrators have"),
            (("--integrator", "bdpt", "--strategy-depth", "2"), "--strategy-depth 2: only with"),
            (("--integrator", "bdpt", "--max-depth", "2", "--strategy-images", tmp_path / "y",
              "--strategy-depth", "3"), "--strategy-depth 3: expected a path length in 1..2"),
            (("--integrator", "bdpt", "--strategy-images", out), "is a file, expected a folder")]:
        r = run("-o", tmp_path / "z.png", *args)
        assert r.returncode == 2 and message in r.stderr and len(r.stderr.strip().splitlines()) == 1, \
            r.stderr


def test07_resumed_render_keeps_the_strategy_images_bitwise(gl_ctx):
    scene = cornell(16)
    settings = settings_from_scene(scene, integrator="bdpt", spp=8, seed=9, max_depth=3,
                                   strategy_depth=3)
    whole = Renderer(scene, settings, ctx=gl_ctx)
    whole.step(8)
    first = Renderer(scene, settings, ctx=gl_ctx)
    first.step(4)
    second = Renderer(scene, settings, ctx=gl_ctx)
    second.restore(first.state())
    second.step(4)
    a, b = whole.strategy_images(), second.strategy_images()
    for r in (whole, first, second):
        r.release()
    assert all(np.array_equal(a[st][i], b[st][i]) for st in a for i in (0, 1))
    assert a[(1, 2)][0].max() > 0
