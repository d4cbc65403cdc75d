"""Discrete distributions (CDF with binary search, alias tables, the lecture's two examples)
and the packed table format that carries every tabulated distribution to GLSL.

The chi-square tests of this module form one Šidák family at alpha = 0.01 (CHI2_FAMILY);
with 10^6 samples an outcome of probability 0.1 whose frequency is off by 1% relative is
seen at ~3 sigma, one off by 3% at ~10 sigma.
"""
import numpy as np
import pytest

from glrender.errors import UsageError
from glrender.sampling import distributions as dist
from glrender.testing.chi2 import ChiSquareTest, LineDomain
from glrender.testing.harness import run_glsl
from glrender.testing.stats import chi2_sf, sidak_alpha

SAMPLES = 1_000_000
CHI2_FAMILY = 5  # test01 and test02 for both samplers, test08
# Outcomes with zero weight, a dynamic range of 1000 and a dominant outcome.
WEIGHTS = np.array([0.0, 1.0, 3.0, 0.0, 2.0, 5.0, 0.5, 10.0, 0.0, 0.01])
PREAMBLE = "float distribution_fetch(uint i) { return table[i]; }"
SAMPLERS = {  # table builder, GLSL include, GLSL sampler, GLSL pmf, numpy sampler, numpy pmf
    "cdf": (dist.discrete_cdf_table, "sampling/discrete_cdf.glsl", "sample_discrete_cdf",
            "discrete_cdf_pmf", dist.sample_discrete_cdf, dist.discrete_cdf_pmf),
    "alias": (dist.alias_table, "sampling/alias_table.glsl", "sample_alias_table",
              "alias_table_pmf", dist.sample_alias_table, dist.alias_table_pmf),
}


def run_discrete(kind, table, u, offset=0):
    _, include, sampler, pmf_fn, _, _ = SAMPLERS[kind]
    body = (f"DiscreteSample s = {sampler}({offset}u, u); uint index_out = s.index; "
            f"float pmf = s.pmf; float rem = s.u_remapped; float pmf_fn = {pmf_fn}({offset}u, s.index);")
    return run_glsl(body, {"u": u}, {"index_out": "uint", "pmf": "float", "rem": "float",
                                      "pmf_fn": "float"},
                    includes=[include], buffers={"table": table}, preamble=PREAMBLE)


def pearson(counts, expected):
    """Pearson chi-square p-value over the outcomes with expected count > 0 (pooling none:
    every expected count here is far above 5)."""
    keep = expected > 0
    assert np.all(counts[~keep] == 0), "an outcome of probability 0 was drawn"
    assert expected[keep].min() > 5
    stat = float(np.sum((counts[keep] - expected[keep]) ** 2 / expected[keep]))
    return chi2_sf(stat, int(keep.sum()) - 1)


@pytest.fixture(scope="module", params=list(SAMPLERS))
def discrete_run(request, gl_ctx):
    kind = request.param
    table = SAMPLERS[kind][0](WEIGHTS)
    u = np.random.default_rng(11 if kind == "cdf" else 12).random(SAMPLES, dtype=np.float32)
    return kind, table, u, run_discrete(kind, table, u)


def test01_frequencies_match_probabilities(discrete_run):
    kind, table, u, out = discrete_run
    p = WEIGHTS / WEIGHTS.sum()
    counts = np.bincount(out["index_out"], minlength=len(p))
    assert pearson(counts, p * SAMPLES) >= sidak_alpha(0.01, CHI2_FAMILY)


def test02_remainder_is_uniform_given_the_outcome(discrete_run, chi2_dir):
    """(index + u_remapped) / n has density n p_i on [i/n, (i+1)/n): one chi-square test
    sees both the outcome frequencies and the uniformity of every remainder."""
    kind, table, u, out = discrete_run
    n, p = len(WEIGHTS), WEIGHTS / WEIGHTS.sum()
    points = (out["index_out"] + out["rem"].astype(np.float64)) / n

    def pdf(x):
        return n * p[np.clip((np.asarray(x) * n).astype(int), 0, n - 1)]
    test = ChiSquareTest(LineDomain((0.0, 1.0)), lambda _: points, pdf, sample_dim=1,
                         sample_count=SAMPLES, res=n * 20, test_count=CHI2_FAMILY, name=kind)
    assert test.run(), test.messages


