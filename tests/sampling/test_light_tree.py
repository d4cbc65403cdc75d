"""The light BVH (glrender/sampling/light_tree.py, shaders/lights/light_tree.glsl) over a
random set of lights: one-sided and two-sided planar lights facing every way, spheres,
point lights and spot lights whose intensities span three decades, a directional light
and an environment.

At random shading points (with normals, and without: points in a medium):
- the probabilities of all lights sum to at most 1, and to 1 less the chance that the
  descent meets a node whose children both have importance 0 (no light chosen: a node's
  bound is looser than its children's), which stays small;
- the sampler's frequencies, "none" among the outcomes, match the pmf (chi-square, one
  Šidák family, CHI2_FAMILY): the pmf's descent along each light's bit trail is the
  sampler's;
- a sample's own probability is the pmf of the light it chose, and GLSL agrees with the
  numpy twins;
- a light the tree never chooses at a point brings it nothing: a one-sided light whose
  plane has the point behind it, a spot whose cutoff cone misses it (the importance is a
  bound, so this is what keeps light selection unbiased).
"""
import numpy as np
import pytest

from glrender.sampling import light_tree as lt
from glrender.testing.harness import run_glsl
from glrender.testing.stats import chi2_sf, sidak_alpha

PREAMBLE = ("float distribution_fetch(uint i) { return table[i]; }\n"
            "uvec4 distribution_fetch4(uint i) { return floatBitsToUint(vec4(table[i], table[i + 1u], "
            "table[i + 2u], table[i + 3u])); }")
CHI2_FAMILY = 6   # test03's shading points
N_PLANAR, N_SPHERE, N_POINT, N_SPOT, N_INF = 120, 20, 30, 30, 2


def random_lights(seed=7):
    """LightBounds of a random light set in a 20-unit box, and per light its kind, the
    planar lights' corner points and the spots' cutoff cosines (for test04)."""
    rng = np.random.default_rng(seed)
    n = N_PLANAR + N_SPHERE + N_POINT + N_SPOT + N_INF
    kind = np.array(["planar"] * N_PLANAR + ["sphere"] * N_SPHERE + ["point"] * N_POINT +
                    ["spot"] * N_SPOT + ["infinite"] * N_INF)
    centre = rng.uniform(-10, 10, (n, 3))
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    b = lt.LightBounds(lo=centre.copy(), hi=centre.copy(), phi=10 ** rng.uniform(-2, 1, n),
                       w=np.tile([0.0, 0.0, 1.0], (n, 1)), cos_o=np.full(n, -1.0),
                       cos_e=np.zeros(n), two_sided=np.zeros(n, bool), infinite=kind == "infinite")
    corners = np.zeros((n, 4, 3))
    cos_cutoff = np.full(n, -1.0)
    for i in range(n):
        if kind[i] == "planar":
            t = np.cross(normal[i], [0.3, 0.5, 0.8])
            t /= np.linalg.norm(t)
            s = np.cross(normal[i], t)
            half = rng.uniform(0.05, 1.0, 2)
            corners[i] = [centre[i] + a * half[0] * t + c * half[1] * s
                          for a, c in ((-1, -1), (1, -1), (-1, 1), (1, 1))]
            b.lo[i], b.hi[i] = corners[i].min(axis=0), corners[i].max(axis=0)
            b.w[i], b.cos_o[i] = normal[i], 1.0
            b.two_sided[i] = i % 4 == 0
        elif kind[i] == "sphere":
            r = rng.uniform(0.1, 1.0)
            b.lo[i], b.hi[i] = centre[i] - r, centre[i] + r
        elif kind[i] == "spot":
            beam, cutoff = np.sort(rng.uniform(0.1, 1.2, 2))
            b.w[i], b.cos_o[i] = normal[i], np.cos(beam)
            b.cos_e[i] = np.cos(cutoff - beam)
            cos_cutoff[i] = np.cos(cutoff)
        elif kind[i] == "infinite" and i == n - N_INF:   # a directional light, then an environment
            b.w[i], b.cos_o[i] = normal[i], 1.0
    return b, kind, corners, cos_cutoff


