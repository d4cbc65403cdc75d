"""GLSL traversal against a float64 brute force, Embree, and on closed meshes (watertightness).

Tolerances come from float32: the watertight test works on vertex coordinates
relative to the ray origin in float32, so the hit distance is accurate to a few
ulps of the origin-to-vertex distance: t is asserted within 1e-5 relative of
the float64 value, or within 1e-5 of the vertex distance (in units of |d|) for
hits so close to the origin that this is the larger (t ~ 1e-5 of the scene).
A ray may legitimately flip between hit and miss only when it passes within
float32 rounding of a triangle's edge (barycentric margin < 1e-5) or ends within
1e-5 of its t_max. Everything else must agree exactly.
"""
import re
from pathlib import Path

import numpy as np
import pytest
from bvh_reference import NO_HIT, brute_force, icosphere, load_mesh, random_soup, trace_glsl

from glrender.accel import build_bvh
from glrender.accel import bvh as bvh_module
from glrender.accel import instances as instances_module
from glrender.gpu import bindings, bvh_upload
from glrender.gpu.bvh_upload import INSTANCES, KINDS, UNITS_RESERVED, GpuBvh
from glrender.errors import UsageError
from glrender.gl.shaders import packaged_root

REL_T = 1e-5
EDGE_MARGIN = 1e-5


def random_rays(rng, n, lo, hi, spread=1.5):
    centre, size = (lo + hi) / 2, (hi - lo).max()
    o = centre + (rng.random((n, 3)) - 0.5) * size * spread
    d = rng.standard_normal((n, 3))
    return o.astype(np.float32), d.astype(np.float32)


def compare(bvh, o, d, t_max, out, max_flips=1e-3):
    """Assert the GLSL answers match the float64 brute force (see the module doc)."""
    ref = brute_force(o, d, bvh.corners, t_max)
    hit = out["prim"] != NO_HIT
    ref_hit = ref["prim"] >= 0
    t_max = np.broadcast_to(t_max, hit.shape).astype(np.float64)
    corners = bvh.corners[np.maximum(ref["prim"], 0)].astype(np.float64)
    reach = np.linalg.norm(corners - o[:, None, :], axis=2).max(axis=1) / np.linalg.norm(d, axis=1)
    near_t_max = np.isfinite(t_max) & (np.abs(np.minimum(ref["t"], 1e30) - t_max) <= REL_T * t_max)
    at_origin = ref_hit & (ref["t"] <= REL_T * reach)  # starts on the surface, within rounding
    borderline = (ref["margin"] < EDGE_MARGIN) | near_t_max | at_origin
    disagree = (hit != ref_hit) & ~at_origin
    assert not np.any(disagree & ~borderline), np.nonzero(disagree & ~borderline)[0][:10]
    assert disagree.sum() <= max_flips * len(o) + 2  # borderline flips are rare
    both = hit & ref_hit & ~at_origin
    tolerance = REL_T * np.maximum(ref["t"], reach)
    assert np.all(np.abs(out["t"][both] - ref["t"][both]) <= tolerance[both])
    # Same triangle unless another lies within the t tolerance (an exact tie).
    other = both & (out["prim"] != ref["prim"])
    assert np.all(ref["second"][other] <= ref["t"][other] * (1 + 2 * REL_T)), np.nonzero(other)[0][:10]
    # Barycentrics of the reported triangle reproduce the hit point.
    k = np.nonzero(both & ~other)[0]
    c = bvh.corners[out["prim"][k]].astype(np.float64)
    b = out["bary"][k].astype(np.float64)
    p = c[:, 0] + b[:, :1] * (c[:, 1] - c[:, 0]) + b[:, 1:] * (c[:, 2] - c[:, 0])
    q = o[k].astype(np.float64) + out["t"][k, None].astype(np.float64) * d[k]
    scale = np.abs(c).max(axis=(1, 2)) + np.abs(q).max(axis=1)
    assert np.all(np.linalg.norm(p - q, axis=1) <= 1e-5 * scale)
    # Any-hit answers the occlusion question exactly as closest-hit does.
    np.testing.assert_array_equal(out["any"], hit)  # exactly, borderline rays included
    np.testing.assert_array_equal(out["hit"], hit)
    return ref


