"""Animation keys in the scene format ([animation]) and the scene at a frame."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError, UsageError
from glrender.scene import model as m
from glrender.scene.animation import Track, frame_range, scene_at_frame

from dist_run import CORNELL, animated_cornell

EPS = np.finfo(np.float64).eps


def rigid(angle, t):
    return m.translate(t) @ m.rotate((0, 1, 0), angle)


def test01_track_holds_keys_and_interpolates_rigidly():
    a, b = rigid(0, (0, 0, 0)), rigid(90, (2, 0, 0))
    tr = Track((0.0, 1.0), (a, b), name="t")
    np.testing.assert_array_equal(tr.at(0.0), a)
    np.testing.assert_array_equal(tr.at(1.0), b)
    np.testing.assert_array_equal(tr.at(-5.0), a)         # held before the first key
    np.testing.assert_array_equal(tr.at(7.0), b)          # and after the last
    mid = tr.at(0.5)
    np.testing.assert_allclose(mid[:3, 3], (1, 0, 0), atol=1e-12)
    np.testing.assert_allclose(mid, rigid(45, (1, 0, 0)), atol=1e-12)   # slerp: half the angle
    for t in np.linspace(0, 1, 7):
        r = tr.at(t)[:3, :3]
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=64 * EPS)   # stays a rotation


def test02_bad_tracks_are_refused():
    with pytest.raises(SceneError, match="increase"):
        Track((1.0, 0.5), (np.eye(4), np.eye(4)), name="x")
    with pytest.raises(SceneError, match="reflection"):
        Track((0.0, 1.0), (np.eye(4), np.diag([-1.0, 1, 1, 1])), name="x")


def test03_toml_animation_and_the_scene_at_a_frame(tmp_path):
    scene = glrender.load(animated_cornell(tmp_path, frames=(2, 5)))
    anim = scene.animation
    assert anim.fps == 24 and anim.frames == (2, 5)
    small = [i for i, s in enumerate(scene.shapes) if s.name == "small box"]
    assert list(anim.shapes) == small
    s0, s1 = scene_at_frame(scene, 0), scene_at_frame(scene, 1)
    np.testing.assert_array_equal(s0.camera.world_from_camera, scene.camera.world_from_camera)
    np.testing.assert_array_equal(s0.shapes[small[0]].world_from_object,
                                  scene.shapes[small[0]].world_from_object)
    # frame 1 at 1/24 s, half-way between the keys at 0 and 1/12 s: half the rise
    rise = s1.shapes[small[0]].world_from_object[1, 3] - s0.shapes[small[0]].world_from_object[1, 3]
    assert abs(rise - 0.125) < 1e-5          # keys at 0.0833333 s, not exactly 1/12
    assert s1.camera.world_from_camera_close is None         # the shutter is closed
    assert frame_range(scene, ":") == [2, 3, 4, 5] and frame_range(scene, "3:4") == [3, 4]
    assert frame_range(scene, "7") == [7]
    for bad in ("4:3", "a:b", "-1:2"):
        with pytest.raises(UsageError):
            frame_range(scene, bad)
    # an open shutter: each frame blurs from its open to its close instant
    blurred = dataclasses.replace(scene, shutter=m.Shutter(open=0.0, close=1 / 24))
    b0 = scene_at_frame(blurred, 0)
    np.testing.assert_allclose(b0.shapes[small[0]].world_from_object_close,
                               s1.shapes[small[0]].world_from_object, atol=1e-12)


@pytest.mark.parametrize("extra,message", [
    ('[[animation.shapes]]\nshape = "nothing"\nkeys = [{ time = 0, transform = { translate = [0, 0, 0] } }]',
     "names 0 shapes"),
    ('[[animation.camera]]\ntime = 0\n', "expected a transform or look_at"),
    ('[[animation.camera]]\ntime = 0\ntransform = { translate = [0, 0, 0] }\n'
     'look_at = { origin = [0, 0, 1], target = [0, 0, 0] }\n', "not both"),
    ('[[animation.camera]]\ntime = 1\nlook_at = { origin = [0, 0, 1], target = [0, 0, 0] }\n'
     '[[animation.camera]]\ntime = 0\nlook_at = { origin = [0, 0, 2], target = [0, 0, 0] }\n',
     "increase"),
])
def test04_toml_errors_name_the_key(tmp_path, extra, message):
    path = tmp_path / "bad.toml"
    path.write_text(CORNELL.read_text() + "\n[animation]\nfps = 24\n\n" + extra + "\n")
    with pytest.raises(SceneError, match=message) as info:
        glrender.load(path)
    assert "animation." in str(info.value)


def test05_no_animation_no_frames():
    scene = glrender.load(CORNELL)
    assert scene.animation is None and scene_at_frame(scene, 3) is scene
    with pytest.raises(UsageError, match="no \\[animation\\]"):
        frame_range(scene, "0:1")
