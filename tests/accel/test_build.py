"""BVH builders (PLOC, binned SAH), the 4-wide collapse, node compression and the depth bound."""
import numpy as np
import pytest
from bvh_reference import icosphere, load_mesh, random_soup

from glrender.accel import build_bvh
from glrender.accel.bvh import LEAF_COUNT_SHIFT, LEAF_FLAG, MAX_DEPTH
from glrender.accel.collapse import KIND_EMPTY, KIND_INNER, KIND_LEAF, MAX_LEAF_SIZE
from glrender.accel.quantize import TEXELS_PER_NODE, decode_planes, exact_sign, pack_nodes

METHODS = ["ploc", "binned_sah"]


def triangle_boxes(corners):
    return corners.min(axis=1), corners.max(axis=1)


def check_structure(bvh, vertices, triangles):
    """Every invariant the GLSL traversal relies on."""
    a = bvh.arrays
    n = bvh.triangle_count
    # prim_order: a permutation of the kept input triangles; corners follow it.
    assert sorted(bvh.prim_order.tolist()) == sorted(bvh.prepared.source.tolist())
    np.testing.assert_array_equal(bvh.corners, np.asarray(vertices, np.float32)[triangles[bvh.prim_order]])
    # Leaves: at most MAX_LEAF_SIZE triangles, together covering each triangle exactly once.
    leaf = a.child_kind == KIND_LEAF
    assert np.all((a.child_count[leaf] >= 1) & (a.child_count[leaf] <= MAX_LEAF_SIZE))
    cover = np.zeros(n, np.int64)
    for first, count in zip(a.child_index[leaf], a.child_count[leaf]):
        cover[first:first + count] += 1
    assert np.all(cover == 1)
    # Inner references: breadth-first, every node but the root referenced exactly once.
    inner = a.child_kind == KIND_INNER
    targets = np.sort(a.child_index[inner])
    np.testing.assert_array_equal(targets, np.arange(1, bvh.node_count))
    parent_depth = np.repeat(a.depth, 4).reshape(-1, 4)[inner]
    np.testing.assert_array_equal(a.depth[a.child_index[inner]], parent_depth + 1)
    assert bvh.depth <= MAX_DEPTH
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
    # The packed references decode to the same leaves.
    refs = bvh.child_refs()
    assert np.all((refs[leaf] & LEAF_FLAG) != 0) and np.all((refs[inner] & LEAF_FLAG) == 0)
    np.testing.assert_array_equal((refs[leaf] >> LEAF_COUNT_SHIFT) & 7, a.child_count[leaf])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", ["soup", "teapot.ply", "bunny_lowres.ply"])
def test01_structure(method, mesh):
    if mesh == "soup":
        v, f = random_soup(np.random.default_rng(1), 700)
    else:
        v, f = load_mesh(mesh)
    bvh = build_bvh(v, f, method=method)
    check_structure(bvh, v, f)
    s = bvh.stats()
    assert s["triangles"] == bvh.triangle_count and s["nodes"] == bvh.node_count
    assert s["bytes"] == bvh.nbytes == bvh.node_count * 64 + bvh.triangle_count * 48 + 16  # + header


def test02_ploc_quality_near_binned_sah():
    """PLOC's tree costs at most 15% more than a full binned-SAH sweep (measured: 5-10%)."""
    for name in ["teapot.ply", "bunny_lowres.ply"]:
        v, f = load_mesh(name)
        ploc, sah = build_bvh(v, f, method="ploc").sah_cost(), build_bvh(v, f, method="binned_sah").sah_cost()
        assert ploc <= 1.15 * sah, (name, ploc, sah)


@pytest.mark.parametrize("count", [0, 1, 2, 5])
def test03_tiny_trees(count):
    v, f = random_soup(np.random.default_rng(2), count)
    bvh = build_bvh(v, f)
    assert bvh.node_count == 1 if count <= 4 else bvh.node_count <= 2
    check_structure(bvh, v, f)
    assert bvh.pack()["nodes"].shape == (TEXELS_PER_NODE * bvh.node_count, 4)
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


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", ["line", "shells"])
def test04_depth_bound_on_adversarial_input(method, mesh):
    v, f = geometric_line(3000, 0.995) if mesh == "line" else nested_shells(3000)
    bvh = build_bvh(v, f, method=method)
    assert bvh.depth <= MAX_DEPTH
    check_structure(bvh, v, f)


