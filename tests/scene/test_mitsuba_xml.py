"""Mitsuba 3 XML: the Cornell box with includes, defaults and refs; parameters; the
plugin subset; hostile files (entity bombs, include cycles, malformed XML)."""
import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene.loaders.mitsuba_xml import spectrum_to_rgb

from conftest import SCENES

CBOX = SCENES / "mitsuba-cbox" / "cbox-rgb.xml"


def test01_cornell_box_rgb(caught):
    with caught as messages:
        scene = glrender.load(CBOX)
    assert sum(len(s.triangles) for s in scene.shapes) == 38     # SOURCES.md counts
    assert scene.film.width == scene.film.height == 256 and scene.sampler.spp == 256
    assert scene.integrator.max_depth == 6 and scene.film.filter == "box"
    (light,) = [s for s in scene.shapes if s.emission is not None]   # <ref id="area-emitter"/>
    assert light.emission.radiance == (18.387, 10.9873, 2.75357)
    assert light.world_from_object[1, 3] == -0.5
    box = scene.materials[scene.shapes[-1].material]
    assert box.reflectance == (0.45, 0.30, 0.90)
    assert scene.camera.fov == pytest.approx(39.3077) and scene.camera.fov_axis == "smaller"
    np.testing.assert_allclose(scene.camera.world_from_camera[:3, 3], [278, 273, -800])
    assert not [w for w in messages if "no camera" in w or "no lights" in w]


def test02_parameters_override_defaults():
    scene = glrender.load(CBOX, spp="16", res=64, max_depth="3")
    assert scene.sampler.spp == 16 and scene.film.width == 64 and scene.integrator.max_depth == 3


def test02b_integrator_keeps_mitsuba_s_rules(monkeypatch):
    """An imported path integrator uses Mitsuba's roulette rule and depth (5 unless the XML
    says), power heuristic and uniform light selection, whatever glrender's defaults are."""
    from glrender.scene import model as m

    monkeypatch.setattr(m.Integrator, "__init__", _other_defaults(m.Integrator.__init__))
    scene = glrender.load(CBOX)
    i = scene.integrator
    assert (i.rr, i.rr_depth, i.strategy, i.light_selection) == (
        "throughput", 5, "mis-power", "uniform")


def _other_defaults(init):
    def wrapped(self, *args, **kwargs):
        init(self, *args, **{"rr": "fixed:0.5", "rr_depth": 1, "strategy": "mis-balance",
                             "light_selection": "power", **kwargs})
    return wrapped


def _scene(body: str) -> str:
    return f'<scene version="3.0.0">\n{body}\n</scene>\n'


SHAPE = ('<shape type="sphere"><float name="radius" value="1"/>'
         '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>')


