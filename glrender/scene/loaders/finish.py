"""The checks every loaded scene gets, whatever its format: a default camera framing
the scene when the file has none, and a warning when nothing emits light."""
from __future__ import annotations

import math

import numpy as np

from .. import model as m
from .diagnostics import warn


def scene_bounds(scene: m.Scene) -> tuple[np.ndarray, np.ndarray] | None:
    """World-space bounding box of every shape (None for a scene without shapes)."""
    points = []
    unit_square = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
    unit_cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    for shape in scene.shapes:
        M = shape.world_from_object
        if shape.kind == "mesh" and shape.instances is not None and shape.vertices is not None \
                and len(shape.vertices):
            # every copy's box: the placed mesh's box under each copy's transform
            from ...accel.instances import instance_world_bounds

            box = m.point_bounds(m.transform_points(M, np.asarray(shape.vertices, np.float64)))
            points += list(instance_world_bounds(np.asarray(shape.instances, np.float64)[:, :3], *box))
        elif shape.kind == "mesh" and shape.vertices is not None and len(shape.vertices):
            v = np.asarray(shape.vertices, np.float64)
            points.append(m.transform_points(M, np.stack(m.point_bounds(v)) if
                                             np.allclose(M[:3, :3], np.diag(np.diag(M[:3, :3])))
                                             else v))
        elif shape.kind in ("rectangle", "disk"):
            points.append(m.transform_points(M, unit_square))
        elif shape.kind == "cube":
            points.append(m.transform_points(M, unit_cube))
        elif shape.kind == "sphere":
            c = np.asarray(shape.center, np.float64)
            points.append(m.transform_points(M, c + shape.radius * unit_cube))
    if not points:
        return None
    p = np.concatenate(points)
    p = p[np.isfinite(p).all(axis=1)]
    if not len(p):
        return None
    return m.point_bounds(p)


def default_camera(scene: m.Scene, fov: float = 40.0) -> m.Camera:
    """A camera on the +z side of the scene's bounding sphere, slightly above, looking at
    its centre, far enough back that the sphere fits the smaller image axis."""
    bounds = scene_bounds(scene)
    if bounds is None:
        return m.Camera()
    lo, hi = bounds
    center = 0.5 * (lo + hi)
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-3)
    distance = radius / math.sin(math.radians(fov) / 2) * 1.05
    direction = np.array([0.0, 0.25, 1.0]) / math.hypot(0.25, 1.0)
    origin = center + distance * direction
    return m.Camera(world_from_camera=m.look_at(origin, center, (0, 1, 0)), fov=fov,
                    fov_axis="smaller", near_clip=max(distance - 2 * radius, distance * 1e-4) * 0.5,
                    far_clip=(distance + 2 * radius) * 2)


def has_emitters(scene: m.Scene) -> bool:
    return bool(scene.lights) or any(s.emission is not None for s in scene.shapes)


def finish_scene(scene: m.Scene, has_camera: bool) -> m.Scene:
    """Default camera (with a warning) when the file has none; warn when nothing emits."""
    if not has_camera:
        scene.camera = default_camera(scene)
        warn(f"{scene.source}: the scene has no camera; a default camera frames it")
    if not has_emitters(scene):
        warn(f"{scene.source}: the scene has no lights and no emitting shapes; it renders black")
    scene.validate()
    return scene