@pytest.mark.parametrize("method", ["ploc", "binned_sah"])
@pytest.mark.parametrize("seed, count", [(11, 1000), (12, 40)])
def test01_random_soups_against_brute_force(gl_ctx, method, seed, count):
    rng = np.random.default_rng(seed)
    v, f = random_soup(rng, count, size=0.3 if count > 100 else 0.8)
    bvh = build_bvh(v, f, method=method)
    gpu = GpuBvh(gl_ctx, bvh)
    o, d = random_rays(rng, 6000, v.min(0), v.max(0))
    t_max = np.where(rng.random(len(o)) < 0.5, np.inf, rng.random(len(o)) * 2).astype(np.float32)
    ref = compare(bvh, o, d, t_max, trace_glsl(gpu, o, d, t_max))
    hits = np.count_nonzero(ref["prim"] >= 0)
    assert 300 < hits < len(o) - 300  # the test sees plenty of hits and misses


def test02_awkward_rays(gl_ctx):
    """Axis-aligned and signed-zero directions, unnormalised lengths, origins on planes."""
    rng = np.random.default_rng(21)
    v, f = load_mesh("teapot.ply")
    bvh = build_bvh(v, f)
    gpu = GpuBvh(gl_ctx, bvh)
    o, d = random_rays(rng, 3000, v.min(0), v.max(0), spread=1.2)
    axis = rng.integers(0, 3, len(o))
    d[:1000] = 0.0
    d[np.arange(1000), axis[:1000]] = rng.choice([-1.0, 1.0], 1000)
    d[1000:1500, 1] = -0.0  # one zero component, sign bit set
    d[1500:2000, :2] = 0.0
    d[2000:2250] *= 1e-3
    d[2250:2500] *= 1e3
    o[2500:2750, 2] = 0.0  # on the plane z = 0 where the teapot stands
    o[2750:, :] = v[f[rng.integers(0, len(f), 250), 0]]  # starting exactly on a vertex
    # Rays starting on the surface or sliding along the base are borderline by nature.
    compare(bvh, o, d, np.float32(np.inf), trace_glsl(gpu, o, d, np.inf), max_flips=0.02)


def test03_t_is_in_units_of_d(gl_ctx):
    v, f = load_mesh("bunny_lowres.ply")
    gpu = GpuBvh(gl_ctx, build_bvh(v, f))
    rng = np.random.default_rng(5)
    o, d = random_rays(rng, 5000, v.min(0), v.max(0), spread=0.5)
    a = trace_glsl(gpu, o, d)
    b = trace_glsl(gpu, o, d * np.float32(4.0))
    hit = a["prim"] != NO_HIT
    assert hit.mean() > 0.5
    np.testing.assert_array_equal(b["prim"], a["prim"])
    np.testing.assert_allclose(b["t"][hit] * 4, a["t"][hit], rtol=REL_T)


@pytest.mark.parametrize("name", ["bunny_lowres.ply", "teapot.ply"])
def test04_same_hits_as_embree(gl_ctx, name):
    """>= 99.99% identical hit/miss and primitive ids on 10^5 rays per mesh."""
    rtcore_scene = pytest.importorskip("embreex.rtcore_scene", reason="embreex (test extra) not installed")
    from embreex.mesh_construction import TriangleMesh

    v, f = load_mesh(name)
    bvh = build_bvh(v, f)
    gpu = GpuBvh(gl_ctx, bvh)
    rng = np.random.default_rng(8)
    o, d = random_rays(rng, 100_000, v.min(0), v.max(0), spread=0.8)
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, v, f.astype(np.int32))
    ref = scene.run(o, d, output=1)
    out = trace_glsl(gpu, o, d)
    ours = np.where(out["prim"] != NO_HIT, bvh.prim_order[np.minimum(out["prim"], bvh.triangle_count - 1)], -1)
    theirs = np.where(ref["geomID"] >= 0, ref["primID"], -1)
    hit = ours >= 0
    assert 0.3 < hit.mean() < 0.9
    assert np.mean(hit == (theirs >= 0)) >= 0.9999
    # Duplicate triangles (bunny_lowres has 40) are one triangle to the builder: compare
    # each id's first geometric twin.
    position = np.unique(v, axis=0, return_inverse=True)[1].ravel()
    _, first, twin = np.unique(np.sort(position[f], axis=1), axis=0, return_index=True, return_inverse=True)
    canonical = np.concatenate([first[twin.ravel()], [-1]])
    assert np.mean(canonical[ours] == canonical[theirs]) >= 0.9999


