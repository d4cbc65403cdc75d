"""Instances: flattening, the motion model (decomposition, interpolation, bounds) and ray
queries at a time against a float64 brute force of the moved triangles."""
import numpy as np
import pytest
from bvh_reference import NO_HIT, brute_force, icosphere, load_mesh, random_soup

from glrender.accel import MotionInstance, build_bvh, flatten_instances
from glrender.gpu.bvh_upload import GpuBvh
from glrender.accel.instances import decompose, matrix_from_quaternion, motion_bounds
from glrender.errors import SceneError, UsageError
from glrender.render.params import shader_defines
from glrender.testing.harness import run_glsl


def rotation(axis, angle):
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def affine(linear, translation):
    return np.concatenate([linear, np.asarray(translation, np.float64)[:, None]], axis=1)


def test01_flatten_static_instances():
    v, f = load_mesh("teapot.ply")
    m0 = affine(rotation([0, 0, 1], 0.7) * 2.0, [1, 2, 3])
    m1 = np.eye(4)
    m1[:3, 3] = [-5, 0, 0]
    verts, tris, inst, local = flatten_instances([(v, f)], [(0, m0), (0, m1)])
    assert len(tris) == 2 * len(f) and np.all(inst[:len(f)] == 0) and np.all(local[len(f):] == np.arange(len(f)))
    np.testing.assert_allclose(verts[tris[:len(f)]], v[f] @ m0[:, :3].T + m0[:, 3], rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(verts[tris[len(f):]], v[f] + [-5, 0, 0], atol=1e-5)
    with pytest.raises(SceneError, match="mesh 3 does not exist"):
        flatten_instances([(v, f)], [(3, m1)])
    with pytest.raises(UsageError, match="last row of a 4x4 transform"):
        flatten_instances([(v, f)], [(0, np.ones((4, 4)))])
    assert flatten_instances([], [])[1].shape == (0, 3)


@pytest.mark.parametrize("seed", range(6))
def test02_decomposition_round_trip(seed):
    rng = np.random.default_rng(seed)
    linear = rotation(rng.standard_normal(3), rng.uniform(0, np.pi)) @ np.diag(rng.uniform(0.2, 3, 3))
    linear = linear @ (np.eye(3) + 0.3 * rng.standard_normal((3, 3)) * (seed % 2))  # shear
    if seed >= 4:
        linear = linear @ np.diag([1, -1, 1])  # a reflection
    m = affine(linear, rng.standard_normal(3))
    t, q, s = decompose(m)
    r = matrix_from_quaternion(q)
    assert np.isclose(np.linalg.det(r), 1.0) and np.allclose(r.T @ r, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(s, s.T, atol=1e-12)
    np.testing.assert_allclose(affine(r @ s, t), m, atol=1e-12)


def spinning(v, f, angle=np.radians(170), scale=(1.0, 1.6), shift=(0.0, 0.5, 0.0)):
    open_ = affine(np.eye(3) * scale[0], [0, 0, 0])
    close = affine(rotation([0.3, 1, 0.2], angle) * scale[1], shift)
    return MotionInstance(v, f, open_, close)


def test03_interpolation_is_rigid_and_hits_the_keys():
    v, f = load_mesh("bunny_lowres.ply")
    inst = spinning(v, f, scale=(1.0, 1.0))
    np.testing.assert_allclose(inst.world_from_object(0.0), inst.world_from_object_open, atol=1e-12)
    np.testing.assert_allclose(inst.world_from_object(1.0), inst.world_from_object_close, atol=1e-12)
    mid = inst.world_from_object(0.5)[:, :3]
    np.testing.assert_allclose(mid.T @ mid, np.eye(3), atol=1e-12)  # no shrinking half way
    np.testing.assert_allclose(inst.world_from_object(0.5)[:, :3], rotation([0.3, 1, 0.2], np.radians(85)),
                               atol=1e-12)


@pytest.mark.parametrize("angle, scale", [(np.radians(170), (1.0, 1.6)), (np.radians(1), (1.0, 1.0)),
                                          (0.0, (0.5, 2.0)), (np.radians(90), (1.0, 1.0))])
def test04_motion_bounds_contain_every_time(angle, scale):
    v, f = load_mesh("bunny_lowres.ply")
    v = v - v.mean(axis=0) + [0.3, 0.0, 0.1]  # off the rotation axis
    inst = spinning(v, f, angle, scale)
    lo_o, hi_o = v.min(axis=0), v.max(axis=0)
    lo, hi = motion_bounds(inst, lo_o, hi_o)
    times = np.linspace(0, 1, 2001)
    world = np.stack([v @ inst.world_from_object(t)[:, :3].T + inst.world_from_object(t)[:, 3] for t in times])
    assert np.all(world.min(axis=(0, 1)) >= lo) and np.all(world.max(axis=(0, 1)) <= hi)
    # Conservative but not loose: within 5% of what the object box itself sweeps.
    box = np.array([[x, y, z] for x in (lo_o[0], hi_o[0]) for y in (lo_o[1], hi_o[1]) for z in (lo_o[2], hi_o[2])])
    corners = np.stack([box @ inst.world_from_object(t)[:, :3].T + inst.world_from_object(t)[:, 3] for t in times])
    swept = corners.max(axis=(0, 1)) - corners.min(axis=(0, 1))
    assert np.all((hi - lo) <= 1.05 * swept + 1e-6)


def motion_scene():
    rng = np.random.default_rng(17)
    static_v, static_f = random_soup(rng, 300, spread=3.0, size=0.4)
    bunny_v, bunny_f = load_mesh("bunny_lowres.ply")
    bunny_v = (bunny_v - bunny_v.mean(axis=0)) * 10  # ~1.5 units
    ball_v, ball_f = icosphere(2)
    spin = MotionInstance(bunny_v, bunny_f, affine(np.eye(3), [1.5, 1.5, 1.5]),
                          affine(rotation([0, 1, 0.3], np.radians(150)) * 1.3, [1.7, 1.4, 1.5]))
    slide = MotionInstance(ball_v * 0.4, ball_f, affine(np.eye(3), [0.5, 2.5, 1.0]),
                           affine(np.diag([1.0, 0.6, 1.4]), [2.5, 2.5, 1.0]))
    return (static_v, static_f), [spin, slide]


def world_corners_at(bvh, time):
    """All packed triangles (static first, then each instance's) in world space at ``time``."""
    parts = [bvh.corners.astype(np.float64)]
    for m in bvh.motion:
        w = m.instance.world_from_object(time)
        parts.append(m.bvh.corners.astype(np.float64) @ w[:, :3].T + w[:, 3])
    return np.concatenate(parts)


def trace_t(gpu, o, d, time, t_max=np.inf):
    gpu.bind()
    n = len(o)
    return run_glsl("BvhHit h; bool hit = bvh_intersect_closest_t(o, d, t_max, time, h);"
                    "bool any = bvh_intersect_any_t(o, d, t_max, time);"
                    "float t = h.t; uint prim = h.prim;",
                    {"o": o, "d": d, "time": time.astype(np.float32),
                     "t_max": np.broadcast_to(np.float32(t_max), (n,)).copy()},
                    {"t": "float", "prim": "uint", "hit": "bool", "any": "bool"},
                    includes=["geometry/motion.glsl"], defines={**shader_defines(), **gpu.defines()})


def test05_queries_at_a_time_against_brute_force(gl_ctx):
    (sv, sf), motion = motion_scene()
    bvh = build_bvh(sv, sf, motion=motion)
    assert [r[1] - r[0] for r in bvh.motion_prim_ranges()] == [m.bvh.triangle_count for m in bvh.motion]
    gpu = GpuBvh(gl_ctx, bvh)
    rng = np.random.default_rng(23)
    times = np.repeat(np.linspace(0, 1, 16), 300)
    n = len(times)
    o = (rng.random((n, 3)) * 3).astype(np.float32)
    d = rng.standard_normal((n, 3)).astype(np.float32)
    out = trace_t(gpu, o, d, times)
    ref_t = np.full(n, np.inf)
    ref_prim = np.full(n, -1)
    margin = np.full(n, np.inf)
    second = np.full(n, np.inf)
    for time in np.unique(times):
        k = times == time
        r = brute_force(o[k], d[k], world_corners_at(bvh, time))
        ref_t[k], ref_prim[k], margin[k], second[k] = r["t"], r["prim"], r["margin"], r["second"]
    hit, ref_hit = out["prim"] != NO_HIT, ref_prim >= 0
    # The object-space ray carries float32 rounding of the transform: edge margin 1e-4.
    disagree = hit != ref_hit
    assert not np.any(disagree & (margin >= 1e-4)) and disagree.sum() <= 2e-3 * n
    both = hit & ref_hit
    scale = 8.0 / np.linalg.norm(d, axis=1)  # scene extent in units of |d|
    assert np.all(np.abs(out["t"][both] - ref_t[both]) <= 4e-5 * (ref_t + scale)[both])
    same = out["prim"][both] == ref_prim[both]
    assert np.all(same | (second[both] <= ref_t[both] * (1 + 1e-4)))
    np.testing.assert_array_equal(out["any"], hit)
    motion_hits = np.count_nonzero(out["prim"][hit] >= bvh.triangle_count)
    assert motion_hits > 200 and hit.sum() - motion_hits > 200  # both kinds of geometry are seen


def test06_motion_blur_moves_the_hit(gl_ctx):
    """A ray through where the sliding ball is at open misses it at close, and vice versa."""
    (sv, sf), motion = motion_scene()
    bvh = build_bvh(np.zeros((0, 3)), np.zeros((0, 3), int), motion=[motion[1]])
    gpu = GpuBvh(gl_ctx, bvh)
    o = np.array([[0.5, 2.5, -3.0], [2.5, 2.5, -3.0]] * 2, np.float32)
    d = np.array([[0, 0, 1]] * 4, np.float32)
    out = trace_t(gpu, o, d, np.array([0.0, 0.0, 1.0, 1.0]))
    np.testing.assert_array_equal(out["hit"], [True, False, False, True])
    np.testing.assert_allclose(out["t"][[0, 3]], [4.0 - 0.4, 4.0 - 0.4 * 1.4], rtol=2e-3)  # tessellation


def test07_world_vertices_at_a_time(gl_ctx):
    (sv, sf), motion = motion_scene()
    bvh = build_bvh(sv, sf, motion=motion)
    gpu = GpuBvh(gl_ctx, bvh)
    gpu.bind()
    total = bvh.triangle_count + sum(m.bvh.triangle_count for m in bvh.motion)
    prim = np.arange(total, dtype=np.uint32)
    for time in (0.0, 0.3, 1.0):
        out = run_glsl("vec3 a = bvh_triangle_vertex_t(prim, 0u, time); vec3 c = bvh_triangle_vertex_t(prim, 2u, time);",
                       {"prim": prim}, {"a": "vec3", "c": "vec3"}, uniforms={"time": time},
                       includes=["geometry/motion.glsl"], defines=shader_defines())
        expect = world_corners_at(bvh, time)
        np.testing.assert_allclose(out["a"], expect[:, 0], atol=2e-5 * 5)
        np.testing.assert_allclose(out["c"], expect[:, 2], atol=2e-5 * 5)


def test08_motion_input_errors():
    v, f = load_mesh("teapot.ply")
    with pytest.raises(SceneError, match="singular"):
        MotionInstance(v, f, affine(np.diag([1.0, 1.0, 0.0]), [0, 0, 0]), affine(np.eye(3), [0, 0, 0]))
    with pytest.raises(SceneError, match="reflection appears or vanishes"):
        MotionInstance(v, f, affine(np.diag([1.0, 1.0, -1.0]), [0, 0, 0]), affine(np.eye(3), [0, 0, 0]))
    with pytest.raises(SceneError, match="NaN or infinite"):
        MotionInstance(v, f, affine(np.eye(3), [np.nan, 0, 0]), affine(np.eye(3), [0, 0, 0]))
    with pytest.raises(UsageError, match="is not a MotionInstance"):
        build_bvh(v, f, motion=[(v, f)])