def shading_points(count, seed):
    """Points in the lights' box (some inside light boxes' neighbourhoods), normals, and
    every fourth point without a normal (a point in a medium)."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-11, 11, (count, 3))
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[::4] = 0.0
    return p.astype(np.float32), n.astype(np.float32)


@pytest.fixture(scope="module")
def tree():
    b, kind, corners, cos_cutoff = random_lights()
    return lt.light_tree_table(b), b, kind, corners, cos_cutoff


def glsl_pmf_all(block, p, n, infinite):
    """GLSL light_tree_pmf of every light at each of the points: (points, lights)."""
    lights = len(infinite)
    pp = np.repeat(p, lights, axis=0)
    nn = np.repeat(n, lights, axis=0)
    light = np.tile(np.arange(lights, dtype=np.uint32), len(p))
    inf = np.tile(infinite.astype(np.uint32), len(p))
    out = run_glsl("float pmf = light_tree_pmf(0u, p, n, light, inf != 0u);",
                   {"p": pp, "n": nn, "light": light, "inf": inf}, {"pmf": "float"},
                   includes=["lights/light_tree.glsl"], buffers={"table": block}, preamble=PREAMBLE)
    return out["pmf"].reshape(len(p), lights).astype(np.float64)


def glsl_sample(block, p, n, u):
    out = run_glsl("LightChoice c = light_tree_sample(0u, p, n, u); uint index = c.index; float pmf = c.pmf;",
                   {"p": p, "n": n, "u": u}, {"index": "uint", "pmf": "float"},
                   includes=["lights/light_tree.glsl"], buffers={"table": block}, preamble=PREAMBLE)
    return out["index"].astype(np.int64), out["pmf"].astype(np.float64)


def test01_probabilities_sum_to_one(gl_ctx, tree):
    block, b, *_ = tree
    p, n = shading_points(64, 1)
    pmf = glsl_pmf_all(block, p, n, b.infinite)
    total = pmf.sum(axis=1)
    assert np.all(total <= 1 + 2e-5) and np.all(total > 0.9), total.min()
    # the lights at infinity: n_inf / (n_inf + 1) among them, uniformly
    # the lights at infinity: in proportion to their irradiance (the directional one's
    # times |cos|) beside the tree's root
    root = np.array([lt.light_tree_importance(lt.light_tree_root(block), p[k], n[k]) for k in range(len(p))])
    inf = np.flatnonzero(b.infinite)
    irradiance = np.stack([b.phi[inf[0]] * np.abs(n @ b.w[inf[0]]), np.full(len(p), b.phi[inf[1]])], axis=1)
    np.testing.assert_allclose(pmf[:, inf], irradiance / (irradiance.sum(axis=1) + root)[:, None], rtol=2e-4)
    # numpy's twin
    for k in range(0, 64, 9):
        twin = [lt.light_tree_pmf(block, p[k], n[k], i, bool(b.infinite[i])) for i in range(len(b.phi))]
        np.testing.assert_allclose(twin, pmf[k], rtol=2e-4, atol=1e-9)


def test02_a_sample_has_the_probability_of_its_light(gl_ctx, tree):
    block, b, *_ = tree
    p, n = shading_points(4096, 2)
    u = np.random.default_rng(3).random(4096, dtype=np.float32)
    index, pmf = glsl_sample(block, p, n, u)
    chosen = pmf > 0
    assert chosen.mean() > 0.95
    table = glsl_pmf_all(block, p[:256], n[:256], b.infinite)
    np.testing.assert_allclose(pmf[:256][chosen[:256]], table[np.arange(256), index[:256]][chosen[:256]], rtol=1e-6)
    # numpy's twin makes the same choices (float32 against float64: a choice near a
    # boundary between children may differ)
    twin = [lt.light_tree_sample(block, p[k], n[k], float(u[k])) for k in range(512)]
    twin_index = np.array([t[0] for t in twin])
    same = np.where(chosen[:512], twin_index == index[:512], twin_index == -1)
    assert same.mean() > 0.99
    np.testing.assert_allclose(np.array([t[1] for t in twin])[same], pmf[:512][same], rtol=2e-4)


@pytest.mark.parametrize("point", range(CHI2_FAMILY))
def test03_frequencies_match_the_pmf(gl_ctx, tree, point):
    block, b, *_ = tree
    p, n = shading_points(CHI2_FAMILY, 4)
    samples = 200_000
    pp = np.repeat(p[point:point + 1], samples, axis=0)
    nn = np.repeat(n[point:point + 1], samples, axis=0)
    u = np.random.default_rng(10 + point).random(samples, dtype=np.float32)
    index, pmf = glsl_sample(block, pp, nn, u)
    probability = glsl_pmf_all(block, p[point:point + 1], n[point:point + 1], b.infinite)[0]
    # the outcomes: each light, then none (a pmf of 0)
    expected = np.append(probability, max(1 - probability.sum(), 0.0)) * samples
    index = np.where(pmf > 0, index, len(probability))
    counts = np.bincount(index, minlength=len(expected)).astype(np.float64)
    assert np.all(counts[expected == 0] == 0), "a light of probability 0 was chosen"
    # pool the outcomes expected fewer than 5 times into one cell
    small = (expected > 0) & (expected < 5)
    cells_e = np.append(expected[expected >= 5], expected[small].sum())
    cells_c = np.append(counts[expected >= 5], counts[small].sum())
    if cells_e[-1] == 0:
        cells_e, cells_c = cells_e[:-1], cells_c[:-1]
    stat = float(np.sum((cells_c - cells_e) ** 2 / cells_e))
    assert chi2_sf(stat, len(cells_e) - 1) >= sidak_alpha(0.01, CHI2_FAMILY)


def test04_lights_never_chosen_bring_nothing(gl_ctx, tree):
    """Where a light's probability is 0 at a point it cannot light the point: one-sided
    planar lights have the point behind their plane, spots have it outside their cutoff."""
    block, b, kind, corners, cos_cutoff = tree
    p, n = shading_points(512, 5)
    pmf = glsl_pmf_all(block, p, n, b.infinite)
    zero = pmf == 0
    assert zero.sum() > 1000    # the tree does rule lights out
    for i in np.flatnonzero(kind == "planar"):
        if b.two_sided[i]:
            continue
        ahead = (p[:, None, :] - corners[i][None]) @ b.w[i]   # (points, corners)
        lit = (ahead > 1e-4).any(axis=1)
        assert not np.any(zero[:, i] & lit), i
    for i in np.flatnonzero(kind == "spot"):
        d = p - b.lo[i]
        cos = d @ b.w[i] / np.linalg.norm(d, axis=1)
        assert not np.any(zero[:, i] & (cos > cos_cutoff[i] + 1e-5)), i


def test05_point_and_spot_lights_alone(gl_ctx):
    """A tree of one light is its root: chosen wherever it can reach (probability 1)."""
    b = lt.LightBounds(lo=np.zeros((1, 3)), hi=np.zeros((1, 3)), phi=np.ones(1),
                       w=np.array([[0.0, 0.0, -1.0]]), cos_o=np.array([np.cos(0.3)]),
                       cos_e=np.array([np.cos(0.2)]), two_sided=np.zeros(1, bool),
                       infinite=np.zeros(1, bool))
    block = lt.light_tree_table(b)
    p = np.array([[0, 0, -2], [0, 0, 2], [1.5, 0, -2]], np.float32)   # below, above, off-axis
    n = np.zeros((3, 3), np.float32)
    pmf = glsl_pmf_all(block, p, n, b.infinite)[:, 0]
    np.testing.assert_array_equal(pmf, [1.0, 0.0, 0.0])   # atan(1.5 / 2) = 0.64 > 0.5


def angle(a, b):
    """The angles between the directions a and b (..., 3), accurate near 0."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), (a * b).sum(axis=-1))


