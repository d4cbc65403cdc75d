"""Static instances sharing bottom-level trees under a top-level tree: the host model
(bounds, records, the builder) and closest/any-hit queries of the GLSL traversal
(geometry/instances.glsl) against a float64 brute force over the flattened copies."""
import numpy as np
import pytest
from bvh_reference import NO_HIT, brute_force, icosphere, load_mesh, random_soup

from glrender.accel import build_bvh
from glrender.accel.instances import (TEXELS_PER_STATIC_INSTANCE, StaticInstances,
                                      instance_world_bounds)
from glrender.errors import SceneError, UsageError
from glrender.gpu.bvh_upload import GpuBvh
from glrender.render.params import shader_defines
from glrender.testing.harness import run_glsl


def random_affine(rng, mirror=False):
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    linear = q @ np.diag(rng.uniform(0.3, 1.2, 3))
    linear = linear @ (np.eye(3) + 0.2 * rng.standard_normal((3, 3)))     # a shear
    if mirror and np.linalg.det(linear) > 0 or not mirror and np.linalg.det(linear) < 0:
        linear = linear @ np.diag([1.0, 1.0, -1.0])
    return np.concatenate([linear, rng.uniform(-4, 4, (3, 1))], axis=1)


def forest(seed=3, copies=(40, 25)):
    """A static soup and two prototypes (a soup of 150 triangles, an icosphere) placed by
    random affine maps, every fifth one a mirror image."""
    rng = np.random.default_rng(seed)
    teapot = random_soup(rng, 150, spread=1.5, size=0.5)
    ball = icosphere(2)
    static = random_soup(rng, 300, spread=8.0, size=1.5)
    static = (static[0] - 4.0, static[1])
    proto = np.concatenate([np.full(copies[0], 0), np.full(copies[1], 1)])
    transforms = np.stack([random_affine(rng, mirror=k % 5 == 0) for k in range(len(proto))])
    return static, StaticInstances([teapot, ball], proto, transforms)


def flattened_corners(bvh):
    """The world-space corners of every packed triangle id, and of each instance's copy of
    its prototype's triangles (instance order = the top-level leaf order)."""
    parts = [bvh.corners.astype(np.float64)]
    top = bvh.top
    bases = np.cumsum([bvh.triangle_count] + [p.triangle_count for p in bvh.prototypes])
    copies, prims, insts = [], [], []
    for j, k in enumerate(top.order):
        p = top.instanced.prototype[k]
        m = top.instanced.transforms[k]
        c = bvh.prototypes[p].corners.astype(np.float64)
        copies.append(c @ m[:, :3].T + m[:, 3])
        prims.append(bases[p] + np.arange(len(c)))
        insts.append(np.full(len(c), j))
    static_prims = np.arange(bvh.triangle_count)
    corners = np.concatenate(parts + copies)
    prim = np.concatenate([static_prims] + prims)
    inst = np.concatenate([np.full(bvh.triangle_count, -1)] + insts)
    return corners, prim, inst


def trace(gpu, o, d, t_max=np.inf):
    gpu.bind()
    n = len(o)
    body = """
        BvhHit h;
        uint inst = kNoInstance;
        bool hit = bvh_traverse(0u, o, d, t_max, false, h);
        if (h.prim != kBvhStackOverflow) hit = instances_traverse(o, d, false, h, inst) || hit;
        BvhHit ha;
        uint ia = kNoInstance;
        bool any = bvh_traverse(0u, o, d, t_max, true, ha);
        if (!any) any = instances_traverse(o, d, true, ha, ia);
        float t = h.t; uint prim = h.prim;
    """
    return run_glsl(body, {"o": o, "d": d, "t_max": np.broadcast_to(np.float32(t_max), (n,)).copy()},
                    {"t": "float", "prim": "uint", "inst": "uint", "hit": "bool", "any": "bool"},
                    includes=["geometry/instances.glsl"], defines={**shader_defines(), **gpu.defines()})


