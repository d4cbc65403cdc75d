"""Orthographic cameras in every scene format that has them: TOML ``kind = "orthographic"``
with ``half_extent``, glTF ``type = "orthographic"`` (xmag, ymag, znear, zfar) and Mitsuba's
``<sensor type="orthographic">`` (its size in to_world's scale); bad values are refused in one
line naming the file and the field, through the API and on the command line (exit 2)."""
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from cli_run import glrender as glrender_cli, one_error_line  # noqa: E402

QUAD = """
[materials.black]
type = "diffuse"
reflectance = [0, 0, 0]
[[shapes]]
type = "rectangle"
material = "black"
emission = { radiance = [1, 1, 1] }
"""


def toml_scene(camera: str) -> str:
    return f"[film]\nwidth = 40\nheight = 20\n[camera]\n{camera}\n{QUAD}"


def gltf_scene(camera: dict, node: dict | None = None) -> str:
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()
    import base64

    return json.dumps({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(pos),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(pos).decode()}],
        "bufferViews": [{"buffer": 0, "byteLength": len(pos)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "cameras": [camera],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 4], **(node or {})}],
        "scenes": [{"nodes": [0, 1]}], "scene": 0,
    })


def mitsuba_scene(sensor_body: str, transform: str = '<scale x="2" y="3"/>') -> str:
    return f"""<scene version="3.0.0">
    <sensor type="orthographic">
        {sensor_body}
        <transform name="to_world">{transform}<lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"""


def test01_toml(write):
    scene = glrender.load(write("o.toml", toml_scene(
        'kind = "orthographic"\nhalf_extent = 2.5\nfov_axis = "y"\nnear_clip = 0\n'
        'look_at = { origin = [0, 0, 4], target = [0, 0, 0], up = [0, 1, 0] }')))
    cam = scene.camera
    assert cam.kind == "orthographic" and cam.orthographic
    assert cam.half_extent == 2.5 and cam.fov_axis == "y" and cam.near_clip == 0
    # the default camera stays a perspective one
    assert glrender.load(write("p.toml", toml_scene("fov = 30"))).camera.kind == "perspective"


def test02_gltf(write, caught):
    """ymag is the half extent along y; the film's width follows xmag / ymag; the node's
    scale is dropped, as for a perspective camera."""
    camera = {"type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 1.5, "znear": 0.0, "zfar": 50}}
    with caught:                                # the triangle has no light: a warning
        scene = glrender.load(write("o.gltf", gltf_scene(camera, {"scale": [2, 2, 2]})))
    cam = scene.camera
    assert cam.kind == "orthographic" and cam.half_extent == 1.5 and cam.fov_axis == "y"
    assert cam.near_clip == 0 and cam.far_clip == 50
    assert scene.film.width == 2 * scene.film.height
    np.testing.assert_allclose(cam.world_from_camera[:3, :3], np.diag([-1.0, 1.0, -1.0]))
    np.testing.assert_allclose(cam.world_from_camera[:3, 3], [0, 0, 4])


def test03_mitsuba_xml(write):
    """Mitsuba's view is [-1, 1] along camera x scaled by to_world: half_extent 1 along x,
    the scale kept in world_from_camera."""
    scene = glrender.load(write("o.xml", mitsuba_scene('<float name="near_clip" value="0.5"/>')))
    cam = scene.camera
    assert cam.kind == "orthographic" and cam.half_extent == 1.0 and cam.fov_axis == "x"
    assert cam.near_clip == 0.5
    np.testing.assert_allclose(np.linalg.norm(cam.world_from_camera[:3, :3], axis=0), [2, 3, 1])


BAD = [
    ("toml", toml_scene('kind = "fisheye"'), "camera.kind: expected one of 'perspective', 'orthographic'"),
    ("toml", toml_scene('kind = "orthographic"\nhalf_extent = 0'), "camera.half_extent: expected a positive length, got 0"),
    ("toml", toml_scene('kind = "orthographic"\nhalf_extent = -1'), "camera.half_extent: expected a number in [0, inf]"),
    ("toml", toml_scene('kind = "orthographic"\nhalf_extent = "wide"'), "camera.half_extent: expected a number"),
    ("toml", toml_scene('kind = "orthographic"\nfov = 30'), "camera.fov: an orthographic camera has no fov"),
    ("toml", toml_scene('kind = "orthographic"\naperture_radius = 0.1'), "camera.aperture_radius: an orthographic camera has no aperture_radius: it has no lens"),
    ("toml", toml_scene("half_extent = 2"), "camera.half_extent: a perspective camera has no half_extent"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 0, "znear": 0, "zfar": 9}}),
     "cameras[0].orthographic.ymag: expected a positive half width, got 0.0"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": -1, "ymag": 1, "znear": 0, "zfar": 9}}),
     "cameras[0].orthographic.xmag: expected a positive half width, got -1.0"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0}}),
     "cameras[0].orthographic.zfar: missing"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 2, "zfar": 1}}),
     "cameras[0].orthographic.zfar: expected a distance above znear (2.0), got 1.0"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": -1, "zfar": 1}}),
     "cameras[0].orthographic.znear: expected a distance >= 0, got -1.0"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": "1", "ymag": 1, "znear": 0, "zfar": 1}}),
     "cameras[0].orthographic.xmag: expected 1 finite numbers"),
    ("gltf", gltf_scene({"type": "orthographic", "orthographic": {"xmag": 100, "ymag": 1, "znear": 0, "zfar": 1}}),
     "cameras[0].orthographic.xmag: xmag / ymag = 100: expected an aspect ratio in (0.05, 20)"),
    ("xml", mitsuba_scene('<float name="fov" value="30"/>'), "an orthographic sensor has no fov"),
    ("xml", mitsuba_scene('<float name="aperture_radius" value="0.1"/>'), "an orthographic sensor has no aperture_radius"),
    ("xml", mitsuba_scene("", '<scale x="0"/>'), "an orthographic sensor needs an invertible transform"),
]


@pytest.mark.parametrize("ext, text, message", BAD, ids=[f"{e}-{i}" for i, (e, _, _) in enumerate(BAD)])
def test04_bad_values_are_refused_by_field(write, ext, text, message):
    path = write(f"bad.{ext}", text)
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    assert message in str(info.value) and str(path) in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("index", [2, 8, 14], ids=["toml", "gltf", "xml"])
def test05_command_line_says_it_in_one_line(write, tmp_path, index):
    ext, text, message = BAD[index]
    path = write(f"bad.{ext}", text)
    line = one_error_line(glrender_cli("render", path, "-o", tmp_path / "o.pfm", "--spp", 1))
    assert message in line and str(path) in line


def test06_model_refuses_a_lens_and_bad_sizes():
    with pytest.raises(SceneError, match="an orthographic camera has no lens, but aperture_radius is 0.5"):
        m.Camera(kind="orthographic", aperture_radius=0.5)
    with pytest.raises(SceneError, match="camera.half_extent: expected a positive length, got nan"):
        m.Camera(kind="orthographic", half_extent=math.nan)
    with pytest.raises(SceneError, match="camera.kind: expected perspective or orthographic"):
        m.Camera(kind="fisheye")