def star_mesh(subdivisions, offset=(0.0, 0.0, 0.0), scale=1.0):
    """A closed icosphere with a smooth radial bump (vertices shared: a closed manifold)."""
    v, f = icosphere(subdivisions)
    r = 1.0 + 0.15 * np.sin(5 * v[:, 0]) * np.cos(3 * v[:, 1])
    return (v * r[:, None] * scale + np.asarray(offset)).astype(np.float32), f


def edge_targets(v, f, rng):
    """Points on every edge in float32: midpoints, thirds and a random fraction."""
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    a, b = v[e[:, 0]], v[e[:, 1]]
    fractions = [np.float32(0.5), np.float32(1 / 3), rng.random((len(e), 1)).astype(np.float32)]
    return np.concatenate([a + fr * (b - a) for fr in fractions]).astype(np.float32)


@pytest.mark.parametrize("offset, scale", [((0.0, 0.0, 0.0), 1.0), ((1000.0, -500.0, 250.0), 3.0)])
def test05_watertight_from_inside(gl_ctx, offset, scale):
    """>= 10^6 rays aimed exactly at the vertices and edges of a closed mesh, from inside: no misses."""
    v, f = star_mesh(5, offset, scale)  # 20,480 triangles, 10,242 vertices, 30,720 edges
    gpu = GpuBvh(gl_ctx, build_bvh(v, f))
    rng = np.random.default_rng(99)
    targets = np.concatenate([v, edge_targets(v, f, rng)])
    centre = np.asarray(offset, np.float32)
    origins = [centre] + [centre + (rng.random(3) - 0.5).astype(np.float32) * np.float32(0.6 * scale)
                          for _ in range(9)]
    o = np.concatenate([np.broadcast_to(c, targets.shape) for c in origins]).astype(np.float32)
    d = (np.tile(targets, (len(origins), 1)) - o).astype(np.float32)
    assert len(o) >= 1_000_000
    out = trace_glsl(gpu, o, d)
    assert np.count_nonzero(out["prim"] == NO_HIT) == 0
    assert np.count_nonzero(~out["any"]) == 0
    # Every ray leaves through the surface near its target (t ~ 1 in units of d).
    assert np.all(np.abs(out["t"] - 1.0) < 0.05)


def front_facing_targets(v, f, eyes, rng):
    """Per eye: vertices and edge points whose every adjacent triangle faces it (with margin).

    A ray from outside aimed at such a point enters the surface there, so it must
    hit something; silhouette points, where a ray may graze past, are left out.
    """
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]).astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    a, b = v[unique[:, 0]], v[unique[:, 1]]
    fraction = rng.random((len(a), 1)).astype(np.float32)
    points = np.concatenate([v, a + np.float32(0.5) * (b - a), a + fraction * (b - a)]).astype(np.float32)
    for eye in eyes:
        to_eye = eye - v[f[:, 0]]
        facing = np.einsum("ij,ij->i", n, to_eye) / np.linalg.norm(to_eye, axis=1) > 0.05
        vertex_ok = np.ones(len(v), bool)
        np.logical_and.at(vertex_ok, f.ravel(), np.repeat(facing, 3))
        edge_ok = np.ones(len(unique), bool)
        np.logical_and.at(edge_ok, inverse.ravel(), np.repeat(facing[None], 3, axis=0).ravel())
        yield eye, points[np.concatenate([vertex_ok, edge_ok, edge_ok])]


def test06_watertight_from_outside(gl_ctx):
    """>= 10^6 rays from outside aimed exactly at front-facing vertices and edges: no misses."""
    v, f = star_mesh(5)
    gpu = GpuBvh(gl_ctx, build_bvh(v, f))
    rng = np.random.default_rng(97)
    eyes = rng.standard_normal((46, 3))
    eyes = (3.0 * eyes / np.linalg.norm(eyes, axis=1, keepdims=True)).astype(np.float32)
    o, d = [], []
    for eye, targets in front_facing_targets(v, f, eyes, rng):
        o.append(np.broadcast_to(eye, targets.shape))
        d.append(targets - eye)
    o, d = np.concatenate(o).astype(np.float32), np.concatenate(d).astype(np.float32)
    assert len(o) >= 1_000_000
    out = trace_glsl(gpu, o, d)
    assert np.count_nonzero(out["prim"] == NO_HIT) == 0 and out["any"].all()


