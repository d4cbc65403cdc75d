"""Sample generators: GLSL matches its numpy twin bit for bit; stratification,
net properties, uniformity, decorrelation, and the discrepancy ordering."""
import numpy as np
import pytest

from glrender.render.params import shader_defines
from glrender.sampling import sequences as seq
from glrender.testing.chi2 import ChiSquareTest, PlanarDomain
from glrender.testing.harness import run_glsl

SAMPLER_DEFINES = {name: shader_defines(sampler=name) for name in seq.SAMPLERS}


def rand_u32(n, seed):
    return np.random.default_rng(seed).integers(0, 2 ** 32, n, dtype=np.uint64).astype(np.uint32)


def test01_hashes_match_numpy(gl_ctx):
    a, b, c = rand_u32(10000, 1), rand_u32(10000, 2), rand_u32(10000, 3)
    out = run_glsl("uint h = pcg_hash(a); uint k = hash_combine(a, b); uvec3 t = pcg3d(uvec3(a, b, c));",
                   {"a": a, "b": b, "c": c}, {"h": "uint", "k": "uint", "t": "uvec3"},
                   includes=["common/hash.glsl"])
    np.testing.assert_array_equal(out["h"], seq.pcg_hash(a))
    np.testing.assert_array_equal(out["k"], seq.hash_combine(a, b))
    np.testing.assert_array_equal(out["t"], np.stack(seq.pcg3d(a, b, c), axis=1))


def test02_owen_sobol_matches_numpy(gl_ctx):
    idx, s = rand_u32(20000, 4), np.stack([rand_u32(20000, k) for k in (5, 6, 7)], axis=1)
    out = run_glsl("uvec2 p = owen_sobol_2d_bits(i, s); uvec2 q = sobol_2d_bits(i);",
                   {"i": idx, "s": s}, {"p": "uvec2", "q": "uvec2"},
                   includes=["sampling/sobol.glsl"])
    np.testing.assert_array_equal(out["p"], np.stack(seq.owen_sobol_2d_bits(idx, s.T), axis=1))
    np.testing.assert_array_equal(out["q"], np.stack(seq.sobol_2d_bits(idx), axis=1))


def test03_sobol_dim1_is_the_pascal_matrix():
    # the superset transform equals the textbook direction-number loop (v ^= v >> 1)
    idx = rand_u32(2000, 8)
    expected = np.zeros_like(idx)
    v = np.uint32(0x80000000)
    for bit in range(32):
        expected ^= np.where((idx >> np.uint32(bit)) & np.uint32(1), v, np.uint32(0))
        v = np.uint32(v ^ (v >> np.uint32(1)))
    np.testing.assert_array_equal(seq.sobol_2d_bits(idx)[1], expected)


@pytest.mark.parametrize("sampler", ["independent", "stratified", "sobol"])
def test04_sampler_matches_numpy(gl_ctx, sampler):
    n = 4096
    pixel = rand_u32(n, 9)
    index = np.arange(n, dtype=np.uint32) % 64
    count, columns = 64, 8
    body = ("SamplerState s = sampler_start(ph, idx, 64u, 8u); s.dim = dim;"
            "vec2 a = sampler_2d(s); float b = sampler_1d(s);")
    dim = (np.arange(n) % 5).astype(np.uint32)
    out = run_glsl(body, {"ph": pixel, "idx": index, "dim": dim}, {"a": "vec2", "b": "float"},
                   includes=["sampling/sampler.glsl"], defines=SAMPLER_DEFINES[sampler])
    np.testing.assert_array_equal(out["a"], seq.sample_2d(sampler, pixel, index, dim, count, columns))
    np.testing.assert_array_equal(out["b"], seq.sample_1d(sampler, pixel, index, dim + 1, count))
    assert out["a"].min() >= 0 and out["a"].max() < 1


def net_ok(bits_x, bits_y, m):
    """Every elementary interval of area 2^-m holds exactly one of the 2^m points."""
    for a in range(m + 1):
        cx = bits_x >> np.uint32(32 - a) if a else np.zeros_like(bits_x)
        cy = bits_y >> np.uint32(32 - (m - a)) if m - a else np.zeros_like(bits_y)
        cells = cx.astype(np.int64) * (1 << (m - a)) + cy
        if len(np.unique(cells)) != 1 << m:
            return False
    return True


