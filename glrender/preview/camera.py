"""Steering the scene's camera: orbit, pan, zoom and fly, as a viewer does.

The controller keeps a rigid pose (eye, target, and the scene camera's up as the
world's up axis) and a fixed local transform ``A = pose0^-1 M0`` that carries what
the scene's matrix has beyond a rigid frame (scale, a mirror, and the shutter-close
matrix of a moving camera): the camera's matrices are always ``pose @ A``, so an
unmoved controller gives the scene's matrices back, and a moved one keeps their
handedness and motion.

Frames follow Mitsuba (glrender/scene/model.py ``look_at``): the columns of
world_from_camera are (left, up, forward, origin). Orbiting turns about the target:
yaw about the up axis, pitch about the camera's left axis, kept at least
``kMinPolar`` from the poles (a turntable never rolls).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..scene import model as m

ORBIT_RADIANS_PER_PIXEL = 0.005     # drag of 200 pixels: about 57 degrees
ZOOM_PER_STEP = 0.85                # distance factor per scroll step
MIN_POLAR = math.radians(2.0)       # closest angle between the view and the up axis


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of v about the unit axis by angle (right-handed)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1.0 - c)


def pose_matrix(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The rigid world_from_camera of a camera at eye looking at target (Mitsuba's frame)."""
    return m.look_at(eye, target, up)


class CameraController:
    """Orbit / pan / zoom / fly state for one scene camera.

    ``center`` and ``radius`` describe the scene's bounding sphere: the orbit target
    starts where the view ray passes closest to its centre, and fly speed and zoom
    limits scale with its radius.
    """

    def __init__(self, camera: m.Camera, center, radius: float):
        self.home = camera
        self.radius = float(radius) if radius > 0 and math.isfinite(radius) else 1.0
        mat = np.asarray(camera.world_from_camera, np.float64)
        eye = mat[:3, 3].copy()
        forward = _normalize(mat[:3, 2])
        up = mat[:3, 1] - forward * np.dot(mat[:3, 1], forward)
        self.up = _normalize(up)
        distance = float(np.dot(np.asarray(center, np.float64) - eye, forward))
        if not distance > 1e-3 * self.radius:
            distance = self.radius
        self.home_pose = (eye, eye + forward * distance)
        pose = pose_matrix(*self.home_pose, self.up)
        inverse = np.linalg.inv(pose)
        self._local_open = inverse @ mat
        close = camera.world_from_camera_close
        self._local_close = None if close is None else inverse @ np.asarray(close, np.float64)
        self.reset()

    # -- state -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the scene's camera."""
        self.eye, self.target = (v.copy() for v in self.home_pose)
        self.extent = 1.0           # an orthographic view's width, as a factor of the scene's
        self.moved = False

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.target - self.eye))

    @property
    def forward(self) -> np.ndarray:
        return _normalize(self.target - self.eye)

    @property
    def left(self) -> np.ndarray:
        return _normalize(np.cross(self.up, self.forward))

    @property
    def camera_up(self) -> np.ndarray:
        return np.cross(self.forward, self.left)

    def camera(self) -> m.Camera:
        """The scene camera at the current pose (the scene's own when unmoved)."""
        if not self.moved:
            return self.home
        pose = pose_matrix(self.eye, self.target, self.up)
        close = None if self._local_close is None else pose @ self._local_close
        wide = {"half_extent": self.home.half_extent * self.extent} if self.home.orthographic else {}
        return replace(self.home, world_from_camera=pose @ self._local_open,
                       world_from_camera_close=close, **wide)

    # -- moves -----------------------------------------------------------------------------
    def orbit(self, dx: float, dy: float) -> None:
        """Turn about the target by a mouse drag of (dx, dy) pixels (y down): dragging right
        swings the camera to its left, so the scene turns with the cursor; dragging down
        raises the camera."""
        offset = self.eye - self.target
        # Rodrigues about +up turns the offset toward -left (left = up x forward)
        offset = _rotate(offset, self.up, -dx * ORBIT_RADIANS_PER_PIXEL)
        axis = _normalize(np.cross(self.up, -offset))       # the camera's left after the yaw
        polar = math.acos(float(np.clip(np.dot(_normalize(offset), self.up), -1.0, 1.0)))
        # about +left the offset turns toward +up: a positive angle lowers the polar angle
        pitch = dy * ORBIT_RADIANS_PER_PIXEL
        pitch = min(pitch, polar - MIN_POLAR)
        pitch = max(pitch, polar - (math.pi - MIN_POLAR))
        offset = _rotate(offset, axis, pitch)
        self.eye = self.target + offset
        self.moved = True

    def pan(self, dx: float, dy: float, pixels_per_unit_height: float) -> None:
        """Slide eye and target in the image plane so the scene under the cursor follows a
        drag of (dx, dy) pixels (y down); ``pixels_per_unit_height`` is the viewport's height
        in pixels divided by tan(fov_y / 2)."""
        scale = 2.0 * self.distance / pixels_per_unit_height
        shift = self.left * (dx * scale) + self.camera_up * (dy * scale)
        self.eye = self.eye + shift
        self.target = self.target + shift
        self.moved = True

    def zoom(self, steps: float) -> None:
        """Dolly toward the target (steps > 0) or away: distance x ZOOM_PER_STEP^steps,
        kept within 1e-4 and 1e4 scene radii. An orthographic view looks the same from any
        distance: its width changes instead, by the same factor (within 1e-4 and 1e4 of the
        scene's)."""
        factor = ZOOM_PER_STEP ** min(max(steps, -100.0), 100.0)
        if self.home.orthographic:
            self.extent = min(max(self.extent * factor, 1e-4), 1e4)
            self.moved = True
            return
        distance = min(max(self.distance * factor, 1e-4 * self.radius), 1e4 * self.radius)
        self.eye = self.target - self.forward * distance
        self.moved = True

    def fly(self, forward: float, right: float, up: float, seconds: float) -> None:
        """Move eye and target together; the arguments are -1, 0 or 1 per axis (up along the
        world's up), at half the scene's radius per second."""
        step = 0.5 * self.radius * seconds
        shift = (self.forward * forward - self.left * right + self.up * up) * step
        self.eye = self.eye + shift
        self.target = self.target + shift
        self.moved = True
