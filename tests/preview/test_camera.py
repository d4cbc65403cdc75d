"""Orbit, pan, zoom and fly (glrender/preview/camera.py): pure geometry, no window."""
from __future__ import annotations

import math

import numpy as np
import pytest

from glrender.preview.camera import MIN_POLAR, ORBIT_RADIANS_PER_PIXEL, ZOOM_PER_STEP, CameraController
from glrender.scene import model as m

CENTER = np.array([0.2, -0.1, 0.3])


def _camera(mirror_scale=True, moving=True) -> m.Camera:
    """A camera whose matrix carries more than a rigid frame: a mirrored, scaled x axis,
    and a shutter-close matrix (motion blur)."""
    open_ = m.look_at((1.0, 2.0, 6.0), CENTER, (0, 1, 0))
    if mirror_scale:
        open_ = open_ @ np.diag([-1.5, 1.5, 1.5, 1.0])
    close = None
    if moving:
        close = open_.copy()
        close[:3, 3] += (0.1, 0.0, -0.05)
    return m.Camera(world_from_camera=open_, world_from_camera_close=close, fov=40.0)


def _controller(**kw) -> CameraController:
    return CameraController(_camera(**kw), CENTER, 2.0)


def _project(camera: m.Camera, point, tan_y: float, height_px: float) -> np.ndarray:
    """Offset of a world point from the image centre in pixels (x right, y down) for a
    viewport height_px pixels high (Mitsuba's frame: camera +x is the image's left)."""
    M = np.asarray(camera.world_from_camera)
    R = M[:3, :3] / np.linalg.norm(M[:3, :3], axis=0)   # the rigid part (columns normalized)
    p = R.T @ (np.asarray(point) - M[:3, 3])
    sign_x = np.sign(np.linalg.det(M[:3, :3]))           # a mirrored x flips the image
    return -np.array([sign_x * p[0], p[1]]) / (p[2] * tan_y) * height_px / 2


def test01_unmoved_is_the_scene_camera():
    cam = _camera()
    c = CameraController(cam, CENTER, 2.0)
    assert c.camera() is cam
    np.testing.assert_allclose(c.target, CENTER, atol=1e-12)   # the view passes the centre
    c.orbit(0.0, 0.0)   # moved by nothing: the same matrices, through pose @ local
    assert c.moved
    np.testing.assert_allclose(c.camera().world_from_camera, cam.world_from_camera, atol=1e-12)
    np.testing.assert_allclose(c.camera().world_from_camera_close, cam.world_from_camera_close,
                               atol=1e-12)


@pytest.mark.parametrize("mirror_scale,moving", [(True, True), (False, False)])
def test02_moves_keep_scale_mirror_and_motion(mirror_scale, moving):
    cam = _camera(mirror_scale, moving)
    c = CameraController(cam, CENTER, 2.0)
    c.orbit(37.0, -12.0)
    c.pan(5.0, 3.0, 400.0)
    c.zoom(1.5)
    new = c.camera()
    M0, M1 = np.asarray(cam.world_from_camera), np.asarray(new.world_from_camera)
    np.testing.assert_allclose(np.linalg.norm(M1[:3, :3], axis=0), np.linalg.norm(M0[:3, :3], axis=0))
    assert np.sign(np.linalg.det(M1[:3, :3])) == np.sign(np.linalg.det(M0[:3, :3]))
    np.testing.assert_allclose(M1[:3, 3], c.eye, atol=1e-12)
    np.testing.assert_allclose(M1[:3, 2] / np.linalg.norm(M1[:3, 2]), c.forward, atol=1e-12)
    if moving:   # the close matrix follows: the same camera-space offset
        np.testing.assert_allclose(np.linalg.inv(M1) @ new.world_from_camera_close,
                                   np.linalg.inv(M0) @ cam.world_from_camera_close, atol=1e-12)
    else:
        assert new.world_from_camera_close is None
    c.reset()
    assert c.camera() is cam


