"""Orthonormal frames from one vector (Duff et al. 2017) and the local/world transforms."""
import numpy as np

from glrender.sampling import frame
from glrender.testing.harness import run_glsl

EPS = 2.0 ** -23


def normals():
    rng = np.random.default_rng(50)
    n = rng.standard_normal((100_000, 3))
    special = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [-1, 0, 0],
                        [1e-4, 0, -1], [0, 1e-7, -1], [1e-7, 1e-7, 1], [1, 1, 1e-8], [-0.0, 0, -1]])
    n = np.vstack([special, n])
    return (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)


def test01_basis_is_orthonormal_and_right_handed(gl_ctx):
    n = normals()
    v = np.random.default_rng(51).standard_normal((len(n), 3)).astype(np.float32)
    out = run_glsl("Frame f = frame_from_z(n); vec3 x = f.x; vec3 y = f.y; "
                   "vec3 local = frame_to_local(f, v); vec3 back = frame_from_local(f, local);",
                   {"n": n, "v": v}, {"x": "vec3", "y": "vec3", "local": "vec3", "back": "vec3"},
                   includes=["common/frame.glsl"])
    x, y, z = (a.astype(np.float64) for a in (out["x"], out["y"], n))
    # Duff et al.'s construction keeps every entry of the basis within a few ulps
    tol = 8 * EPS
    for a, b in ((x, y), (x, z), (y, z)):
        assert np.max(np.abs(np.sum(a * b, axis=1))) <= tol
    for a in (x, y):
        assert np.max(np.abs(np.linalg.norm(a, axis=1) - 1)) <= tol
    assert np.max(np.abs(np.cross(x, y) - z)) <= tol
    # to local and back is the identity (an orthogonal matrix and its transpose)
    np.testing.assert_allclose(out["back"], v, rtol=0, atol=tol * np.abs(v).max())
    np.testing.assert_allclose(out["local"][:, 2], np.sum(v * n, axis=1), rtol=0, atol=tol * np.abs(v).max())
    # the numpy twin builds the same basis
    bx, by, _ = frame.frame_from_z(n.astype(np.float64))
    np.testing.assert_allclose(out["x"], bx, rtol=0, atol=tol)
    np.testing.assert_allclose(out["y"], by, rtol=0, atol=tol)
    n64 = n / np.linalg.norm(n.astype(np.float64), axis=1, keepdims=True)
    f = frame.frame_from_z(n64)
    np.testing.assert_allclose(frame.frame_from_local(f, frame.frame_to_local(f, v)), v, atol=1e-12)


def test02_frame_from_xy(gl_ctx):
    x = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]], np.float32)
    y = np.array([[0.0, 1.0, 0.0], [0.0, -0.8, 0.6]], np.float32)
    out = run_glsl("Frame f = frame_from_xy(x, y); vec3 z = f.z;", {"x": x, "y": y}, {"z": "vec3"},
                   includes=["common/frame.glsl"])
    np.testing.assert_allclose(out["z"], np.cross(x, y), atol=EPS)
    np.testing.assert_allclose(frame.frame_from_xy(x, y)[2], np.cross(x, y), atol=1e-12)
