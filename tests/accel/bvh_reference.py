"""Test helpers for the BVH: a float64 brute-force tracer, test meshes, and the GLSL tracer."""
from __future__ import annotations

from pathlib import Path

import numpy as np

MESHES = Path(__file__).resolve().parents[1] / "data" / "meshes"
NO_HIT = 0xFFFFFFFF


def load_mesh(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A mesh from tests/data/meshes as (vertices float32, faces int64)."""
    import trimesh

    mesh = trimesh.load(MESHES / name, process=False)
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.int64)


def brute_force(o: np.ndarray, d: np.ndarray, corners: np.ndarray, t_max=np.inf,
                chunk: int = 1 << 22) -> dict[str, np.ndarray]:
    """Closest hits of rays o + t d, t in (0, t_max), against triangles (T, 3, 3), in float64.

    Returns ``t`` (inf: miss), ``prim`` (-1: miss), ``second`` (t of the next
    nearest distinct hit, for ties) and ``margin`` (smallest barycentric of the
    hit, in units of the triangle's scale: how far the hit is from an edge).
    """
    o = np.asarray(o, np.float64)
    d = np.asarray(d, np.float64)
    c = np.asarray(corners, np.float64)
    n, t_count = len(o), len(c)
    t_max = np.broadcast_to(np.asarray(t_max, np.float64), (n,))
    best = np.full(n, np.inf)
    second = np.full(n, np.inf)
    prim = np.full(n, -1, np.int64)
    margin = np.full(n, np.inf)
    if t_count == 0:
        return {"t": best, "prim": prim, "second": second, "margin": margin}
    v0, e1, e2 = c[:, 0], c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    step = max(1, chunk // t_count)
    for s in range(0, n, step):
        oo, dd = o[s:s + step, None, :], d[s:s + step, None, :]
        p = np.cross(dd, e2[None])
        det = np.sum(e1[None] * p, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = oo - v0[None]
            u = np.sum(tv * p, axis=-1) * inv
            q = np.cross(tv, e1[None])
            v = np.sum(dd * q, axis=-1) * inv
            t = np.sum(e2[None] * q, axis=-1) * inv
        ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < t_max[s:s + step, None])
        t = np.where(ok, t, np.inf)
        k = np.argmin(t, axis=1)
        rows = np.arange(len(k))
        tb = t[rows, k]
        t2 = t.copy()
        t2[rows, k] = np.inf
        best[s:s + step] = tb
        second[s:s + step] = t2.min(axis=1)
        hit = np.isfinite(tb)
        prim[s:s + step] = np.where(hit, k, -1)
        m = np.minimum(np.minimum(u[rows, k], v[rows, k]), 1 - u[rows, k] - v[rows, k])
        margin[s:s + step] = np.where(hit, m, np.inf)
    return {"t": best, "prim": prim, "second": second, "margin": margin}


def ray_triangle_t(o: np.ndarray, d: np.ndarray, corners: np.ndarray, t_max=np.inf) -> np.ndarray:
    """Hit distance of ray k against triangle k (inf: miss), in float64, with the same
    arithmetic and hit rule as :func:`brute_force` (so the same t, bit for bit)."""
    o = np.asarray(o, np.float64)
    d = np.asarray(d, np.float64)
    c = np.asarray(corners, np.float64)
    v0, e1, e2 = c[:, 0], c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    p = np.cross(d, e2)
    det = np.sum(e1 * p, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = o - v0
        u = np.sum(tv * p, axis=-1) * inv
        q = np.cross(tv, e1)
        v = np.sum(d * q, axis=-1) * inv
        t = np.sum(e2 * q, axis=-1) * inv
    ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < t_max)
    return np.where(ok, t, np.inf)


def trace_glsl(gpu_bvh, o: np.ndarray, d: np.ndarray, t_max=np.inf,
               defines=None) -> dict[str, np.ndarray]:
    """Closest hit and any hit of each ray through the GLSL traversal.

    Returns ``t``, ``prim`` (BVH order; NO_HIT on a miss), ``bary``, ``hit`` and
    ``any`` (the any-hit answer for the same ray), and ``loops`` (the larger
    loop count of the two queries) when ``defines`` sets GLRENDER_COUNT_LOOPS.
    """
    from glrender.render.params import shader_defines
    from glrender.testing.harness import run_glsl

    n = len(o)
    t_max = np.broadcast_to(np.asarray(t_max, np.float32), (n,)).copy()
    counting = bool((defines or {}).get("GLRENDER_COUNT_LOOPS"))
    outputs = {"t": "float", "prim": "uint", "bary": "vec2", "hit": "bool", "any": "bool"}
    body = ["BvhHit h;", "bool hit = bvh_intersect_closest(o, d, t_max, h);"]
    if counting:
        outputs["loops"] = "uint"
        body += ["uint loops = g_loop_count;", "g_loop_count = 0u;"]
    body += ["bool any = bvh_intersect_any(o, d, t_max);",
             "float t = h.t;", "uint prim = h.prim;", "vec2 bary = h.bary;"]
    if counting:
        body += ["loops = max(loops, g_loop_count);"]
    gpu_bvh.bind()
    return run_glsl("\n".join(body), {"o": np.asarray(o, np.float32), "d": np.asarray(d, np.float32),
                                       "t_max": t_max},
                    outputs, includes=["geometry/bvh.glsl"],
                    defines={**shader_defines(), **gpu_bvh.defines(), **(defines or {})})


def random_soup(rng, count: int, spread: float = 1.0, size: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """``count`` random triangles (unshared vertices) in a cube of side ``spread``."""
    centres = rng.random((count, 1, 3)) * spread
    verts = (centres + (rng.random((count, 3, 3)) - 0.5) * size).reshape(-1, 3)
    return verts.astype(np.float32), np.arange(3 * count).reshape(count, 3)


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed, consistently wound unit icosphere (shared vertices)."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = np.array(v, np.float64)
    verts /= np.linalg.norm(verts, axis=1, keepdims=True)
    faces = np.array(f, np.int64)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = verts[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(verts) + inverse.reshape(3, -1).T  # midpoints of edges 01, 12, 20
        verts = np.concatenate([verts, mid])
        a, b, c = faces.T
        faces = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([b, m[:, 1], m[:, 0]], 1),
                                np.stack([c, m[:, 2], m[:, 1]], 1), m])
    return verts, faces