def test01_world_bounds_contain_every_copy():
    rng = np.random.default_rng(0)
    v, f = load_mesh("teapot.ply")
    t = np.stack([random_affine(rng, mirror=k % 2 == 1) for k in range(50)])
    lo, hi = instance_world_bounds(t, v.min(axis=0), v.max(axis=0))
    for k in range(50):
        w = v.astype(np.float64) @ t[k, :, :3].T + t[k, :, 3]
        assert np.all(lo[k] <= w.min(axis=0)) and np.all(hi[k] >= w.max(axis=0))
        # tight: the box of the transformed box, no more than rounding beyond it
        assert np.all(w.min(axis=0) - lo[k] < 0.6 * (hi[k] - lo[k]))


def test02_records_and_top_level():
    (sv, sf), inst = forest()
    bvh = build_bvh(sv, sf, instanced=inst)
    packed = bvh.pack()
    header = packed["instances"][0].view(np.uint32)
    assert header[0] == 0 and header[1] == bvh.triangle_count and header[2] == len(inst)
    assert header[3] == len(packed["nodes"]) // 4 - bvh.top.arrays.node_count    # top level last
    records = packed["instances"][1:].reshape(len(inst), TEXELS_PER_STATIC_INSTANCE, 4)
    for j, k in enumerate(bvh.top.order):
        m = inst.transforms[k]
        np.testing.assert_allclose(records[j, 3:6], m, rtol=1e-6, atol=1e-6)
        inverse = records[j, 0:3].astype(np.float64)
        np.testing.assert_allclose(inverse[:, :3] @ m[:, :3], np.eye(3), atol=1e-5)
    assert sorted(bvh.top.order) == list(range(len(inst)))
    counts = [p.triangle_count for p in bvh.prototypes]
    assert bvh.stats()["instanced_triangles"] == 40 * counts[0] + 25 * counts[1]
    assert len(bvh.buffers().prim_orders) == 3


def test03_queries_against_brute_force(gl_ctx):
    (sv, sf), inst = forest()
    bvh = build_bvh(sv, sf, instanced=inst)
    gpu = GpuBvh(gl_ctx, bvh)
    rng = np.random.default_rng(5)
    n = 3000
    o = (rng.random((n, 3)) * 10 - 5).astype(np.float32)
    d = rng.standard_normal((n, 3)).astype(np.float32)
    out = trace(gpu, o, d)
    corners, prim, owner = flattened_corners(bvh)
    ref = brute_force(o, d, corners)
    ref_hit = ref["prim"] >= 0
    hit = out["prim"] != NO_HIT
    # the object-space ray carries float32 rounding of the transform: edge margin 1e-4
    disagree = hit != ref_hit
    assert not np.any(disagree & (ref["margin"] >= 1e-4)) and disagree.sum() <= 2e-3 * n
    both = hit & ref_hit
    scale = 12.0 / np.linalg.norm(d, axis=1)
    assert np.all(np.abs(out["t"][both] - ref["t"][both]) <= 4e-5 * (ref["t"] + scale)[both])
    want_prim = prim[ref["prim"][both]]
    want_inst = owner[ref["prim"][both]].astype(np.int64)
    got_inst = np.where(out["inst"][both] == NO_HIT, -1, out["inst"][both].astype(np.int64))
    same = (out["prim"][both] == want_prim) & (got_inst == want_inst)
    assert np.all(same | (ref["second"][both] <= ref["t"][both] * (1 + 1e-4)))
    np.testing.assert_array_equal(out["any"], hit)
    instanced_hits = np.count_nonzero(got_inst >= 0)
    assert instanced_hits > 300 and both.sum() - instanced_hits > 100   # both levels are seen
    assert len(np.unique(got_inst[got_inst >= 0])) > 30                 # many copies are met


def test04_input_errors():
    v, f = icosphere(1)
    with pytest.raises(UsageError, match="shape"):
        StaticInstances([(v, f)], [0, 0], np.zeros((3, 3, 4)))
    with pytest.raises(UsageError, match="prototype index"):
        StaticInstances([(v, f)], [1], np.eye(4)[None])
    with pytest.raises(SceneError, match="singular"):
        StaticInstances([(v, f)], [0], np.zeros((1, 3, 4)))
    with pytest.raises(SceneError, match="NaN"):
        StaticInstances([(v, f)], [0], np.full((1, 4, 4), np.nan))