def test06b_watertight_small(gl_ctx):
    """The fast version of test05: the vertices and edge midpoints of a smaller closed mesh."""
    v, f = star_mesh(3)
    gpu = GpuBvh(gl_ctx, build_bvh(v, f))
    rng = np.random.default_rng(98)
    targets = np.concatenate([v, edge_targets(v, f, rng)])
    o = np.zeros_like(targets) + np.float32(0.01)
    out = trace_glsl(gpu, o, targets - o)
    assert np.count_nonzero(out["prim"] == NO_HIT) == 0 and out["any"].all()


def test07_empty_and_single_triangle(gl_ctx):
    o = np.zeros((64, 3), np.float32)
    d = np.random.default_rng(0).standard_normal((64, 3)).astype(np.float32)
    empty = trace_glsl(GpuBvh(gl_ctx, build_bvh(np.zeros((0, 3)), np.zeros((0, 3), int))), o, d)
    assert np.all(empty["prim"] == NO_HIT) and not empty["any"].any()
    v = np.array([[-1, -1, 1], [1, -1, 1], [0, 1, 1]], np.float32)
    one = trace_glsl(GpuBvh(gl_ctx, build_bvh(v, [[0, 1, 2]])), o, np.tile([[0, 0, 2]], (64, 1)).astype(np.float32))
    assert np.all(one["prim"] == 0) and np.allclose(one["t"], 0.5)
    np.testing.assert_allclose(one["bary"], [[0.25, 0.5]] * 64, atol=1e-6)


def test08_loop_counts_stay_far_below_the_llvmpipe_cap(gl_ctx):
    """Worst invocation on hard inputs: 10^6 identical triangles, a soup of 10^4 overlapping ones."""
    rng = np.random.default_rng(4)
    cases = {
        "identical": (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32),
                      np.zeros((1_000_000, 3), np.int64) + [0, 1, 2]),
        "overlapping": random_soup(rng, 10_000, spread=0.2, size=1.0),
        "teapot": load_mesh("teapot.ply"),
    }
    for name, (v, f) in cases.items():
        gpu = GpuBvh(gl_ctx, build_bvh(v, f))
        o, d = random_rays(rng, 20_000, v.min(0), v.max(0))
        out = trace_glsl(gpu, o, d, defines={"GLRENDER_COUNT_LOOPS": 1})
        assert out["loops"].max() < 30_000, (name, out["loops"].max())


def test09_stack_overflow_is_reported_not_silent(gl_ctx):
    """A stack too small for the tree (forced by a define) flags the ray instead of looping."""
    v, f = load_mesh("bunny_lowres.ply")
    bvh = build_bvh(v, f)
    assert bvh.depth >= 2
    gpu = GpuBvh(gl_ctx, bvh)
    o, d = random_rays(np.random.default_rng(3), 4000, v.min(0), v.max(0), spread=0.5)
    out = trace_glsl(gpu, o, d, defines={"GLRENDER_BVH_MAX_DEPTH": 0})
    flagged = out["prim"] == 0xFFFFFFFE
    assert flagged.any() and not out["hit"][flagged].any()
    full = trace_glsl(gpu, o, d)
    np.testing.assert_array_equal(out["prim"][~flagged], full["prim"][~flagged])