def test03_orbit_turns_about_the_target():
    c = _controller()
    eye0, target, left0 = c.eye.copy(), c.target.copy(), c.left.copy()
    height0 = np.dot(eye0 - target, c.up)
    c.orbit(10.0, 0.0)   # drag right: the camera swings to its left, at the same height
    assert np.dot(c.eye - eye0, left0) > 0
    np.testing.assert_allclose(np.linalg.norm(c.eye - target), np.linalg.norm(eye0 - target))
    np.testing.assert_allclose(np.dot(c.eye - target, c.up), height0, atol=1e-12)
    horizontal = np.linalg.norm(eye0 - target - height0 * c.up)   # radius of the turn
    angle = 2 * math.asin(np.linalg.norm(c.eye - eye0) / (2 * horizontal))
    np.testing.assert_allclose(angle, 10.0 * ORBIT_RADIANS_PER_PIXEL, rtol=1e-9)
    # a full turn in small steps comes back
    c = _controller()
    steps = 100
    for _ in range(steps):
        c.orbit(2 * math.pi / ORBIT_RADIANS_PER_PIXEL / steps, 0.0)
    np.testing.assert_allclose(c.eye, eye0, atol=1e-9)
    np.testing.assert_allclose(c.target, target, atol=1e-12)


def test04_orbit_pitch_raises_and_stops_short_of_the_pole():
    c = _controller()
    y0 = np.dot(c.eye - c.target, c.up)
    c.orbit(0.0, 20.0)   # drag down: the camera rises
    assert np.dot(c.eye - c.target, c.up) > y0
    c.orbit(0.0, 1e5)
    polar = math.acos(np.dot(c.eye - c.target, c.up) / c.distance)
    np.testing.assert_allclose(polar, MIN_POLAR, atol=1e-9)
    c.orbit(0.0, -1e5)
    polar = math.acos(np.dot(c.eye - c.target, c.up) / c.distance)
    np.testing.assert_allclose(polar, math.pi - MIN_POLAR, atol=1e-9)
    c.camera()   # look_at still has a frame


@pytest.mark.parametrize("drag", [(12.0, 0.0), (0.0, -7.0), (-4.0, 9.0)])
def test05_pan_keeps_the_point_under_the_cursor(drag):
    """The scene point at the target's depth moves on screen exactly as the mouse did."""
    c = _controller()
    tan_y, height_px = math.tan(math.radians(20.0)), 300.0
    target = c.target.copy()
    before = _project(c.camera() if c.moved else c.home, target, tan_y, height_px)
    np.testing.assert_allclose(before, 0.0, atol=1e-9)
    c.pan(*drag, height_px / tan_y)
    after = _project(c.camera(), target, tan_y, height_px)
    np.testing.assert_allclose(after, drag, atol=1e-9)
    np.testing.assert_allclose(c.forward, _controller().forward, atol=1e-12)


def test06_zoom_and_fly():
    c = _controller()
    d0, f0, target = c.distance, c.forward.copy(), c.target.copy()
    c.zoom(2.0)
    np.testing.assert_allclose(c.distance, d0 * ZOOM_PER_STEP ** 2)
    np.testing.assert_allclose(c.forward, f0, atol=1e-12)
    np.testing.assert_allclose(c.target, target)
    c.zoom(-1e4)   # far away and back: never through the target
    c.zoom(1e4)
    assert c.distance > 0
    c = _controller()
    eye0 = c.eye.copy()
    c.fly(1, 0, 0, 0.5)              # half the scene's radius per second, forward
    np.testing.assert_allclose(c.eye - eye0, f0 * 0.5 * 2.0 * 0.5, atol=1e-12)
    c.fly(0, 1, 1, 1.0)              # right (-left) and up the world's axis
    np.testing.assert_allclose(c.eye - eye0 - f0 * 0.5, (-c.left + c.up) * 1.0, atol=1e-12)
    np.testing.assert_allclose(c.distance, _controller().distance)


def test07_zoom_narrows_an_orthographic_view():
    """An orthographic view is as wide at every distance: the wheel changes its width, by
    the factor a perspective camera's distance changes, and R restores it."""
    cam = m.Camera(world_from_camera=m.look_at((1.0, 2.0, 6.0), CENTER, (0, 1, 0)),
                   kind="orthographic", half_extent=2.0)
    c = CameraController(cam, CENTER, 2.0)
    d0 = c.distance
    c.zoom(2.0)
    zoomed = c.camera()
    assert zoomed.orthographic and math.isclose(zoomed.half_extent, 2.0 * ZOOM_PER_STEP ** 2)
    assert math.isclose(c.distance, d0)
    np.testing.assert_allclose(zoomed.world_from_camera, cam.world_from_camera, atol=1e-12)
    c.zoom(-1e4)
    assert c.camera().half_extent <= 2.0 * 1e4
    c.reset()
    assert c.camera() is cam