def test03_subset_plugins(write):
    path = write("s.xml", _scene("""
    <default name="kind" value="roughconductor"/>
    <bsdf type="$kind" id="metal"><string name="material" value="Au"/><float name="alpha" value="0.2"/>
        <string name="distribution" value="ggx"/></bsdf>
    <bsdf type="twosided" id="ts"><bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
        </bsdf></bsdf>
    <texture type="checkerboard" id="checks"><rgb name="color0" value="1, 0, 0"/>
        <transform name="to_uv"><scale x="4" y="2"/></transform></texture>
    <shape type="rectangle"><ref id="metal"/></shape>
    <shape type="cube"><ref id="ts"/></shape>
    <shape type="disk"><bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
    <emitter type="spot"><float name="cutoff_angle" value="30"/><rgb name="intensity" value="5"/>
        <transform name="to_world"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>
    <emitter type="directional"><vector name="direction" value="0, -1, 0"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
    <sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/>
        <rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter></film>
        <sampler type="multijitter"><integer name="sample_count" value="9"/></sampler></sensor>
    <integrator type="direct"><integer name="emitter_samples" value="2"/><integer name="bsdf_samples" value="0"/></integrator>
    """))
    scene = glrender.load(path)
    metal = scene.materials[scene.shapes[0].material]
    assert metal.kind == "roughconductor" and metal.alpha == (0.2, 0.2) and metal.distribution == "ggx"
    assert metal.eta[0] == pytest.approx(0.14303598)
    plastic = scene.materials[scene.shapes[1].material]
    assert plastic.kind == "roughplastic" and plastic.two_sided and plastic.reflectance == (0.1, 0.2, 0.3)
    disk = scene.shapes[2]
    assert disk.kind == "mesh" and disk.emission.radiance == (2, 2, 2)
    area = 0.5 * np.linalg.norm(np.cross(*(disk.vertices[disk.triangles][:, 1:] -
                                           disk.vertices[disk.triangles][:, :1]).transpose(1, 0, 2)), axis=1).sum()
    assert area == pytest.approx(np.pi, rel=1e-12)          # the tessellation keeps the area
    tex = scene.materials[disk.material].reflectance
    assert tex.kind == "checkerboard" and tex.color0 == (1, 0, 0) and tex.color1 == (0.2, 0.2, 0.2)
    np.testing.assert_allclose(tex.uv_transform, np.diag([4, 2, 1]))
    kinds = [light.kind for light in scene.lights]
    assert kinds == ["spot", "directional", "constant"]
    assert scene.lights[0].beam_width == pytest.approx(22.5)
    assert scene.camera.aperture_radius == 0.1 and scene.film.width == 40 and scene.film.filter == "gaussian"
    assert scene.sampler.kind == "stratified" and scene.sampler.spp == 9
    assert scene.integrator.kind == "direct" and scene.integrator.emitter_samples == 2


def test04_unsupported_plugins_one_warning_with_lines(write, caught):
    path = write("u.xml", _scene(f"""{SHAPE}
    <shape type="hair"/>
    <bsdf type="principled" id="p"/>
    <shape type="sphere"><ref id="p"/></shape>
    <medium type="homogeneous"/>
    <volume type="grid"/>"""))
    with caught as messages:
        scene = glrender.load(path)
    assert len(scene.shapes) == 2
    (note,) = [w for w in messages if "unsupported Mitsuba features" in w]
    assert "shape type 'hair' (line 3)" in note and "bsdf type 'principled' (grey diffuse used) (line 4)" in note
    assert '<medium type="homogeneous"> (line 6)' in note and "line 7" in note
    assert any("no camera" in w for w in messages)


def test05_serialized_meshes_are_a_clear_error(write):
    path = write("z.xml", _scene('<shape type="serialized"><string name="filename" value="a.serialized"/></shape>'))
    with pytest.raises(SceneError, match=r"z\.xml:2: .*serialized meshes are not supported"):
        glrender.load(path)


@pytest.mark.parametrize("body, message", [
    ('<shape type="obj"><string name="filename" value="nothere.obj"/></shape>', r"x\.xml:2: mesh file 'nothere.obj' not found"),
    ('<shape type="sphere"><ref id="nobody"/></shape>', r"undefined id"),
    ('<integer name="x" value="$nope"/>', r"x\.xml:2: unknown parameter \$nope"),
    ('<shape type="sphere"><float name="radius" value="big"/></shape>', r"x\.xml:2: expected numbers"),
    ('<shape type="sphere"><rgb name="radius" value="1"/></shape>', r"radius: expected a <float>"),
    ('<sensor type="perspective"><float name="fov" value="500"/></sensor>' + SHAPE, r"camera.fov"),
    ('<bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/>' + SHAPE, r"id 'a' is already used"),
    ('<shape type="sphere">', r"malformed XML"),
])
def test06_bad_input(write, body, message):
    path = write("x.xml", _scene(body))
    with pytest.raises(SceneError, match=message):
        glrender.load(path)


def test07_entity_bomb_is_refused(write):
    bomb = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
            + "".join(f'<!ENTITY lol{i} "{("&lol" + str(i - 1) + ";") * 10 if i else "&lol;" * 10}">' for i in range(9))
            + ']>\n<scene version="3.0.0"><string name="x" value="&lol8;"/></scene>')
    with pytest.raises(SceneError, match="refused: the XML declares entities"):
        glrender.load(write("bomb.xml", bomb))