def decoded_nodes(block):
    """Every node of the block decoded by the numpy twin, top-down: (node, parent box)."""
    out = {}
    root = lt.light_tree_root(block)
    out[0] = (root, np.asarray(block[4:7], np.float32), np.asarray(block[8:11], np.float32))
    stack = [0]
    while stack:
        i = stack.pop()
        nd = out[i][0]
        if not nd.leaf:
            for c in (nd.child, nd.child + 1):
                out[c] = (lt._decode(block, c, nd.lo, nd.hi), nd.lo, nd.hi)
                stack.append(c)
    return out


def test06_quantised_nodes_hold_their_lights(tree):
    """Each decoded node bounds what it holds: its box holds the node's box, its sphere the
    decoded box, its cone (axis, theta_o) the node's cone and its theta_e is at least the
    node's; its intensity is the node's (float32)."""
    block, b, *_ = tree
    builder = lt._build(b)
    nodes = decoded_nodes(block)
    assert len(nodes) == builder.used == 2 * int((~b.infinite).sum()) - 1
    for i, (nd, _, _) in nodes.items():
        assert np.all(nd.lo.astype(np.float64) <= builder.lo[i]) and np.all(nd.hi.astype(np.float64) >= builder.hi[i]), i
        centre = (np.float32(0.5) * (nd.lo + nd.hi)).astype(np.float64)
        corners = np.array([[(nd.hi if (k >> a) & 1 else nd.lo)[a] for a in range(3)] for k in range(8)], np.float64)
        assert np.linalg.norm(corners - centre, axis=1).max() <= nd.half_diag, i
        assert nd.phi == np.float32(builder.phi[i])
        assert nd.cos_e <= builder.cos_e[i]
        assert nd.leaf == bool(builder.flags[i] & lt.FLAG_LEAF)
        assert nd.two_sided == bool(builder.flags[i] & lt.FLAG_TWO_SIDED)
        if builder.cos_o[i] > -1:
            axis_error = angle(nd.w, builder.w[i])
            assert np.arccos(builder.cos_o[i]) + axis_error <= np.arccos(nd.cos_o), i
    # quantisation is close: boxes grow by a few steps of their parent's, cones by ~0.01 rad
    for i, (nd, p_lo, p_hi) in nodes.items():
        step = (p_hi.astype(np.float64) - p_lo) / lt.BOX_STEPS
        assert np.all(builder.lo[i] - nd.lo <= 2 * step + 1e-5) and np.all(nd.hi - builder.hi[i] <= 2 * step + 1e-5)


