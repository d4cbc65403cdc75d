"""Animation: camera and rigid-object motion keyed over time, evaluated per frame.

A :class:`Track` holds keys ``(time, world_from_object)``; between two keys the
transform is split as ``M = T R S`` (polar decomposition, as motion blur does in
:mod:`glrender.accel.instances`) and T, S are interpolated linearly and R by slerp,
so a rigid motion stays rigid. Before the first key and after the last the track
holds still.

Frame ``f`` is the instant ``f / fps`` seconds. Its exposure spans the scene's
shutter, ``[f / fps + shutter.open, f / fps + shutter.close]`` seconds: with an open
shutter (close > open) each keyed camera or shape gets its transforms at both ends
(linear motion blur within the frame), else the transform at the frame's instant.
:func:`scene_at_frame` returns the scene as it is at a frame; everything else in the
scene is shared with the original (not copied).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from . import model as m


@dataclass
class Track:
    """Keyed transforms of one camera or shape: ``times`` ascending (seconds),
    ``matrices`` the 4x4 world_from_object (or world_from_camera) at each."""

    times: tuple[float, ...]
    matrices: tuple[np.ndarray, ...]
    name: str = ""

    def __post_init__(self):
        from ..accel.instances import decompose

        if not self.times or len(self.times) != len(self.matrices):
            raise SceneError(f"{self.name}: expected one or more keys, each with a time and a "
                             f"transform")
        if any(b <= a for a, b in zip(self.times, self.times[1:])):
            raise SceneError(f"{self.name}: key times must increase, got {list(self.times)}")
        keys = []
        for t, mat in zip(self.times, self.matrices):
            try:
                keys.append(decompose(np.asarray(mat, np.float64)[:3]))
            except SceneError as exc:
                raise SceneError(f"{self.name}: the key at time {t:g}: {exc}") from None
        for (_, _, s0), (_, _, s1) in zip(keys, keys[1:]):
            if np.linalg.det(s0) * np.linalg.det(s1) <= 0:
                raise SceneError(f"{self.name}: a reflection appears or vanishes between keys")
        self._keys = keys

    def at(self, time: float) -> np.ndarray:
        """The 4x4 transform at ``time`` seconds (held before the first and after the
        last key; exactly the key's matrix at a key's time)."""
        from ..accel.instances import matrix_from_quaternion, slerp

        times = self.times
        if time <= times[0]:
            return np.array(self.matrices[0], np.float64)
        if time >= times[-1]:
            return np.array(self.matrices[-1], np.float64)
        k = int(np.searchsorted(times, time, side="right")) - 1
        if time == times[k]:
            return np.array(self.matrices[k], np.float64)
        u = (time - times[k]) / (times[k + 1] - times[k])
        (t0, q0, s0), (t1, q1, s1) = self._keys[k], self._keys[k + 1]
        if np.dot(q0, q1) < 0:   # the shorter way round
            q1 = -q1
        out = np.eye(4)
        out[:3, :3] = matrix_from_quaternion(slerp(q0, q1, u)) @ ((1 - u) * s0 + u * s1)
        out[:3, 3] = (1 - u) * t0 + u * t1
        return out


@dataclass
class Animation:
    """Keyed motion of a scene: ``fps`` frames per second, ``frames`` the default
    (first, last) frame range (inclusive), ``camera`` a track (or None) and
    ``shapes`` a track per index of ``Scene.shapes``."""

    fps: float = 24.0
    frames: tuple[int, int] | None = None
    camera: Track | None = None
    shapes: dict[int, Track] = field(default_factory=dict)

    def __post_init__(self):
        if not (isinstance(self.fps, (int, float)) and self.fps > 0 and np.isfinite(self.fps)):
            raise SceneError(f"animation.fps: expected a positive number, got {self.fps!r}")
        if self.frames is not None and not 0 <= self.frames[0] <= self.frames[1]:
            raise SceneError(f"animation.frames: expected [first, last] with 0 <= first <= last, "
                             f"got {list(self.frames)}")

    def exposure(self, frame: int, shutter: m.Shutter) -> tuple[float, float]:
        """Seconds at which frame ``frame``'s shutter opens and closes."""
        t = frame / self.fps
        if shutter.active:
            return t + shutter.open, t + shutter.close
        return t, t


def scene_at_frame(scene: m.Scene, frame: int) -> m.Scene:
    """The scene as it is at ``frame``: keyed camera and shapes placed at the frame's
    exposure (with their shutter-close transform when the shutter is open). A scene
    without animation is returned as it is."""
    anim = scene.animation
    if anim is None:
        return scene
    if not isinstance(frame, (int, np.integer)) or frame < 0:
        raise SceneError(f"frame: expected a non-negative integer, got {frame!r}")
    t_open, t_close = anim.exposure(int(frame), scene.shutter)
    blur = scene.shutter.active
    camera = scene.camera
    if anim.camera is not None:
        camera = dataclasses.replace(
            camera, world_from_camera=anim.camera.at(t_open),
            world_from_camera_close=anim.camera.at(t_close) if blur else None)
    shapes = list(scene.shapes)
    for index, track in anim.shapes.items():
        shapes[index] = dataclasses.replace(
            shapes[index], world_from_object=track.at(t_open),
            world_from_object_close=track.at(t_close) if blur else None)
    return dataclasses.replace(scene, camera=camera, shapes=shapes)


def frame_range(scene: m.Scene, text: str) -> list[int]:
    """Frames of ``--frames A:B`` (A through B, inclusive), ``A`` (one frame) or ``:``
    (the range of the scene's [animation])."""
    from ..errors import UsageError

    anim = scene.animation
    if text.strip() == ":":
        if anim is None or anim.frames is None:
            raise UsageError(f"--frames {text}: the scene gives no frame range; give A:B")
        return list(range(anim.frames[0], anim.frames[1] + 1))
    first, sep, last = text.partition(":")
    try:
        a = int(first)
        b = int(last) if sep else a
    except ValueError:
        raise UsageError(f"--frames {text}: expected A:B (frames A through B) or A, with "
                         f"non-negative integers") from None
    if not 0 <= a <= b:
        raise UsageError(f"--frames {text}: expected 0 <= A <= B")
    if anim is None:
        raise UsageError(f"--frames {text}: {scene.source} has no [animation]; render it "
                         f"without --frames")
    return list(range(a, b + 1))
