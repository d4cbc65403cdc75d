"""Instanced meshes from every format: TOML ``instances`` (transforms inline or a .npy file
of 4x4 matrices), Mitsuba 3 ``shapegroup``/``instance`` and glTF nodes sharing a mesh
(tests/scene/test_gltf.py) load as one shape with its copies' transforms; bad input is one
line naming the file, the field and what was expected."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m

PLY = Path(__file__).resolve().parents[2] / "scenes" / "sample-ply" / "bunny_lowres.ply"

TOML = """
[camera]
look_at = {{ origin = [0, -6, 3], target = [0, 0, 0], up = [0, 0, 1] }}
[materials.white]
reflectance = 0.5
[[lights]]
type = "constant"
[[shapes]]
type = "mesh"
file = "{ply}"
material = "white"
transform = {{ scale = 2 }}
instances = {instances}
"""


def test01_toml_inline_and_npy(write):
    inline = '[[{ translate = [1, 0, 0] }, { rotate = { axis = [0, 0, 1], angle = 90 } }], ' \
             '[1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]]'
    write("bunny.ply", PLY.read_bytes())
    scene = glrender.load(write("a.toml", TOML.format(ply="bunny.ply", instances=inline)))
    (shape,) = scene.shapes
    assert shape.instances.shape == (2, 4, 4)
    np.testing.assert_allclose(shape.instances[0], m.rotate((0, 0, 1), 90) @ m.translate((1, 0, 0)))
    np.testing.assert_allclose(shape.instances[1][:3, 3], [5, 0, 0])
    np.testing.assert_allclose(shape.world_from_object, m.scale(2.0))
    transforms = np.stack([m.translate((k, 0, 0)) for k in range(12)]).astype(np.float32)
    np.save(write("t.npy", b"").parent / "t.npy", transforms)
    scene = glrender.load(write("b.toml", TOML.format(ply="bunny.ply", instances='"t.npy"')))
    np.testing.assert_array_equal(scene.shapes[0].instances, transforms)


@pytest.mark.parametrize("instances, data, message", [
    ('"t.npy"', np.zeros((3, 3, 3)), "expected K row-major 4x4 matrices"),
    ('"t.npy"', np.zeros((2, 4, 4)), "matrix 0 is not finite with last row (0, 0, 0, 1)"),
    ('"t.npy"', b"not an array", "cannot read 't.npy' as a numpy array"),
    ('"t.txt"', b"", "expected a .npy file of 4x4 matrices"),
    ('"missing.npy"', None, "no such file"),
    ('[]', None, "expected an array of transforms or a .npy file name"),
    ('[[1, 2, 3]]', None, "expected 16 numbers"),
])
def test02_toml_bad_instances(write, instances, data, message):
    write("bunny.ply", PLY.read_bytes())
    if isinstance(data, np.ndarray):
        np.save(write("t.npy", b"").parent / "t.npy", data)
    elif data is not None:
        write("t.npy" if "npy" in instances else "t.txt", data)
    path = write("a.toml", TOML.format(ply="bunny.ply", instances=instances))
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    text = str(info.value)
    assert text.startswith(str(path)) and "shapes[0].instances" in text and message in text, text


def test03_toml_instances_of_a_sphere_are_refused(write):
    text = TOML.format(ply="x", instances="[[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]]")
    text = text.replace('type = "mesh"\nfile = "x"', 'type = "sphere"')
    with pytest.raises(SceneError, match="only meshes are instanced"):
        glrender.load(write("a.toml", text))


XML = """<scene version="3.0.0">
  <shape type="shapegroup" id="group">
    <shape type="ply">
      <string name="filename" value="bunny.ply"/>
      <transform name="to_world"><scale value="2"/></transform>
    </shape>
    <shape type="sphere"><float name="radius" value="0.1"/></shape>
  </shape>
  {instances}
  <emitter type="constant"/>
</scene>
"""


def test04_mitsuba_shapegroup_and_instance(write):
    write("bunny.ply", PLY.read_bytes())
    body = "\n".join(f'<shape type="instance"><ref id="group"/><transform name="to_world">'
                     f'<translate x="{k}"/></transform></shape>' for k in range(3))
    scene = glrender.load(write("s.xml", XML.format(instances=body)))
    meshes = [s for s in scene.shapes if s.kind == "mesh"]
    spheres = [s for s in scene.shapes if s.kind == "sphere"]
    (mesh,) = meshes
    assert len(spheres) == 3                 # other shapes: one per instance
    np.testing.assert_allclose(mesh.instances[:, 0, 3], [0, 1, 2])
    np.testing.assert_allclose(mesh.world_from_object, m.scale(2.0))
    np.testing.assert_allclose(sorted(s.world_from_object[0, 3] for s in spheres), [0, 1, 2])
    # a group nothing places draws nothing
    scene = glrender.load(write("t.xml", XML.format(instances="")))
    assert not any(s.kind == "mesh" for s in scene.shapes)


def test05_mitsuba_instance_needs_a_shapegroup(write):
    write("bunny.ply", PLY.read_bytes())
    body = '<shape type="instance"><transform name="to_world"><translate x="1"/></transform></shape>'
    with pytest.raises(SceneError, match="expected one shapegroup"):
        glrender.load(write("s.xml", XML.format(instances=body)))
