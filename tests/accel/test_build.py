"""BVH builders (PLOC, binned SAH), the 4- and 8-wide collapse, node compression and the depth bound."""
import hashlib

import numpy as np
import pytest
from bvh_reference import brute_force, icosphere, load_mesh, random_soup, ray_triangle_t

from glrender.accel import Bvh, MotionInstance, build_bvh
from glrender.accel.bvh import (LEAF_COUNT_SHIFT, LEAF_FIRST_MASK, LEAF_FLAG, MAX_DEPTH,
                                MAX_LEAF_SIZE_BY_WIDTH, max_depth, stack_size)
from glrender.accel.collapse import KIND_EMPTY, KIND_INNER, KIND_LEAF, MAX_LEAF_SIZE, range_levels
from glrender.accel.quantize import decode_planes, exact_sign, pack_nodes, texels_per_node

METHODS = ["ploc", "binned_sah"]
WIDTHS = [4, 8]


def triangle_boxes(corners):
    return corners.min(axis=1), corners.max(axis=1)


def check_structure(bvh, vertices, triangles, max_leaf=MAX_LEAF_SIZE):
    """Every invariant the GLSL traversal relies on."""
    a = bvh.arrays
    n = bvh.triangle_count
    w = bvh.width
    assert a.child_kind.shape == (bvh.node_count, w) and a.child_lo.shape == (bvh.node_count, w, 3)
    # prim_order: a permutation of the kept input triangles; corners follow it.
    assert sorted(bvh.prim_order.tolist()) == sorted(bvh.prepared.source.tolist())
    np.testing.assert_array_equal(bvh.corners, np.asarray(vertices, np.float32)[triangles[bvh.prim_order]])
    # Leaves: at most max_leaf triangles, together covering each triangle exactly once.
    leaf = a.child_kind == KIND_LEAF
    assert np.all((a.child_count[leaf] >= 1) & (a.child_count[leaf] <= max_leaf))
    assert np.all(a.child_count[a.child_kind == KIND_EMPTY] == 0)
    cover = np.zeros(n, np.int64)
    for first, count in zip(a.child_index[leaf], a.child_count[leaf]):
        cover[first:first + count] += 1
    assert np.all(cover == 1)
    # Inner references: breadth-first, every node but the root referenced exactly once.
    inner = a.child_kind == KIND_INNER
    targets = np.sort(a.child_index[inner])
    np.testing.assert_array_equal(targets, np.arange(1, bvh.node_count))
    parent_depth = np.repeat(a.depth, w).reshape(-1, w)[inner]
    np.testing.assert_array_equal(a.depth[a.child_index[inner]], parent_depth + 1)
    assert bvh.depth <= max_depth(w)
    # Boxes: a leaf box holds its triangles, an inner child's box holds its node's children.
    lo, hi = triangle_boxes(bvh.corners)
    for (node, slot) in zip(*np.nonzero(leaf)):
        f, c = a.child_index[node, slot], a.child_count[node, slot]
        assert np.all(a.child_lo[node, slot] <= lo[f:f + c].min(axis=0))
        assert np.all(a.child_hi[node, slot] >= hi[f:f + c].max(axis=0))
    for (node, slot) in zip(*np.nonzero(inner)):
        child = a.child_index[node, slot]
        valid = a.child_kind[child] != KIND_EMPTY
        assert np.all(a.child_lo[node, slot] <= a.child_lo[child][valid].min(axis=0))
        assert np.all(a.child_hi[node, slot] >= a.child_hi[child][valid].max(axis=0))
    # The inner children's subtrees hold exactly the triangles their slots count.
    subtree = np.zeros(bvh.node_count, np.int64)
    subtree[a.child_index[inner]] = a.child_count[inner]
    np.testing.assert_array_equal(a.child_count.sum(axis=1)[1:], subtree[1:])
    assert a.child_count[0].sum() == n
    # The packed references decode to the same leaves.
    refs = bvh.child_refs()
    assert np.all((refs[leaf] & LEAF_FLAG) != 0) and np.all((refs[inner] & LEAF_FLAG) == 0)
    np.testing.assert_array_equal((refs[leaf] >> LEAF_COUNT_SHIFT) & 7, a.child_count[leaf])
    np.testing.assert_array_equal(refs[leaf] & LEAF_FIRST_MASK, a.child_index[leaf])
    np.testing.assert_array_equal(refs[inner], a.child_index[inner])


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", ["soup", "teapot.ply", "bunny_lowres.ply"])
def test01_structure(method, mesh, width):
    if mesh == "soup":
        v, f = random_soup(np.random.default_rng(1), 700)
    else:
        v, f = load_mesh(mesh)
    bvh = build_bvh(v, f, method=method, width=width)
    assert bvh.width == width
    check_structure(bvh, v, f)
    s = bvh.stats()
    assert s["triangles"] == bvh.triangle_count and s["nodes"] == bvh.node_count and s["width"] == width
    node_bytes = 16 * texels_per_node(width)
    assert s["bytes"] == bvh.nbytes == bvh.node_count * node_bytes + bvh.triangle_count * 48 + 16  # + header