def test10_texture_units_agree_with_the_layout_file():
    """Every geometry sampler of bvh_layout.glsl at the unit and of the type bvh_upload binds;
    each kind's further parts an array sized by its parts define, at units past every other
    texture unit."""
    text = (packaged_root() / "geometry" / "bvh_layout.glsl").read_text()
    points = bindings.binding_points()
    declared = {m[2]: (points[m[0]], m[1], m[3]) for m in
                re.findall(r"layout\(binding = (\w+)\) uniform (\w+) (\w+)(?:\[GEOMETRY_MORE\((\w+)\)\])?;", text)}
    expected = {INSTANCES[2]: (INSTANCES[0], "samplerBuffer", "")}
    for spec in KINDS.values():
        sampler = "usamplerBuffer" if spec.fmt.endswith("ui") else "samplerBuffer"
        expected[spec.sampler] = (spec.unit, sampler, "")
        expected[spec.sampler + "_more"] = (spec.more, sampler, spec.parts_define)
    assert declared == expected
    assert all(unit in UNITS_RESERVED for unit in (KINDS["nodes"].unit, KINDS["triangles"].unit, INSTANCES[0]))
    more = sorted(spec.more for spec in KINDS.values())
    assert max(set(points.values()) - set(more)) < more[0]
    # No other shader file declares a geometry unit.
    for path in packaged_root().rglob("*.glsl"):
        if path.name != "bvh_layout.glsl":
            assert not re.search(r"uniform u?samplerBuffer u_(bvh|tri)_", path.read_text()), path
    constants = dict(re.findall(r"const \w+ (k\w+) = (0x[0-9A-Fa-f]+|\d+)u?;", text))
    assert int(constants["kBvhLeafFlag"], 0) == bvh_module.LEAF_FLAG
    assert int(constants["kBvhLeafCountShift"], 0) == bvh_module.LEAF_COUNT_SHIFT
    assert int(constants["kBvhLeafFirstMask"], 0) == bvh_module.LEAF_FIRST_MASK
    assert int(constants["kTexelsPerMotionInstance"]) == instances_module.TEXELS_PER_INSTANCE
    assert int(constants["kTexelsPerStaticInstance"]) == instances_module.TEXELS_PER_STATIC_INSTANCE
    params_text = (packaged_root() / "common" / "params.glsl").read_text()
    assert re.search(rf"#define GLRENDER_BVH_MAX_DEPTH {bvh_module.MAX_DEPTH}\n", params_text)


def test11_gpu_bvh_refuses_trees_deeper_than_the_stack(gl_ctx, monkeypatch):
    v, f = load_mesh("teapot.ply")
    bvh = build_bvh(v, f)
    monkeypatch.setattr(type(bvh), "depth", property(lambda self: bvh_module.MAX_DEPTH + 1))
    with pytest.raises(UsageError, match="exceeds the traversal stack bound 31 "):
        GpuBvh(gl_ctx, bvh)


def trace_glsl8(gpu, o, d, t_max, has_ray, coop_lanes, count_loops=False):
    """Closest and any hit through geometry/bvh8.glsl; lanes without a ray ask nothing.
    With ``count_loops``, ``loops``: the SIMD vector's loop iterations over both queries."""
    from glrender.render.params import shader_defines
    from glrender.testing.harness import run_glsl

    body = ["BvhHit h;", "bool hit = bvh8_traverse(has != 0u, 0u, o, d, t_max, false, h);",
            "BvhHit h2;", "bool any = bvh8_traverse(has != 0u, 0u, o, d, t_max, true, h2);",
            "float t = h.t;", "uint prim = h.prim;", "vec2 bary = h.bary;", "uint loops = g_loop_count;"]
    outputs = {"t": "float", "prim": "uint", "bary": "vec2", "hit": "bool", "any": "bool"}
    if count_loops:
        outputs["loops"] = "uint"
    gpu.bind()
    return run_glsl("\n".join(body), {"o": o, "d": d, "t_max": np.asarray(t_max, np.float32),
                                       "has": has_ray.astype(np.uint32)}, outputs,
                    includes=["geometry/bvh8.glsl"],
                    defines={**shader_defines(), **gpu.defines(), "GLRENDER_COOP_LANES": coop_lanes,
                             "GLRENDER_COUNT_LOOPS": int(count_loops)})


