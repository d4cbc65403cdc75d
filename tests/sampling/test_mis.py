"""Multiple importance sampling weights: they sum to one, follow Veach's formulas, and
guard degenerate inputs (never NaN)."""
import numpy as np
import pytest

from glrender.sampling import mis
from glrender.testing.harness import run_glsl

INCLUDE = ["sampling/mis.glsl"]
N = 100_000
# Sums of count float32 weights, each within a few ulps: |sum - 1| <= 4 count eps.
EPS = 2.0 ** -23


def random_techniques(count, seed):
    rng = np.random.default_rng(seed)
    n = rng.integers(1, 16, (N, count)).astype(np.float32)
    pdf = (10.0 ** rng.uniform(-6, 6, (N, count))).astype(np.float32)  # 12 decades
    pdf[rng.random((N, count)) < 0.1] = 0.0  # some techniques cannot make the sample
    return n, pdf


def test01_two_technique_weights_sum_to_one(gl_ctx):
    (n, pdf) = random_techniques(2, 1)
    out = run_glsl("float bf = mis_balance(n.x, p.x, n.y, p.y); float bg = mis_balance(n.y, p.y, n.x, p.x);"
                   "float pf = mis_power(n.x, p.x, n.y, p.y); float pg = mis_power(n.y, p.y, n.x, p.x);",
                   {"n": n, "p": pdf}, {k: "float" for k in ("bf", "bg", "pf", "pg")}, includes=INCLUDE)
    some = (pdf > 0).any(axis=1)
    for f, g in (("bf", "bg"), ("pf", "pg")):
        total = out[f] + out[g]
        np.testing.assert_allclose(total[some], 1.0, rtol=0, atol=4 * 2 * EPS)
        assert np.all(total[~some] == 0)
    f, g = n[:, 0] * pdf[:, 0].astype(np.float64), n[:, 1] * pdf[:, 1].astype(np.float64)
    with np.errstate(invalid="ignore"):
        np.testing.assert_allclose(out["bf"][some], (f / (f + g))[some], rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(out["pf"][some], (f * f / (f * f + g * g))[some], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(out["bf"], mis.mis_balance(n[:, 0], pdf[:, 0], n[:, 1], pdf[:, 1]),
                               rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(out["pf"], mis.mis_power(n[:, 0], pdf[:, 0], n[:, 1], pdf[:, 1]),
                               rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("count", [2, 3, 5, 8])
def test02_n_technique_weights_sum_to_one(gl_ctx, count):
    n, pdf = random_techniques(count, 10 + count)
    pad = np.zeros((N, 8 - count), np.float32)
    n8, p8 = np.hstack([n, pad]), np.hstack([pdf, pad])
    body = ["float nn[kMisMaxTechniques] = float[](" + ", ".join(
                f"{'na' if i < 4 else 'nb'}[{i % 4}]" for i in range(8)) + ");",
            "float pp[kMisMaxTechniques] = float[](" + ", ".join(
                f"{'pa' if i < 4 else 'pb'}[{i % 4}]" for i in range(8)) + ");",
            "vec4 wb0, wb1, wp0, wp1;",
            "for (int k = 0; k < 4; ++k) {",
            f"    wb0[k] = mis_balance_n(nn, pp, {count}, k); wb1[k] = mis_balance_n(nn, pp, {count}, k + 4);",
            f"    wp0[k] = mis_power_n(nn, pp, {count}, k); wp1[k] = mis_power_n(nn, pp, {count}, k + 4);",
            "}"]
    out = run_glsl("\n".join(body), {"na": n8[:, :4], "nb": n8[:, 4:], "pa": p8[:, :4], "pb": p8[:, 4:]},
                   {"wb0": "vec4", "wb1": "vec4", "wp0": "vec4", "wp1": "vec4"}, includes=INCLUDE)
    some = (pdf > 0).any(axis=1)
    for key in ("b", "p"):
        w = np.hstack([out[f"w{key}0"], out[f"w{key}1"]])
        assert np.all(w[:, count:] == 0) and np.all(np.isfinite(w)) and np.all(w >= 0)
        np.testing.assert_allclose(w.sum(axis=1)[some], 1.0, rtol=0, atol=4 * count * EPS)
        assert np.all(w.sum(axis=1)[~some] == 0)
        ref = np.stack([mis.mis_weight_n(n, pdf, k, 1 if key == "b" else 2) for k in range(count)], 1)
        np.testing.assert_allclose(w[:, :count], ref, rtol=1e-5, atol=1e-12)
    if count == 2:  # the n-technique form is the two-technique form
        np.testing.assert_allclose(out["wb0"][:, 0], mis.mis_balance(n[:, 0], pdf[:, 0], n[:, 1], pdf[:, 1]),
                                   rtol=1e-6, atol=1e-12)


def test03_guards_never_return_nan(gl_ctx):
    inf, nan = np.inf, np.nan
    cases = np.array([  # pdf_f, pdf_g, expected balance weight of f
        [0.0, 0.0, 0.0],   # no technique can make the sample
        [0.0, 2.0, 0.0],
        [2.0, 0.0, 1.0],
        [inf, 1.0, 1.0],   # a delta technique against a finite one
        [1.0, inf, 0.0],
        [inf, inf, 0.0],   # two deltas: undefined, guarded
        [nan, 1.0, 0.0],
        [1.0, nan, 0.0],
        [3e38, 3e38, 0.5],  # (n p)^2 would overflow float32
        [1e-38, 1e-38, 0.5],
        [2.0, 1.0, 2.0 / 3.0],
    ], np.float32)
    out = run_glsl("float b = mis_balance(1.0, c.x, 1.0, c.y); float p = mis_power(1.0, c.x, 1.0, c.y);",
                   {"c": cases}, {"b": "float", "p": "float"}, includes=INCLUDE)
    assert np.all(np.isfinite(out["b"])) and np.all(np.isfinite(out["p"]))
    np.testing.assert_allclose(out["b"], cases[:, 2], rtol=1e-6)
    np.testing.assert_allclose(out["p"][-1], 0.8, rtol=1e-6)  # 4 / (4 + 1)
    np.testing.assert_allclose(out["p"][:-1], np.where(cases[:-1, 2] == 0.5, 0.5, cases[:-1, 2]), rtol=1e-6)
    with np.errstate(all="ignore"):
        np.testing.assert_allclose(mis.mis_balance(1.0, cases[:, 0], 1.0, cases[:, 1]), cases[:, 2], rtol=1e-6)
    w = mis.mis_weight_n(np.ones((3, 3)), np.array([[0, 0, 0], [inf, 1, 2], [inf, inf, 1]], np.float64), 0, 2)
    np.testing.assert_array_equal(w, [0.0, 1.0, 0.0])