def test08_include_cycles_and_depth(write):
    write("a.xml", _scene('<include filename="b.xml"/>'))
    b = write("b.xml", _scene('<include filename="a.xml"/>'))
    with pytest.raises(SceneError, match="include cycle"):
        glrender.load(b)
    for i in range(20):
        write(f"d{i}.xml", _scene(f'<include filename="d{i + 1}.xml"/>' if i < 19 else SHAPE))
    with pytest.raises(SceneError, match="deeper than 16"):
        glrender.load(b.parent / "d0.xml")


def test09_paths_leaving_the_scene_folder_are_refused_unless_allowed(tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "outside.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    path = tmp_path / "scene" / "s.xml"
    path.write_text(_scene('<shape type="obj"><string name="filename" value="../outside.obj"/></shape>' + SHAPE))
    with pytest.raises(SceneError, match=r"s\.xml:2: mesh file '\.\./outside\.obj' resolves to .*"
                                         r"outside the scene's folder .*: refused"):
        glrender.load(path)
    assert len(glrender.load(path, search_path=[tmp_path]).shapes) == 2


def test10_spectra_as_mitsubas_rgb_variants():
    # values printed by Mitsuba 3.9.1 scalar_rgb (mi.traverse) for cbox.xml's spectra; the
    # fit of the CIE curves and the D65 stand-in keep bright channels within 2%
    flat = spectrum_to_rgb([400, 700], [0.78, 0.78], reflectance=True)
    np.testing.assert_allclose(flat, [0.776367, 0.77981, 0.776029], rtol=0.01)
    light = spectrum_to_rgb([400, 500, 600, 700], [0, 8, 15.6, 18.4], reflectance=False)
    np.testing.assert_allclose(light, [20.7108, 10.8546, 2.77115], rtol=0.01)


def test11_focal_length_sets_the_diagonal_field_of_view(write):
    import math

    from glrender.render.renderer import camera_tangents

    path = write("f.xml", _scene('<sensor type="perspective"><string name="focal_length" value="35mm"/>'
                                 '<film type="hdrfilm"><integer name="width" value="300"/>'
                                 '<integer name="height" value="200"/></film></sensor>' + SHAPE))
    scene = glrender.load(path)
    tx, _ = camera_tangents(scene.camera, 300, 200)
    # Mitsuba 3.9.1 (scalar_rgb) reports x_fov = 54.43222427368164 for this sensor
    assert math.degrees(2 * math.atan(tx)) == pytest.approx(54.43222427368164, rel=1e-6)


def test12_default_bsdf_is_black_on_emitters(write):
    """Mitsuba 3 gives a shape without a BSDF a diffuse 0.5, but an emitting one a black
    diffuse (shape.cpp): a light does not reflect unless its BSDF says so."""
    path = write("d.xml", _scene(SHAPE + '<shape type="rectangle"/>'))
    scene = glrender.load(path)
    light, plain = (scene.materials[shape.material] for shape in scene.shapes)
    assert light.kind == "diffuse" and light.reflectance == (0.0, 0.0, 0.0)
    assert plain.kind == "diffuse" and plain.reflectance == (0.5, 0.5, 0.5)


def test12_rotate_takes_the_axis_as_given(write):
    """Mitsuba 3's rotate puts the axis into Rodrigues' formula unnormalised: an axis longer
    than 1 scales and shears too (checked against Mitsuba's ScalarTransform4f.rotate)."""
    path = write("r.xml", _scene('<shape type="sphere"><transform name="to_world">'
                                 '<rotate x="1" y="1" angle="45"/></transform></shape>'))
    (shape,) = glrender.load(path).shapes
    c = s = np.sqrt(0.5)
    expected = [[c + (1 - c), 1 - c, s], [1 - c, c + (1 - c), -s], [-s, s, c]]
    np.testing.assert_allclose(shape.world_from_object[:3, :3], expected, atol=1e-12)
