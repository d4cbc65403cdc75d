"""Mesh clean-up and recomputed vertex normals (glrender/scene/loaders/meshes.py) against a
triangle-by-triangle reference written from the definition."""
import math

import numpy as np
import pytest

from glrender.errors import SceneError
from glrender.scene.loaders.meshes import MeshData, finish_mesh, vertex_normals


def _reference_normals(v, f):
    """Angle-weighted face normals summed per vertex, one triangle and corner at a time."""
    out = np.zeros((len(v), 3))
    for tri in f:
        p = [np.asarray(v[i], float) for i in tri]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n /= max(np.linalg.norm(n), 1e-300)
        for k in range(3):
            a, b = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
            cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
            out[tri[k]] += n * math.acos(min(1.0, max(-1.0, cos)))
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(length > 0, out / np.where(length > 0, length, 1), 0)


def _irregular_mesh(seed=3):
    """A jittered, randomly wound grid: unequal angles and areas at every vertex."""
    rng = np.random.default_rng(seed)
    k = 7
    x, y = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    v = np.stack([x, y, np.zeros_like(x)], -1).reshape(-1, 3).astype(float)
    v[:, :2] += rng.uniform(-0.3, 0.3, (len(v), 2))
    v[:, 2] = np.sin(v[:, 0]) * np.cos(0.7 * v[:, 1])
    a = (x[:-1, :-1] * k + y[:-1, :-1]).ravel()
    f = np.concatenate([np.stack([a, a + k, a + 1], 1), np.stack([a + 1, a + k, a + k + 1], 1)])
    flip = rng.random(len(f)) < 0.3
    f[flip] = f[flip][:, [0, 2, 1]]
    return v, f


def test01_vertex_normals_match_the_definition():
    v, f = _irregular_mesh()
    np.testing.assert_allclose(vertex_normals(v, f), _reference_normals(v, f), rtol=0, atol=1e-12)


def test02_finish_mesh_drops_zero_area_triangles_before_the_normals(caught):
    v, f = _irregular_mesh()
    v = np.concatenate([v, [[0.5, 0.5, 9.0]]])
    degenerate = np.array([[0, 1, 0], [2, 2, 2], [len(v) - 1, len(v) - 1, 3]])  # repeated corners
    collinear = np.array([[0, 1, 2]])          # vertices 0, 1, 2: on one line only if x equal
    v[[0, 1, 2], 0] = 0.0
    v[[0, 1, 2], 1] = [0.0, 1.0, 2.5]
    v[[0, 1, 2], 2] = 0.0
    mixed = np.concatenate([f[:5], degenerate, f[5:], collinear])
    with caught as messages:
        mesh = finish_mesh(MeshData(v, mixed), "m.ply")
    assert any("m.ply: dropped 4 zero-area triangles of" in w for w in messages)
    np.testing.assert_array_equal(mesh.triangles, f)
    np.testing.assert_allclose(mesh.normals, _reference_normals(v, f), rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad, message", [
    (lambda v, f: (np.where(np.arange(len(v))[:, None] == 4, np.nan, v), f),
     r"m\.ply: vertex 4 has a NaN or infinite coordinate"),
    (lambda v, f: (v, np.concatenate([f, [[0, 1, len(v)]]])), r"m\.ply: triangle \d+ refers to vertex"),
    (lambda v, f: (v, f[:, [0, 0, 1]]), r"m\.ply: no triangles with non-zero area"),
])
def test03_bad_meshes_name_the_file(bad, message):
    v, f = bad(*_irregular_mesh())
    with pytest.raises(SceneError, match=message):
        finish_mesh(MeshData(v, f), "m.ply")