def test07_quantisers_round_outward():
    """The box, cosine and axis encodings on their own, on hard cases: tiny boxes far from
    the origin inside large parents, boxes touching their parent's sides, points; cosines
    at +-1 and 0; axes along and near the octahedron's folds."""
    rng = np.random.default_rng(11)
    m = 4000
    centre = rng.uniform(-1e4, 1e4, (m, 3)) * (rng.random((m, 1)) < 0.5)
    size = 10.0 ** rng.uniform(-6, 4, (m, 1))
    p_lo = (centre - size).astype(np.float32)
    p_hi = (centre + size).astype(np.float32)
    t = np.sort(rng.random((m, 2, 3)), axis=1)
    t[::7, 0] = 0.0
    t[::5, 1] = 1.0
    t[::11, 1] = t[::11, 0]    # points
    lo = p_lo + t[:, 0] * (p_hi.astype(np.float64) - p_lo)
    hi = p_lo + t[:, 1] * (p_hi.astype(np.float64) - p_lo)
    lo, hi = np.maximum(lo, p_lo), np.minimum(hi, p_hi)
    q_lo, q_hi, d_lo, d_hi = lt.quantise_box(lo, hi, p_lo, p_hi)
    assert np.all(q_lo <= lt.BOX_STEPS) and np.all(q_hi <= lt.BOX_STEPS)
    assert np.all(d_lo <= lo) and np.all(d_hi >= hi)
    np.testing.assert_array_equal((d_lo, d_hi), lt.decode_box(q_lo, q_hi, p_lo, p_hi))
    c = np.concatenate([[-1.0, 0.0, 1.0, -1 + 1e-9, 1 - 1e-9], rng.uniform(-1, 1, 2000)])
    q = lt.quantise_cos(c)
    assert np.all(lt.decode_cos(q) <= c) and np.all(q <= lt.COS_STEPS)
    assert np.all(c - lt.decode_cos(q) < 2.5 / lt.COS_STEPS)
    w = rng.normal(size=(3000, 3))
    w[:6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    w[6:12, 2] = 0.0           # on the fold z = 0
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    bits, wd = lt.encode_octahedral(w)
    np.testing.assert_array_equal(wd, lt.decode_octahedral(bits))
    error = angle(wd, w)
    assert error.max() < 1e-4
    cos_o = rng.uniform(-1, 1, len(w))
    cos_o[:20] = 1.0
    widened = lt.widen_cone(cos_o, w, wd)
    assert np.all(np.arccos(cos_o) + error <= np.arccos(widened))


def test08_glsl_decodes_as_the_twin(gl_ctx, tree):
    """The shader decodes every node as the numpy twin (its box within one float32 step
    for a fused multiply-add, still holding the node's box)."""
    block, b, *_ = tree
    builder = lt._build(b)
    nodes = decoded_nodes(block)
    idx = np.array(sorted(nodes), np.uint32)
    p_lo = np.array([nodes[i][1] for i in idx], np.float32)
    p_hi = np.array([nodes[i][2] for i in idx], np.float32)
    at = (lt.HEADER + lt.INFINITE_FLOATS * lt._u(block, 1) + lt._u(block, 2) + lt.NODE_FLOATS * idx).astype(np.uint32)
    out = run_glsl("LightTreeNode nd = light_tree_decode(at, p_lo, p_hi); vec3 lo = nd.lo; vec3 hi = nd.hi; "
                   "vec3 w = nd.w; vec4 c = vec4(nd.cos_o, nd.cos_e, nd.phi, nd.half_diag); "
                   "uint word = nd.word; uint child = nd.child;",
                   {"at": at, "p_lo": p_lo, "p_hi": p_hi},
                   {"lo": "vec3", "hi": "vec3", "w": "vec3", "c": "vec4", "word": "uint", "child": "uint"},
                   includes=["lights/light_tree.glsl"], buffers={"table": block}, preamble=PREAMBLE)
    twin = [nodes[i][0] for i in idx]
    lo = np.array([t.lo for t in twin])
    hi = np.array([t.hi for t in twin])
    ulp = np.spacing(np.maximum(np.abs(p_lo), np.abs(p_hi)))
    assert np.all(np.abs(out["lo"] - lo) <= ulp) and np.all(np.abs(out["hi"] - hi) <= ulp)
    assert np.all(out["lo"] <= builder.lo[idx]) and np.all(out["hi"] >= builder.hi[idx])
    np.testing.assert_allclose(out["w"], np.array([t.w for t in twin]), atol=1e-6)
    np.testing.assert_array_equal(out["c"], np.array([[t.cos_o, t.cos_e, t.phi, t.half_diag] for t in twin], np.float32))
    np.testing.assert_array_equal(out["child"], [t.child for t in twin])
    np.testing.assert_array_equal(out["word"] >> 30, [t.two_sided * 1 + t.leaf * 2 for t in twin])


def test09_nodes_start_on_16_bytes(gl_ctx, tree):
    """Wherever the block sits in the packed array (LightBounds.offset), its nodes start on a
    multiple of 4 elements (the shader reads them 16 bytes at a time) and are the same nodes;
    the device scene's light table puts the tree where its light bounds say, after the
    alias table."""
    import dataclasses
    import sys
    from pathlib import Path
    from glrender.gpu.device_scene import DeviceScene
    from glrender.scene import model as m
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))
    from render_scenes import base

    block, b, *_ = tree
    nodes = lt._u(block, 0) * lt.NODE_FLOATS
    for offset in range(5):
        moved = lt.light_tree_table(dataclasses.replace(b, offset=offset))
        at = lt.HEADER + lt.INFINITE_FLOATS * lt._u(moved, 1) + lt._u(moved, 2)
        assert (offset + at) % 4 == 0 and lt._u(moved, 2) < 4
        np.testing.assert_array_equal(moved[at:at + nodes], block[at - lt._u(moved, 2) + lt._u(block, 2):][:nodes])
    scene = base(8, 8)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5)))
    for k in range(3):
        scene.shapes.append(m.Shape("rectangle", material=grey, emission=m.Emission((1.0 + k, 1.0, 1.0)),
                                    world_from_object=m.translate((k, 0.0, 2.0))))
    scene.lights.append(m.Light("point", position=(0.0, 0.0, 5.0), intensity=(2.0, 2.0, 2.0)))
    scene.lights.append(m.Light("constant", radiance=(0.1, 0.1, 0.1)))
    ds = DeviceScene(gl_ctx, scene)
    try:
        n = len(ds.packed.lights)
        dist = ds.light_table("bvh", "area").distributions
        t = 1 + 3 * n     # shaders/lights/light_selection.glsl light_tree_offset
        tree_block = dist[t:]
        assert lt._u(tree_block, 0) == 2 * (n - 1) - 1 and lt._u(tree_block, 1) == 1
        assert (t + lt.HEADER + lt.INFINITE_FLOATS + lt._u(tree_block, 2)) % 4 == 0
        total = sum(lt.light_tree_pmf(tree_block, [0.5, 0.0, 0.0], [0.0, 0.0, 1.0], i, i == n - 1) for i in range(n))
        assert abs(total - 1) < 1e-5
    finally:
        ds.release()
