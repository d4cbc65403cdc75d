"""Input clean-up before the BVH build: invalid, degenerate and duplicate triangles."""
import numpy as np
import pytest

from glrender.accel import build_bvh
from glrender.accel.mesh import prepare_triangles
from glrender.errors import SceneError, UsageError

QUAD = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32),
        np.array([[0, 1, 2], [0, 2, 3]]))


def test01_clean_mesh_is_kept_whole():
    p = prepare_triangles(*QUAD)
    assert p.count == 2 and p.input_count == 2
    assert (p.skipped_invalid, p.skipped_degenerate, p.removed_duplicates) == (0, 0, 0)
    np.testing.assert_array_equal(p.source, [0, 1])
    np.testing.assert_array_equal(p.corners[1], QUAD[0][[0, 2, 3]])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e39])
def test02_non_finite_vertices_skipped_with_a_count(bad):
    v, f = QUAD[0].astype(np.float64).copy(), np.array([[0, 1, 2], [0, 2, 3], [1, 2, 3]])
    v[3, 1] = bad  # 1e39 overflows float32: invalid too
    p = prepare_triangles(v, f)
    assert p.skipped_invalid == 2 and p.count == 1
    np.testing.assert_array_equal(p.source, [0])


def test03_non_finite_vertices_raise_on_request():
    v = QUAD[0].copy()
    v[3, 0] = np.nan
    with pytest.raises(SceneError, match=r"1 of 2 triangles use a NaN or infinite vertex \(first: vertex 3"):
        prepare_triangles(v, QUAD[1], on_invalid="raise")
    prepare_triangles(v[:3], QUAD[1][:1], on_invalid="raise")  # an unused NaN vertex is fine


def test04_zero_area_triangles_skipped():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1e-20, 0, 0]], np.float32)
    f = np.array([[0, 1, 2],   # collinear
                  [0, 0, 3],   # repeated vertex
                  [0, 4, 3],   # tiny but not zero: kept
                  [0, 1, 3]])
    p = prepare_triangles(v, f)
    assert p.skipped_degenerate == 2
    np.testing.assert_array_equal(p.source, [2, 3])


def test05_exact_duplicates_removed_in_any_corner_order():
    rng = np.random.default_rng(3)
    v = rng.random((30, 3)).astype(np.float32)
    f = rng.permutation(30).reshape(10, 3)  # ten distinct triangles
    dup = np.concatenate([f, f[:5][:, [1, 2, 0]], f[:5][:, [2, 1, 0]], f[:3]])
    # Duplicates through distinct vertex indices with equal positions count too.
    v2 = np.concatenate([v, v])
    dup = np.concatenate([dup, f[:4] + 30])
    p = prepare_triangles(v2, dup)
    assert p.removed_duplicates == 5 + 5 + 3 + 4
    np.testing.assert_array_equal(p.source, np.arange(len(f)))  # first occurrences kept


def test05b_hash_collisions_never_remove_distinct_triangles(monkeypatch):
    """Vertex hashes only group triangles for the exact comparison: with every hash
    equal, every distinct triangle is kept (a collision can only leave a duplicate)."""
    from glrender.accel import mesh

    rng = np.random.default_rng(5)
    v = rng.random((60, 3)).astype(np.float32)
    f = rng.permutation(60).reshape(20, 3)
    tris = np.concatenate([f, f[:6][:, [2, 0, 1]], f[:2]])
    expected = prepare_triangles(v, tris)
    monkeypatch.setattr(mesh, "_vertex_hashes", lambda v32: np.zeros(len(v32), np.uint64))
    collided = prepare_triangles(v, tris)
    assert expected.removed_duplicates == 8
    np.testing.assert_array_equal(expected.source, np.arange(20))
    assert 0 <= collided.removed_duplicates <= 8
    assert set(range(20)) <= set(collided.source.tolist())
    removed = sorted(set(range(len(tris))) - set(collided.source.tolist()))
    assert all(i >= 20 for i in removed)                  # only later copies go


@pytest.mark.parametrize("spacing", [1.0, 1 / 128, 0.1])
def test05c_vertex_hashes_of_grid_points_are_distinct(spacing):
    """Regular grids are where a weak hash collides: none here (64^3 points)."""
    from glrender.accel.mesh import _vertex_hashes

    axis = np.arange(64, dtype=np.float32) * np.float32(spacing)
    v = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    assert len(np.unique(_vertex_hashes(np.ascontiguousarray(v)))) == len(v)


def test06_near_duplicates_are_kept():
    v, f = QUAD
    v2 = np.concatenate([v, v + np.float32(1e-7)])
    p = prepare_triangles(v2, np.concatenate([f, f + 4]))
    assert p.removed_duplicates == 0 and p.count == 4


def test07_million_identical_triangles_become_one():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    f = np.zeros((1_000_000, 3), np.int64) + [0, 1, 2]
    bvh = build_bvh(v, f)
    assert bvh.triangle_count == 1 and bvh.stats()["removed_duplicates"] == 999_999
    assert bvh.prim_order.tolist() == [0]


@pytest.mark.parametrize("vertices, triangles, message", [
    (np.zeros((3, 2)), np.zeros((1, 3), int), r"vertices must have shape \(V, 3\)"),
    (np.zeros((3, 3)), np.zeros((1, 4), int), r"triangles must have shape \(T, 3\)"),
    (np.zeros((3, 3)), np.zeros((1, 3)), r"triangles must be integer vertex indices"),
])
def test08_wrong_shapes_and_types(vertices, triangles, message):
    with pytest.raises(UsageError, match=message):
        prepare_triangles(vertices, triangles)


@pytest.mark.parametrize("index", [-1, 4])
def test09_indices_outside_the_vertices(index):
    f = QUAD[1].copy()
    f[1, 2] = index
    with pytest.raises(SceneError, match=r"1 triangle indices lie outside the 4 vertices"):
        prepare_triangles(QUAD[0], f)


def test10_empty_input():
    p = prepare_triangles(np.zeros((0, 3)), np.zeros((0, 3), int))
    assert p.count == 0 and p.corners.shape == (0, 3, 3)
    p = prepare_triangles([], [])
    assert p.count == 0