def test03_pmf_values_and_glsl_against_numpy(discrete_run):
    kind, table, u, out = discrete_run
    p = WEIGHTS / WEIGHTS.sum()
    np.testing.assert_allclose(out["pmf"], p[out["index_out"]], rtol=2 ** -23)
    np.testing.assert_array_equal(out["pmf"], out["pmf_fn"])
    index, pmf, rem = SAMPLERS[kind][4](table, 0, u[:200_000])
    np.testing.assert_array_equal(out["index_out"][:200_000], index)  # float32 decisions agree
    np.testing.assert_allclose(out["pmf"][:200_000], pmf, rtol=2 ** -23)
    # the remainder carries the rounding of u - cdf (or u n - bin) divided by p (or q)
    np.testing.assert_allclose(out["rem"][:200_000], rem, rtol=0, atol=2 ** -16)
    assert np.all((out["rem"] >= 0) & (out["rem"] < 1))


def test04_pmf_outside_the_table_is_zero(gl_ctx):
    for kind, (build, include, _, pmf_fn, _, np_pmf) in SAMPLERS.items():
        table = build(WEIGHTS)
        k = np.array([0, 1, 9, 10, 1000], np.uint32)
        out = run_glsl(f"float pmf = {pmf_fn}(0u, k);", {"k": k}, {"pmf": "float"},
                       includes=[include], buffers={"table": table}, preamble=PREAMBLE)
        expected = np.where(k < 10, WEIGHTS[np.minimum(k, 9)] / WEIGHTS.sum(), 0.0)
        np.testing.assert_allclose(out["pmf"], expected, rtol=2 ** -23)
        np.testing.assert_allclose(np_pmf(table, 0, k.astype(np.int64)), expected, rtol=2 ** -23)


def test05_invert_discrete_cdf_sample(gl_ctx):
    table = dist.discrete_cdf_table(WEIGHTS)
    u = np.random.default_rng(13).random(100_000, dtype=np.float32)
    out = run_glsl("DiscreteSample s = sample_discrete_cdf(0u, u); "
                   "float back = invert_discrete_cdf_sample(0u, s.index, s.u_remapped);",
                   {"u": u}, {"back": "float"}, includes=["sampling/discrete_cdf.glsl"],
                   buffers={"table": table}, preamble=PREAMBLE)
    # (u - c0) / (c1 - c0) and back: a few roundings of values below 1
    np.testing.assert_allclose(out["back"], u, rtol=0, atol=4 * 2 ** -24)
    index, _, rem = dist.sample_discrete_cdf(table, 0, u)
    np.testing.assert_allclose(dist.invert_discrete_cdf_sample(table, 0, index, rem), u,
                               rtol=0, atol=4 * 2 ** -24)


def test06_alias_table_holds_the_distribution():
    """Each outcome's total probability in the alias table (kept share of its own bin plus
    the aliased shares of others) is its pmf, to float32 rounding of q."""
    for weights in (WEIGHTS, np.arange(1.0, 101.0), np.array([1e-6, 1.0, 1e6]), np.ones(7)):
        table = dist.alias_table(weights)
        n = int(table[:1].view(np.uint32)[0])
        records = table[1:].reshape(n, 3)
        q = records[:, 0].astype(np.float64)
        alias = records[:, 1].view(np.uint32)
        total = q.copy()
        np.add.at(total, alias, 1.0 - q)
        np.testing.assert_allclose(total / n, weights / weights.sum(), rtol=0, atol=4e-7)