def test01b_width_constants():
    assert [texels_per_node(w) for w in WIDTHS] == [4, 6]
    assert [max_depth(w) for w in WIDTHS] == [31, 21] and MAX_DEPTH == max_depth(4)
    assert [stack_size(w) for w in WIDTHS] == [96, 154]
    assert [range_levels(w) for w in WIDTHS] == [13, 9]
    for w in WIDTHS:  # the smallest R with width^(R + 1) >= 2^28, and within the depth bound
        r = range_levels(w)
        assert w ** (r + 1) >= 2 ** 28 > w ** r and r <= max_depth(w)
    with pytest.raises(ValueError, match="node width"):
        texels_per_node(6)


def test02_ploc_quality_near_binned_sah():
    """PLOC's tree costs at most 15% more than a full binned-SAH sweep (measured: 5-10%)."""
    for name in ["teapot.ply", "bunny_lowres.ply"]:
        v, f = load_mesh(name)
        ploc, sah = build_bvh(v, f, method="ploc").sah_cost(), build_bvh(v, f, method="binned_sah").sah_cost()
        assert ploc <= 1.15 * sah, (name, ploc, sah)


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("count", [0, 1, 2, 5])
def test03_tiny_trees(count, width):
    v, f = random_soup(np.random.default_rng(2), count)
    bvh = build_bvh(v, f, width=width)
    assert bvh.node_count == 1 if count <= 4 else bvh.node_count <= 2
    check_structure(bvh, v, f)
    assert bvh.pack()["nodes"].shape == (texels_per_node(width) * bvh.node_count, 4)
    if count == 0:
        assert np.all(bvh.arrays.child_kind == KIND_EMPTY) and bvh.sah_cost() == 0.0


def geometric_line(n, ratio):
    """Triangles shrinking geometrically along x: PLOC and SAH trees of depth ~n."""
    x = 1.0 - ratio ** np.arange(n)
    size = 0.5 * ratio ** np.arange(n)
    c = np.stack([x, 0 * x, 0 * x], 1)
    v = np.stack([c, c + size[:, None] * [1, 0, 0], c + size[:, None] * [0, 1, 0]], 1)
    return v.reshape(-1, 3).astype(np.float32), np.arange(3 * n).reshape(-1, 3)


def nested_shells(n):
    """n concentric triangles of growing size around one point."""
    s = 1.003 ** np.arange(n)
    v = np.stack([0 * s, 0 * s, 0 * s], 1)[:, None] + s[:, None, None] * np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]])
    return v.reshape(-1, 3).astype(np.float32), np.arange(3 * n).reshape(-1, 3)


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", ["line", "shells"])
def test04_depth_bound_on_adversarial_input(method, mesh, width):
    v, f = geometric_line(3000, 0.995) if mesh == "line" else nested_shells(3000)
    bvh = build_bvh(v, f, method=method, width=width)
    assert bvh.depth <= max_depth(width)
    check_structure(bvh, v, f)