def test05_depth_bound_engages():
    """Without the bound these trees would be deeper than the stack allows."""
    from glrender.accel.collapse import collapse_to_bvh4
    from glrender.accel.ploc import build_ploc

    v, f = geometric_line(3000, 0.995)
    c = v[f]
    tree = build_ploc(c.min(axis=1), c.max(axis=1), top_clusters=1)  # PLOC to the root
    count = tree.counts()
    leaf = tree.leaf_mask(count, 4, 1.0, 1.0)
    unbounded = collapse_to_bvh4(tree, leaf, count, tree.first_prim(count), max_depth=1000)
    bounded = collapse_to_bvh4(tree, leaf, count, tree.first_prim(count), max_depth=MAX_DEPTH)
    assert unbounded.depth.max() > MAX_DEPTH >= bounded.depth.max()


def test06_closed_mesh_and_large_coordinates():
    v, f = icosphere(3)
    v = (v * 1e-3 + np.array([1e4, -3e3, 7.0])).astype(np.float32)
    bvh = build_bvh(v, f)
    check_structure(bvh, v, f)


@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-6, 0.0), (1e-3, 1e5), (1e30, 0.0),
                                           (1.0, -3e7), (0.0, 5.0)])
def test07_quantized_boxes_contain_the_float_boxes(scale, offset):
    rng = np.random.default_rng(7)
    n = 2000
    lo = (rng.standard_normal((n, 4, 3)) * scale + offset).astype(np.float32)
    hi = (lo + rng.random((n, 4, 3)).astype(np.float32) * np.float32(scale)).astype(np.float32)
    hi[::7, 1] = lo[::7, 1]  # flat children
    valid = rng.random((n, 4)) < 0.85
    valid[::5] = [True, False, False, False]
    valid[3] = False  # an empty node
    refs = rng.integers(0, 2**32, (n, 4), dtype=np.uint32)
    packed = pack_nodes(lo, hi, valid, refs)
    dlo, dhi = decode_planes(packed)
    assert np.all(dlo[valid] <= lo[valid]) and np.all(dhi[valid] >= hi[valid])
    # ... and so do the exact reals p + q s the traversal's fused slab test works from
    rec = packed.reshape(n, TEXELS_PER_NODE, 4)
    p = np.broadcast_to(rec[:, None, 0, :3].view(np.float32), lo.shape)
    e = np.stack([(rec[:, 0, 3] >> (8 * a)) & 255 for a in range(3)], axis=1).astype(np.int64) - 127
    s = np.broadcast_to(np.ldexp(np.float32(1), e).astype(np.float32)[:, None, :], lo.shape)
    words = np.stack([rec[:, 2, 0], rec[:, 2, 2], rec[:, 3, 0], rec[:, 2, 1], rec[:, 2, 3], rec[:, 3, 1]], 1)
    q = np.stack([(words >> (8 * k)) & 255 for k in range(4)], axis=1).astype(np.float32)
    assert np.all(exact_sign(p, q[..., :3] * s, lo)[valid] <= 0)
    assert np.all(exact_sign(p, q[..., 3:] * s, hi)[valid] >= 0)
    assert np.all(np.any(dlo[~valid] > dhi[~valid], axis=-1))  # empty slots stay empty
    np.testing.assert_array_equal(packed.reshape(n, 4, 4)[:, 1], refs)
    # Not needlessly loose: each plane within 2 grid steps of the float plane.
    node_lo = np.where(valid[..., None], lo, np.inf).min(axis=1)
    node_hi = np.where(valid[..., None], hi, -np.inf).max(axis=1)
    extent = np.where(np.isfinite(node_lo), node_hi - node_lo, 0)[:, None, :]
    step = np.maximum(extent / 255 * 2, np.abs(lo) * 2.0**-20)
    assert np.all((lo - dlo)[valid] <= step[valid]) and np.all((dhi - hi)[valid] <= step[valid])


def test08_bvh_packed_nodes_hold_the_child_boxes():
    v, f = load_mesh("bunny_lowres.ply")
    bvh = build_bvh(v, f)
    dlo, dhi = decode_planes(bvh.pack()["nodes"])
    k = bvh.arrays.child_kind != KIND_EMPTY
    assert np.all(dlo[k] <= bvh.arrays.child_lo[k]) and np.all(dhi[k] >= bvh.arrays.child_hi[k])


def test09_options():
    v, f = load_mesh("teapot.ply")
    small = build_bvh(v, f, max_leaf_size=1)
    assert np.all(small.arrays.child_count[small.arrays.child_kind == KIND_LEAF] == 1)
    with pytest.raises(ValueError, match="method must be one of"):
        build_bvh(v, f, method="sweep")
    with pytest.raises(ValueError, match="max_leaf_size must be 1..4"):
        build_bvh(v, f, max_leaf_size=5)


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