def test07_reflect_or_transmit_by_fresnel(gl_ctx):
    F = np.repeat(np.array([0.0, 0.04, 0.5, 0.9, 1.0], np.float32), 200_000)
    u = np.random.default_rng(14).random(len(F), dtype=np.float32)
    out = run_glsl("DiscreteSample s = choose_reflect_transmit(F, u); uint which = s.index; "
                   "float pmf = s.pmf; float rem = s.u_remapped;", {"F": F, "u": u},
                   {"which": "uint", "pmf": "float", "rem": "float"},
                   includes=["sampling/discrete.glsl"])
    reflect = out["which"] == 0
    np.testing.assert_allclose(out["pmf"], np.where(reflect, F, 1 - F), rtol=1e-7)
    assert np.all(out["which"][F == 0] == 1) and np.all(out["which"][F == 1] == 0)
    # frequency of reflection per F: binomial, Šidák over the three non-trivial F
    z = 4.0
    for f in (0.04, 0.5, 0.9):
        sel = F == f
        freq = reflect[sel].mean()
        assert abs(freq - f) <= z * np.sqrt(f * (1 - f) / sel.sum())
    # the remainder is uniform: its mean 1/2 and variance 1/12 within 4 sigma
    rem = out["rem"].astype(np.float64)
    assert abs(rem.mean() - 0.5) <= 4 * np.sqrt(1 / 12 / len(rem))
    assert np.all((rem >= 0) & (rem < 1))
    which, pmf, rem_np = dist.choose_reflect_transmit(F, u)
    np.testing.assert_array_equal(which, out["which"])
    np.testing.assert_allclose(rem_np, out["rem"], rtol=0, atol=2 ** -20)


def test08_lights_chosen_by_power(gl_ctx):
    powers = np.array([100.0, 1.0, 10.0, 0.0, 50.0, 25.0])
    table = dist.light_power_table(powers)
    u = np.random.default_rng(15).random(SAMPLES, dtype=np.float32)
    out = run_glsl("DiscreteSample s = sample_light_by_power(0u, u); uint light = s.index; "
                   "float pmf = s.pmf;", {"u": u}, {"light": "uint", "pmf": "float"},
                   includes=["sampling/alias_table.glsl"], buffers={"table": table},
                   preamble=PREAMBLE)
    p = powers / powers.sum()
    np.testing.assert_allclose(out["pmf"], p[out["light"]], rtol=2 ** -23)
    counts = np.bincount(out["light"], minlength=len(p))
    assert pearson(counts, p * SAMPLES) >= sidak_alpha(0.01, CHI2_FAMILY)