@pytest.mark.parametrize("coop_lanes", [0, 3, 8])
def test12_8_wide_traversal_per_lane_and_cooperative(gl_ctx, coop_lanes):
    """geometry/bvh8.glsl against the brute force: per lane (0), cooperative when at most 3
    of a vector's 8 lanes have rays, and always cooperative (8); lanes without a ray get no
    hit and still help. The kernel's last vector is partly empty (a divergent call): the
    cooperative query must notice and trace per lane."""
    rng = np.random.default_rng(41)
    v, f = load_mesh("teapot.ply")
    bvh = build_bvh(v, f, width=8)
    gpu = GpuBvh(gl_ctx, bvh)
    n = 12003  # not a multiple of 8
    o, d = random_rays(rng, n, v.min(0), v.max(0), spread=0.9)
    t_max = np.where(rng.random(n) < 0.5, np.inf, rng.random(n) * 2).astype(np.float32)
    has_ray = rng.random(n) < np.repeat(rng.choice([0.1, 0.4, 1.0], n // 64 + 1), 64)[:n]
    out = trace_glsl8(gpu, o, d, t_max, has_ray, coop_lanes)
    none = ~has_ray
    assert np.all(out["prim"][none] == NO_HIT) and not out["any"][none].any()
    sub = {k: v_[has_ray] for k, v_ in out.items()}
    ref = compare(bvh, o[has_ray], d[has_ray], t_max[has_ray], sub)
    assert 300 < np.count_nonzero(ref["prim"] >= 0) < has_ray.sum() - 300


def test12d_cooperative_loop_counts_stay_far_below_the_cap(gl_ctx):
    """Cooperatively a vector loops over all its rays one after another: the loop counter
    (the vector's iterations, common/loop_counter.glsl) stays far below llvmpipe's cap for
    a full vector of rays, and counts at least what the per-lane traversal takes."""
    import trimesh

    ROOT = Path(__file__).resolve().parents[2]
    mesh = trimesh.load(ROOT / "scenes" / "cornell-bunny" / "bunny.ply", process=False)
    v, f = np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.int64)
    bvh = build_bvh(v, f, width=8)
    gpu = GpuBvh(gl_ctx, bvh)
    rng = np.random.default_rng(5)
    o, d = random_rays(rng, 4096, v.min(0), v.max(0), spread=0.9)
    t_max = np.full(len(o), np.inf, np.float32)
    has_ray = np.ones(len(o), bool)
    coop = trace_glsl8(gpu, o, d, t_max, has_ray, 8, count_loops=True)["loops"]
    lane = trace_glsl8(gpu, o, d, t_max, has_ray, 0, count_loops=True)["loops"]
    per_vector = coop.reshape(-1, 8)
    assert np.all(per_vector == per_vector[:, :1])   # one count per vector
    assert np.all(coop.reshape(-1, 8).max(1) >= lane.reshape(-1, 8).max(1))
    assert coop.max() < 6_000, coop.max()


def test12b_gpu_bvh_takes_the_widths_a_traversal_reads(gl_ctx, monkeypatch):
    v, f = load_mesh("teapot.ply")
    bvh = build_bvh(v, f)
    monkeypatch.setattr(type(bvh), "width", property(lambda self: 2))   # no builder makes one
    with pytest.raises(UsageError, match="read 4 or 8-wide trees, this one is 2-wide"):
        GpuBvh(gl_ctx, bvh)


def test12c_8_wide_constants_match_the_builder():
    from glrender.accel.quantize import texels_per_node

    src = (packaged_root() / "geometry" / "bvh8.glsl").read_text()
    assert re.search(rf"kBvh8TexelsPerNode = {texels_per_node(8)};", src)
    assert re.search(rf"kBvh8MaxDepth = {bvh_module.max_depth(8)};", src)


@pytest.mark.parametrize("width, coop_lanes", [(4, None), (8, 0), (8, 8)],
                         ids=["4-wide", "8-wide-per-lane", "8-wide-cooperative"])
def test13_trees_in_parts_answer_as_from_one_texture(gl_ctx, monkeypatch, width, coop_lanes):
    """A 20,000-triangle soup's tree with the texel limit forced down to 15,000, so that its
    nodes span three textures (4-wide; 8-wide: two) and its corners four (geometry/bvh_layout.glsl): the same
    answers, bit for bit, as from one texture of each, through the 4-wide traversal and the
    8-wide one per lane and cooperatively."""
    rng = np.random.default_rng(29)
    v, f = random_soup(rng, 20000, size=0.05)
    bvh = build_bvh(v, f, width=width)
    o, d = random_rays(rng, 8192, v.min(0), v.max(0))
    t_max = np.where(rng.random(len(o)) < 0.5, np.inf, rng.random(len(o))).astype(np.float32)

    def trace(gpu):
        if width == 4:
            return trace_glsl(gpu, o, d, t_max)
        return trace_glsl8(gpu, o, d, t_max, np.ones(len(o), bool), coop_lanes)

    whole = GpuBvh(gl_ctx, bvh)
    assert whole.parts == {"nodes": 1, "triangles": 1} and whole.defines() == {}
    expected = trace(whole)
    monkeypatch.setattr(bvh_upload, "TEXEL_LIMIT", 15_000)
    split = GpuBvh(gl_ctx, bvh)
    assert split.parts == {"nodes": 3 if width == 4 else 2, "triangles": 4}
    got = trace(split)
    whole.release()
    split.release()
    assert expected["hit"].mean() > 0.2
    for key, value in expected.items():
        np.testing.assert_array_equal(got[key], value, err_msg=key)