@pytest.mark.parametrize("m", [4, 7, 10])
def test05_owen_sobol_blocks_are_0m2_nets(m):
    # for any pixel and dimension seeds, the first 2^m shuffled, scrambled points are a (0,m,2)-net
    rng = np.random.default_rng(m)
    for _ in range(20):
        seeds = rng.integers(0, 2 ** 32, 3, dtype=np.uint64).astype(np.uint32)
        x, y = seq.owen_sobol_2d_bits(np.arange(1 << m, dtype=np.uint32), seeds)
        assert net_ok(x, y, m)
    # and the test can fail: independent points are not nets
    x, y = rng.integers(0, 2 ** 32, (2, 1 << m), dtype=np.uint64).astype(np.uint32)
    assert not net_ok(x, y, m)


@pytest.mark.parametrize("count", [16, 64, 12, 7])
def test06_stratified_one_point_per_stratum(gl_ctx, count):
    pixels = 50
    columns = seq.strata_columns(count)
    ph = np.repeat(rand_u32(pixels, 10), count)
    idx = np.tile(np.arange(count, dtype=np.uint32), pixels)
    body = (f"SamplerState s = sampler_start(ph, idx, {count}u, {columns}u);"
            "vec2 a = sampler_2d(s); float b = sampler_1d(s);")
    out = run_glsl(body, {"ph": ph, "idx": idx}, {"a": "vec2", "b": "float"},
                   includes=["sampling/sampler.glsl"], defines=SAMPLER_DEFINES["stratified"])
    rows = count // columns
    for p in range(pixels):
        a, b = out["a"][p * count:(p + 1) * count], out["b"][p * count:(p + 1) * count]
        cells = (a[:, 0] * columns).astype(int) * rows + (a[:, 1] * rows).astype(int)
        assert sorted(cells) == list(range(count))
        assert sorted((b * count).astype(int)) == list(range(count))


@pytest.mark.parametrize("sampler", ["independent", "stratified", "sobol"])
def test07_uniform_over_the_square(sampler, chi2_dir):
    # 2^20 samples = 4096 pixels x 256 samples, dimension 3: chi-square against the uniform pdf
    pixels, count = 4096, 256
    ph = np.repeat(seq.pixel_hash(np.arange(pixels), 0, 1), count)
    idx = np.tile(np.arange(count, dtype=np.uint32), pixels)
    points = seq.sample_2d(sampler, ph, idx, 3, count)
    test = ChiSquareTest(PlanarDomain(((0, 1), (0, 1))), lambda u: points,
                         lambda p: np.ones(len(p)), sample_count=len(points), test_count=3,
                         name=f"uniform-{sampler}")
    assert test.run(), test.messages


@pytest.mark.parametrize("sampler", ["stratified", "sobol"])
def test08_dimension_pairs_are_decorrelated(sampler):
    # padding: within a pixel, dimension 2 and dimension 5 are independent
    pixels, count = 2000, 16
    ph = np.repeat(seq.pixel_hash(np.arange(pixels), 7, 2), count)
    idx = np.tile(np.arange(count, dtype=np.uint32), pixels)
    a = seq.sample_2d(sampler, ph, idx, 2, count)
    b = seq.sample_2d(sampler, ph, idx, 5, count)
    n = len(a)
    for i in range(2):
        for j in range(2):
            r = np.corrcoef(a[:, i], b[:, j])[0, 1]
            assert abs(r) < 5.0 / np.sqrt(n), (i, j, r)


def test09_discrepancy_sobol_beats_stratified_beats_independent():
    """Mean L2-star discrepancy of 256-point pixel patterns over 64 pixels.

    Expected (Owen 1997, Niederreiter): independent ~ N^-1/2, jittered ~ N^-3/4,
    scrambled (0,m,2)-nets ~ N^-1 (log N)^1/2: at N = 256 the gaps are several x,
    far beyond the pixel-to-pixel spread of the means (asserted with 5 standard errors).
    """
    pixels, count = 64, 256
    results = {}
    for sampler in ("independent", "stratified", "sobol"):
        d = []
        for p in range(pixels):
            ph = seq.pixel_hash(p, 3, 5)
            pts = seq.sample_2d(sampler, np.full(count, ph), np.arange(count), 1, count)
            d.append(seq.l2_star_discrepancy(pts))
        d = np.array(d)
        results[sampler] = (d.mean(), d.std(ddof=1) / np.sqrt(pixels))
    (mi, si), (ms, ss), (mo, so) = results["independent"], results["stratified"], results["sobol"]
    assert ms + 5 * ss < mi - 5 * si, results
    assert mo + 5 * so < ms - 5 * ss, results