def test09_packer_offsets_and_buffer_texture(gl_ctx):
    """Several tables in one packed array, read through a buffer texture (the renderer's
    way): each is sampled at its offset exactly as when it stands alone."""
    from glrender.gl.buffers import BufferTexture
    from glrender.gl.shaders import compile_compute

    packer = dist.DistributionPacker()
    off_cdf = packer.add_discrete_cdf(WEIGHTS)
    off_1d = packer.add_distribution_1d([1.0, 0.0, 2.0], (0.0, 3.0))
    off_alias = packer.add_alias_table(WEIGHTS)
    off_2d = packer.add_distribution_2d(np.arange(12.0).reshape(3, 4))
    data = packer.array()
    assert data.dtype == np.float32 and len(data) == packer.size
    assert (off_cdf, off_1d, off_alias) == (0, 2 + 2 * 10, 22 + 5 + 2 * 3)
    assert len(data) - off_2d == 2 + (5 + 2 * 3) + 3 * (5 + 2 * 4)

    u = np.random.default_rng(16).random(4096, dtype=np.float32)
    source = f"""#version 450
layout(local_size_x = 64) in;
#include "sampling/discrete_cdf.glsl"
#include "sampling/alias_table.glsl"
#include "sampling/distribution2d.glsl"
layout(binding = 3) uniform samplerBuffer u_distributions;
layout(std430, binding = 0) readonly buffer U {{ float u_in[]; }};
layout(std430, binding = 1) writeonly buffer O {{ vec4 result[]; }};
float distribution_fetch(uint i) {{ return texelFetch(u_distributions, int(i)).r; }}
void main() {{
    uint i = gl_GlobalInvocationID.x;
    float pdf;
    vec2 p = sample_distribution_2d({off_2d}u, vec2(u_in[i], 1.0 - u_in[i]), pdf);
    result[i] = vec4(float(sample_discrete_cdf({off_cdf}u, u_in[i]).index),
                     float(sample_alias_table({off_alias}u, u_in[i]).index), p.x, pdf);
}}
"""
    texture = BufferTexture(gl_ctx, data, "r32f", "distributions")
    try:
        texture.bind(3)
        program = compile_compute(gl_ctx, source=source, name="packed-test")
        u_buf = gl_ctx.gl.buffer(u.tobytes())
        out_buf = gl_ctx.gl.buffer(reserve=len(u) * 16)
        u_buf.bind_to_storage_buffer(0)
        out_buf.bind_to_storage_buffer(1)
        program.run(group_x=len(u) // 64)
        result = np.frombuffer(out_buf.read(), np.float32).reshape(-1, 4)
        u_buf.release()
        out_buf.release()
    finally:
        texture.release()
    np.testing.assert_array_equal(result[:, 0], dist.sample_discrete_cdf(data, off_cdf, u)[0])
    np.testing.assert_array_equal(result[:, 1], dist.sample_alias_table(data, off_alias, u)[0])
    p, pdf = dist.sample_distribution_2d(data, off_2d, np.column_stack([u, 1 - u]))
    np.testing.assert_allclose(result[:, 2], p[:, 0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(result[:, 3], pdf, rtol=1e-6)


def test10_integers_are_stored_bit_exact():
    table = dist.alias_table(np.ones(70_000))
    assert int(table[:1].view(np.uint32)[0]) == 70_000
    aliases = table[1:].reshape(-1, 3)[:, 1].view(np.uint32)
    assert np.all(aliases < 70_000)


@pytest.mark.parametrize("build, args, message", [
    (dist.discrete_cdf_table, ([],), "no weights"),
    (dist.discrete_cdf_table, ([1.0, -1.0],), "finite and >= 0"),
    (dist.alias_table, ([1.0, np.nan],), "finite and >= 0"),
    (dist.alias_table, ([0.0, 0.0],), "all weights are zero"),
    (dist.distribution_1d_table, ([0.0, 0.0],), "all weights are zero"),
    (dist.distribution_1d_table, ([1.0], (1.0, 1.0)), "empty interval"),
    (dist.distribution_2d_table, ([1.0, 2.0],), "expected a 2D image"),
    (dist.distribution_2d_table, (np.zeros((2, 3)),), "all weights are zero"),
])
def test11_builders_reject_bad_weights(build, args, message):
    with pytest.raises(UsageError, match=message):
        build(*args)


def test12_image_distribution_over_an_environment_map_domain(gl_ctx):
    """A 2D table over (phi, theta) in [0, 2 pi] x [0, pi] with an empty row: the pdf per
    unit area integrates to 1 over the domain and matches the sampler's density."""
    image = np.random.default_rng(17).random((8, 16)) ** 4
    image[3] = 0.0
    bounds = ((0.0, 2 * np.pi), (0.0, np.pi))
    table = dist.distribution_2d_table(image, bounds)
    cell = (2 * np.pi / 16) * (np.pi / 8)
    j, i = np.meshgrid(np.arange(8), np.arange(16), indexing="ij")
    centres = np.column_stack([((i + 0.5) * 2 * np.pi / 16).ravel(), ((j + 0.5) * np.pi / 8).ravel()])
    assert dist.distribution_2d_pdf(table, 0, centres).sum() * cell == pytest.approx(1, rel=1e-6)
    u = np.random.default_rng(18).random((50_000, 2), dtype=np.float32)
    out = run_glsl("float pdf_s; vec2 p = sample_distribution_2d(0u, u, pdf_s); "
                   "float pdf = distribution_2d_pdf(0u, p);", {"u": u},
                   {"p": "vec2", "pdf_s": "float", "pdf": "float"},
                   includes=["sampling/distribution2d.glsl"], buffers={"table": table},
                   preamble=PREAMBLE)
    np.testing.assert_allclose(out["pdf"], out["pdf_s"], rtol=4 * 2 ** -23)
    assert np.all(out["pdf"] > 0)
    row = np.minimum((out["p"][:, 1] / np.pi * 8).astype(int), 7)
    assert not np.any(row == 3)  # the empty row is never chosen