@pytest.mark.parametrize("width", WIDTHS)
def test05_depth_bound_engages(width):
    """Without the bound these trees would be deeper than the stack allows; bounded, and
    at the smallest bound (balanced ranges from depth 1 on), they keep every invariant."""
    from glrender.accel.collapse import collapse_to_bvh
    from glrender.accel.ploc import build_ploc

    v, f = geometric_line(3000, 0.995)
    c = v[f]
    tree = build_ploc(c.min(axis=1), c.max(axis=1), top_clusters=1)  # PLOC to the root
    count = tree.counts()
    leaf = tree.leaf_mask(count, 4, 1.0, 1.0)
    first = tree.first_prim(count)
    unbounded = collapse_to_bvh(tree, leaf, count, first, max_depth=1000, width=width)
    bounded = collapse_to_bvh(tree, leaf, count, first, max_depth=max_depth(width), width=width)
    assert unbounded.depth.max() > max_depth(width) >= bounded.depth.max()
    bvh = build_bvh(v, f, top_clusters=1, width=width)
    assert bvh.depth <= max_depth(width)
    check_structure(bvh, v, f)
    # The tightest bound the collapse accepts: everything below depth 1 is balanced ranges
    # (8-wide, ranges of 5..7 triangles leave empty parts).
    tight = range_levels(width) + 1
    arrays = collapse_to_bvh(tree, leaf, count, first, max_depth=tight, width=width)
    assert arrays.depth.max() <= tight
    check_structure(Bvh(c[arrays.prim_order], arrays.prim_order, arrays, bvh.prepared), v, f)
    with pytest.raises(ValueError, match="max_depth must be at least"):
        collapse_to_bvh(tree, leaf, count, first, max_depth=range_levels(width) - 1, width=width)


def test06_closed_mesh_and_large_coordinates():
    v, f = icosphere(3)
    v = (v * 1e-3 + np.array([1e4, -3e3, 7.0])).astype(np.float32)
    bvh = build_bvh(v, f)
    check_structure(bvh, v, f)


def layout_planes(packed, width):
    """Origin, scale, integer planes (N, width, 3) and references (N, width) read from packed
    nodes by the documented texel layout (independently of decode_planes)."""
    t = texels_per_node(width)
    rec = packed.reshape(-1, t, 4)
    n = len(rec)
    p = rec[:, 0, :3].view(np.float32)
    e = np.stack([(rec[:, 0, 3] >> (8 * a)) & 255 for a in range(3)], axis=1).astype(np.int64) - 127
    s = np.ldexp(np.float32(1), e).astype(np.float32)
    qlo = np.zeros((n, width, 3), np.int64)
    qhi = np.zeros((n, width, 3), np.int64)
    for k in range(width):
        shift = 8 * (k % 4)
        if width == 4:  # texel 2: lo.x, hi.x, lo.y, hi.y; texel 3: lo.z, hi.z
            lo_words = [rec[:, 2, 0], rec[:, 2, 2], rec[:, 3, 0]]
            hi_words = [rec[:, 2, 1], rec[:, 2, 3], rec[:, 3, 1]]
        else:  # texel 3 + axis: lo of children 0-3, lo of 4-7, hi of 0-3, hi of 4-7
            lo_words = [rec[:, 3 + a, k // 4] for a in range(3)]
            hi_words = [rec[:, 3 + a, 2 + k // 4] for a in range(3)]
        for a in range(3):
            qlo[:, k, a] = (lo_words[a] >> shift) & 255
            qhi[:, k, a] = (hi_words[a] >> shift) & 255
    refs = rec[:, 1:1 + width // 4].reshape(n, width)
    if width == 4:
        assert np.all(rec[:, 3, 2:] == 0)
    return p, s, qlo, qhi, refs


@pytest.mark.parametrize("density", [0.85, 0.4])  # the valid slots: in place, or gathered
@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-6, 0.0), (1e-3, 1e5), (1e30, 0.0),
                                           (1.0, -3e7), (0.0, 5.0)])
def test07_quantized_boxes_contain_the_float_boxes(scale, offset, width, density):
    rng = np.random.default_rng(7)
    n = 2000
    lo = (rng.standard_normal((n, width, 3)) * scale + offset).astype(np.float32)
    hi = (lo + rng.random((n, width, 3)).astype(np.float32) * np.float32(scale)).astype(np.float32)
    hi[::7, 1] = lo[::7, 1]  # flat children
    valid = rng.random((n, width)) < density
    valid[::5] = [True] + [False] * (width - 1)
    valid[::11, -1] = False
    valid[3] = False  # an empty node
    refs = rng.integers(0, 2**32, (n, width), dtype=np.uint32)
    packed = pack_nodes(lo, hi, valid, refs)
    assert packed.shape == (n * texels_per_node(width), 4) and packed.dtype == np.uint32
    dlo, dhi = decode_planes(packed, width)
    assert np.all(dlo[valid] <= lo[valid]) and np.all(dhi[valid] >= hi[valid])
    # ... and so do the exact reals p + q s the traversal's fused slab test works from
    p, s, qlo, qhi, packed_refs = layout_planes(packed, width)
    p, s = np.broadcast_to(p[:, None], lo.shape), np.broadcast_to(s[:, None], lo.shape)
    assert np.all(exact_sign(p, qlo.astype(np.float32) * s, lo)[valid] <= 0)
    assert np.all(exact_sign(p, qhi.astype(np.float32) * s, hi)[valid] >= 0)
    # decode_planes reads the documented layout; empty slots are q_lo = 255 > q_hi = 0
    np.testing.assert_array_equal(dlo, p + qlo.astype(np.float32) * s)
    np.testing.assert_array_equal(dhi, p + qhi.astype(np.float32) * s)
    assert np.all(qlo[~valid] == 255) and np.all(qhi[~valid] == 0)
    assert np.all(np.any(dlo[~valid] > dhi[~valid], axis=-1))  # empty slots stay empty
    np.testing.assert_array_equal(packed_refs, refs)
    # Not needlessly loose: each plane within 2 grid steps of the float plane.
    node_lo = np.where(valid[..., None], lo, np.inf).min(axis=1)
    node_hi = np.where(valid[..., None], hi, -np.inf).max(axis=1)
    extent = np.where(np.isfinite(node_lo), node_hi - node_lo, 0)[:, None, :]
    step = np.maximum(extent / 255 * 2, np.abs(lo) * 2.0**-20)
    assert np.all((lo - dlo)[valid] <= step[valid]) and np.all((dhi - hi)[valid] <= step[valid])


def test07b_width_8_packs_the_4_wide_planes_of_its_halves():
    """An 8-wide node whose children 4-7 are empty quantises children 0-3 as the 4-wide
    node of the same boxes does (same origin, exponents and planes; the one computed on
    the slots in place, the other on the valid slots gathered)."""
    rng = np.random.default_rng(8)
    n = 500
    lo = rng.standard_normal((n, 4, 3)).astype(np.float32)
    hi = (lo + rng.random((n, 4, 3)).astype(np.float32)).astype(np.float32)
    valid = rng.random((n, 4)) < 0.9
    refs = rng.integers(0, 2**32, (n, 4), dtype=np.uint32)
    four = layout_planes(pack_nodes(lo, hi, valid, refs), 4)
    pad = np.zeros((n, 4, 3), np.float32)
    eight = layout_planes(pack_nodes(np.concatenate([lo, pad], 1), np.concatenate([hi, pad], 1),
                                     np.concatenate([valid, np.zeros((n, 4), bool)], 1),
                                     np.concatenate([refs, refs], 1)), 8)
    for a, b in zip(four[:2], eight[:2]):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(four[2:], eight[2:]):
        np.testing.assert_array_equal(a, b[:, :4])
    assert np.all(eight[2][:, 4:] == 255) and np.all(eight[3][:, 4:] == 0)


@pytest.mark.parametrize("width", WIDTHS)
def test08_bvh_packed_nodes_hold_the_child_boxes(width):
    v, f = load_mesh("bunny_lowres.ply")
    bvh = build_bvh(v, f, width=width)
    dlo, dhi = decode_planes(bvh.pack()["nodes"], width)
    k = bvh.arrays.child_kind != KIND_EMPTY
    assert np.all(dlo[k] <= bvh.arrays.child_lo[k]) and np.all(dhi[k] >= bvh.arrays.child_hi[k])
    assert np.all(np.any(dlo[~k] > dhi[~k], axis=-1))


def test09_options():
    from glrender.errors import UsageError

    v, f = load_mesh("teapot.ply")
    small = build_bvh(v, f, max_leaf_size=1)
    assert np.all(small.arrays.child_count[small.arrays.child_kind == KIND_LEAF] == 1)
    with pytest.raises(ValueError, match="method must be one of"):
        build_bvh(v, f, method="sweep")
    with pytest.raises(UsageError, match=r"max_leaf_size must be 1\.\.4 for width 4, got 5$"):
        build_bvh(v, f, max_leaf_size=5)
    with pytest.raises(UsageError, match=r"max_leaf_size must be 1\.\.7 for width 8, got 8$"):
        build_bvh(v, f, max_leaf_size=8, width=8)
    for width in (2, 6, 16, True, "8"):
        with pytest.raises(UsageError, match=r"^build_bvh: width must be one of \(4, 8\), got"):
            build_bvh(v, f, width=width)
    # 8-wide leaves of up to 7 triangles (cheap triangle tests make the SAH choose big leaves)
    big = build_bvh(v, f, width=8, max_leaf_size=7, c_tri=0.05)
    counts = big.arrays.child_count[big.arrays.child_kind == KIND_LEAF]
    assert counts.max() == 7 and MAX_LEAF_SIZE_BY_WIDTH == {4: 4, 8: 7}
    check_structure(big, v, f, max_leaf=7)


def test10_morton_order_is_the_stable_argsort_of_the_codes():
    """morton_order sorts unstably and then puts equal codes in index order: the same as a
    stable argsort, on inputs with many ties (points on a coarse grid) and without."""
    from glrender.accel.morton import morton_codes, morton_order

    rng = np.random.default_rng(4)
    for n, levels in [(1, 1), (2, 1), (500, 2), (3000, 7), (3000, 10**6)]:
        points = rng.integers(0, levels, (n, 3)).astype(np.float32)
        np.testing.assert_array_equal(morton_order(points),
                                      np.argsort(morton_codes(points), kind="stable"))


def test11_a_soup_and_the_same_mesh_indexed_build_the_same_tree():
    """A soup (indices 0..3T-1, the renderer's layout) and the same triangles indexed give
    the same tree, duplicates and degenerate triangles removed alike."""
    v, f = icosphere(3)
    f = np.concatenate([f, f[:40][:, [1, 2, 0]], f[:5], [[0, 0, 1]]])
    soup = v[f].reshape(-1, 3)
    a = build_bvh(v, f)
    b = build_bvh(soup, np.arange(len(soup)).reshape(-1, 3))
    assert a.stats()["removed_duplicates"] == b.stats()["removed_duplicates"] == 45
    for key in ("nodes", "triangles", "instances"):
        np.testing.assert_array_equal(a.pack()[key], b.pack()[key])
    np.testing.assert_array_equal(a.prim_order, b.prim_order)


def sha256(array):
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()


def test12_4_wide_packing_is_unchanged():
    """The 4-wide nodes the GLSL traversal reads, bit for bit as before 8-wide trees existed
    (a binned-SAH top, balanced ranges under the depth bound, and a motion instance's tree)."""
    v, f = load_mesh("bunny_lowres.ply")
    assert sha256(build_bvh(v, f).pack()["nodes"]) == \
        "803d30d83f0334f7e57eadcf7e259ec8c837fec3ba08fd81894b813ff3e30bd1"
    v, f = geometric_line(3000, 0.995)
    assert sha256(build_bvh(v, f, top_clusters=1).pack()["nodes"]) == \
        "5870a1d806f3c4a414948a1fcaf83e7b93822b9710c06e859831c9315776f078"
    v, f = load_mesh("teapot.ply")
    iv, i_f = icosphere(2)
    slide = np.eye(4)
    slide[0, 3] = 0.5
    bvh = build_bvh(v, f, motion=[MotionInstance(iv, i_f, np.eye(4), slide)])
    assert sha256(bvh.pack()["nodes"]) == "71275fe0c7908ae76c4c5a18c36cedcb24249a49ec02b9242281f2cf6ea7f219"
    assert bvh.nbytes == 164688


def reference_closest_hit(nodes, corners, width, root, o, d):
    """Closest hits of rays o + t d, t > 0, through packed nodes alone (numpy, float64).

    Decodes the planes and references of the packed nodes and follows them from ``root``,
    all rays together, a level at a time: every (ray, node) pair tests its node's child
    boxes (padded by a hair, so the float64 slab test cannot lose a grazing hit), inner
    children it enters become the next level's pairs and leaves it enters give (ray,
    triangle) pairs. Returns (t, prim) like :func:`brute_force` (prim -1: miss; the
    smallest prim among equal t), prim indexing ``corners`` (the packed triangle order).
    """
    lo, hi = decode_planes(nodes, width)
    refs = nodes.reshape(-1, texels_per_node(width), 4)[:, 1:1 + width // 4].reshape(-1, width)
    finite = np.isfinite(corners).all(axis=(1, 2))
    pad = 1e-6 * float(np.abs(corners[finite]).max()) if finite.any() else 0.0
    lo, hi = lo.astype(np.float64) - pad, hi.astype(np.float64) + pad
    o, d = np.asarray(o, np.float64), np.asarray(d, np.float64)
    with np.errstate(divide="ignore"):
        inv = 1.0 / d
    ray = np.arange(len(o))
    node = np.full(len(o), root, np.int64)
    pair_ray, pair_tri = [], []
    visited = 0
    while len(ray):
        visited += len(ray)
        assert visited < 1_000_000
        positive = (d[ray] >= 0)[:, None, :]
        near = np.where(positive, lo[node], hi[node])
        far = np.where(positive, hi[node], lo[node])
        oo, ii = o[ray][:, None, :], inv[ray][:, None, :]
        with np.errstate(invalid="ignore"):
            t_near, t_far = (near - oo) * ii, (far - oo) * ii  # nan (0 * inf): on the plane
        t_near = np.where(np.isnan(t_near), -np.inf, t_near).max(axis=-1)
        t_far = np.where(np.isnan(t_far), np.inf, t_far).min(axis=-1)
        enter = (t_near <= t_far) & (t_far >= 0)
        r = refs[node]
        leaf = enter & ((r & LEAF_FLAG) != 0)
        inner = enter & ((r & LEAF_FLAG) == 0)
        rows, slots = np.nonzero(leaf)
        lr = r[rows, slots]
        count = ((lr >> LEAF_COUNT_SHIFT) & 7).astype(np.int64)
        first = (lr & LEAF_FIRST_MASK).astype(np.int64)
        owner = np.repeat(ray[rows], count)
        offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        pair_ray.append(owner)
        pair_tri.append(np.repeat(first, count) + offset)
        rows, slots = np.nonzero(inner)
        ray, node = ray[rows], r[rows, slots].astype(np.int64)
    pr, pt = np.concatenate(pair_ray), np.concatenate(pair_tri)
    t = ray_triangle_t(o[pr], d[pr], corners[pt])
    hit = np.isfinite(t)
    pr, pt, t = pr[hit], pt[hit], t[hit]
    order = np.lexsort((pt, t, pr))
    pr, pt, t = pr[order], pt[order], t[order]
    best = np.ones(len(pr), bool)
    best[1:] = pr[1:] != pr[:-1]
    t_out = np.full(len(o), np.inf)
    prim_out = np.full(len(o), -1, np.int64)
    t_out[pr[best]], prim_out[pr[best]] = t[best], pt[best]
    return t_out, prim_out


def random_rays(rng, n, lo, hi, spread=1.5):
    centre, size = (lo + hi) / 2, (hi - lo).max()
    o = centre + (rng.random((n, 3)) - 0.5) * size * spread
    d = rng.standard_normal((n, 3))
    d[::17, 0] = 0  # some rays parallel to a slab
    return o.astype(np.float32), d.astype(np.float32)


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("mesh", ["bunny_lowres.ply", "soup", "line"])
def test13_reference_traversal_of_the_packed_tree_finds_the_closest_hit(mesh, width):
    """Walking the packed nodes (planes and references only) finds the brute-force closest
    hit of every ray; the 'line' tree (top_clusters=1) has balanced ranges under its bound."""
    rng = np.random.default_rng(13)
    if mesh == "soup":
        v, f = random_soup(rng, 1500)
        bvh = build_bvh(v, f, width=width)
    elif mesh == "line":
        v, f = geometric_line(3000, 0.995)
        bvh = build_bvh(v, f, width=width, top_clusters=1)
    else:
        v, f = load_mesh(mesh)
        bvh = build_bvh(v, f, width=width)
    packed = bvh.pack()
    corners = packed["triangles"].reshape(-1, 3, 4)[..., :3]
    np.testing.assert_array_equal(corners, bvh.corners)
    o, d = random_rays(rng, 600, v.min(0), v.max(0))
    # half of the rays aimed at random points of random triangles (the 'line' is a thin strip)
    c = bvh.corners[rng.integers(0, bvh.triangle_count, len(o) // 2)]
    u, w = rng.random((2, len(c), 1)) * 0.5
    d[::2] = c[:, 0] + u * (c[:, 1] - c[:, 0]) + w * (c[:, 2] - c[:, 0]) - o[::2]
    t, prim = reference_closest_hit(packed["nodes"], corners, width, 0, o, d)
    ref = brute_force(o, d, corners)
    assert np.count_nonzero(ref["prim"] >= 0) > len(o) // 3
    np.testing.assert_array_equal(t, ref["t"])
    np.testing.assert_array_equal(prim, ref["prim"])


def test14_8_wide_motion_instance_trees():
    """Motion instances' trees get the static tree's width and follow it in the buffers;
    each walks from its own root to its own (object-space) triangles."""
    v, f = load_mesh("teapot.ply")
    iv, i_f = icosphere(2)
    slide = np.eye(4)
    slide[0, 3] = 0.5
    bvh = build_bvh(v, f, width=8, motion=[MotionInstance(iv, i_f, np.eye(4), slide)])
    m = bvh.motion[0].bvh
    assert m.width == 8 and bvh.depth == max(bvh.arrays.depth.max(), m.arrays.depth.max())
    check_structure(m, iv.astype(np.float32), i_f)
    packed = bvh.pack()
    assert len(packed["nodes"]) == 6 * (bvh.node_count + m.node_count)
    assert bvh.stats()["bytes"] == bvh.nbytes == sum(a.nbytes for a in packed.values())
    corners = packed["triangles"].reshape(-1, 3, 4)[..., :3]
    begin, end = bvh.motion_prim_ranges()[0]
    rng = np.random.default_rng(14)
    o, d = random_rays(rng, 1000, iv.min(0), iv.max(0))
    t, prim = reference_closest_hit(packed["nodes"], corners, 8, bvh.node_count, o, d)
    ref = brute_force(o, d, m.corners)
    assert np.count_nonzero(ref["prim"] >= 0) > len(o) // 5
    np.testing.assert_array_equal(t, ref["t"])
    np.testing.assert_array_equal(prim, np.where(ref["prim"] >= 0, ref["prim"] + begin, -1))
