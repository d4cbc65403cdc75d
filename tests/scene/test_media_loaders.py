"""Participating media in every scene format that has them: Mitsuba's ``<medium>`` (nested in
shapes and sensors or referenced by id, homogeneous and heterogeneous, phase functions,
constvolume and gridvolume with to_world and use_grid_bbox), the TOML ``[media.NAME]`` tables
(with the sigma_a / sigma_s form) and glTF's KHR_materials_volume; every bad value refused
in one line naming the file and its line or field, through the API and on the command line.
Loading only: nothing here renders a medium."""
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m
from glrender.scene.loaders.volumes import write_vol

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from cli_run import glrender as glrender_cli, one_error_line  # noqa: E402
from test_hostile_inputs import gltf_doc  # noqa: E402


def xml(body: str) -> str:
    """A Mitsuba scene around ``body``, which starts on line 2."""
    return f'<scene version="3.0.0">\n{body}\n<emitter type="constant"/>\n</scene>\n'


def toml(media: str, shape: str = "", camera: str = "") -> str:
    """A TOML scene with ``media`` tables, a null-bounded cube (``shape``: its extra keys)
    and ``camera`` keys."""
    return (f'{media}\n[materials.boundary]\ntype = "null"\n[[shapes]]\ntype = "cube"\n'
            f'material = "boundary"\n{shape}\n[camera]\n{camera}\n[[lights]]\ntype = "constant"\n')


GRID = np.arange(24, dtype=np.float32).reshape(2, 3, 4) / 24     # (Z, Y, X), values in [0, 1)
BOX = ((-1.0, 0.0, -1.0), (1.0, 2.0, 1.0))


def _by_name(scene: m.Scene) -> dict[str, m.Medium]:
    return {medium.name: medium for medium in scene.media}


# -- Mitsuba XML ---------------------------------------------------------------------------------
def test01_xml_defaults_are_mitsubas(write):
    path = write("s.xml", xml('<shape type="sphere"><bsdf type="null"/>'
                              '<medium type="homogeneous" name="interior"/></shape>'))
    scene = glrender.load(path)
    (medium,) = scene.media
    assert (medium.kind, medium.sigma_t, medium.albedo, medium.scale) == (
        "homogeneous", (1.0, 1.0, 1.0), (0.75, 0.75, 0.75), 1.0)
    assert (medium.phase, medium.sample_emitters) == ("isotropic", True)
    shape = scene.shapes[0]
    assert (shape.interior, shape.exterior) == (0, None)
    assert scene.materials[shape.material].kind == "null"
    assert scene.camera.medium is None


def test02_xml_values_references_and_the_sensor(write):
    path = write("s.xml", xml("""
    <medium type="homogeneous" id="fog">
        <rgb name="sigma_t" value="0.1, 0.2, 0.3"/>
        <spectrum name="albedo" value="0.9"/>
        <float name="scale" value="2"/>
        <boolean name="sample_emitters" value="false"/>
        <phase type="hg"><float name="g" value="-0.3"/></phase>
    </medium>
    <shape type="cube"><ref name="exterior" id="fog"/>
        <medium type="homogeneous" name="interior" id="milk"><phase type="hg"/></medium></shape>
    <shape type="sphere"><ref name="interior" id="fog"/></shape>
    <sensor type="perspective"><ref id="fog"/></sensor>"""))
    scene = glrender.load(path)
    media = _by_name(scene)
    assert sorted(media) == ["fog", "milk"]                  # one medium however often referred to
    fog = media["fog"]
    assert (fog.sigma_t, fog.albedo, fog.scale, fog.sample_emitters) == (
        (0.1, 0.2, 0.3), (0.9, 0.9, 0.9), 2.0, False)
    assert (fog.phase, fog.g) == ("hg", -0.3)
    assert (media["milk"].phase, media["milk"].g) == ("hg", 0.8)   # Mitsuba's default g
    index = scene.media.index(fog)
    cube, sphere = scene.shapes
    assert (cube.interior, cube.exterior) == (scene.media.index(media["milk"]), index)
    assert (sphere.interior, sphere.exterior) == (index, None)
    assert scene.camera.medium == index


def test03_xml_nested_sensor_medium(write):
    path = write("s.xml", xml('<sensor type="perspective"><medium type="homogeneous">'
                              '<float name="sigma_t" value="3"/></medium></sensor>'
                              '<shape type="sphere"/>'))
    scene = glrender.load(path)
    assert scene.camera.medium == 0 and scene.media[0].sigma_t == (3.0, 3.0, 3.0)


@pytest.mark.parametrize("use_grid_bbox", [False, True])
def test04_xml_gridvolume(write, tmp_path, use_grid_bbox):
    write_vol(tmp_path / "smoke.vol", GRID, BOX)
    albedo = np.full((1, 2, 2, 3), [0.2, 0.4, 0.6], np.float32)
    np.save(tmp_path / "albedo.npy", albedo)
    path = write("s.xml", xml(f"""
    <medium type="heterogeneous" id="smoke">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="smoke.vol"/>
            <boolean name="use_grid_bbox" value="{str(use_grid_bbox).lower()}"/>
            <string name="filter_type" value="nearest"/>
            <transform name="to_world"><scale value="2"/><translate value="0, 1, 0"/></transform>
        </volume>
        <volume type="gridvolume" name="albedo"><string name="filename" value="albedo.npy"/></volume>
        <float name="scale" value="50"/>
    </medium>
    <shape type="cube"><bsdf type="null"/><ref name="interior" id="smoke"/></shape>"""))
    scene = glrender.load(path)
    (smoke,) = scene.media
    assert smoke.kind == "heterogeneous" and smoke.scale == 50.0
    sigma_t = smoke.sigma_t
    np.testing.assert_array_equal(sigma_t.data, GRID[..., None])
    assert sigma_t.filter == "nearest" and sigma_t.resolution == (4, 3, 2)
    to_world = m.translate((0, 1, 0)) @ m.scale(2)            # Mitsuba: scale first, then translate
    expected = to_world @ m.translate(BOX[0]) @ m.scale(np.subtract(BOX[1], BOX[0])) \
        if use_grid_bbox else to_world
    np.testing.assert_allclose(sigma_t.world_from_object, expected)
    np.testing.assert_array_equal(smoke.albedo.data, albedo)
    assert smoke.albedo.filter == "trilinear"
    np.testing.assert_array_equal(smoke.albedo.world_from_object, np.eye(4))


def test05_xml_constant_volumes(write):
    path = write("s.xml", xml("""
    <shape type="sphere"><medium type="homogeneous" name="interior">
        <volume type="constvolume" name="albedo"><rgb name="value" value="0.1, 0.2, 0.3"/></volume>
    </medium></shape>
    <shape type="cube"><medium type="heterogeneous" name="interior">
        <float name="sigma_t" value="4"/></medium></shape>
    <shape type="cube"><medium type="heterogeneous" name="interior">
        <volume type="constvolume" name="sigma_t"><rgb name="value" value="1, 2, 3"/>
            <transform name="to_world"><translate value="5, 0, 0"/></transform></volume>
    </medium></shape>"""))
    homogeneous, plain, placed = glrender.load(path).media
    assert homogeneous.albedo == (0.1, 0.2, 0.3) and homogeneous.sigma_t == (1.0, 1.0, 1.0)
    # Mitsuba's constvolume: constant over the unit cube its to_world places, which bounds
    # a heterogeneous medium: a one-voxel grid here
    assert plain.sigma_t.data.shape == (1, 1, 1, 1) and plain.sigma_t.data[0, 0, 0, 0] == 4.0
    np.testing.assert_array_equal(plain.sigma_t.world_from_object, np.eye(4))
    np.testing.assert_array_equal(placed.sigma_t.data.reshape(-1), [1, 2, 3])
    np.testing.assert_array_equal(placed.sigma_t.world_from_object, m.translate((5, 0, 0)))
    assert plain.albedo == (0.75, 0.75, 0.75)


def test06_xml_what_is_ignored_is_listed(write, tmp_path, caught):
    write_vol(tmp_path / "g.vol", GRID)
    path = write("s.xml", xml("""<medium type="homogeneous" id="unused"/>
    <shape type="sphere"><medium type="homogeneous"/></shape>
    <emitter type="point"><medium type="homogeneous"/></emitter>
    <shape type="cube"><medium type="heterogeneous" name="interior"><volume type="gridvolume" name="sigma_t">
        <string name="filename" value="g.vol"/><string name="wrap_mode" value="repeat"/></volume></medium></shape>"""))
    with caught as messages:
        scene = glrender.load(path)
    (note,) = [w for w in messages if "unsupported Mitsuba features" in w]
    assert "medium 'unused' (not used by any shape or sensor) (line 2)" in note
    assert "a medium in a shape named neither interior nor exterior (line 3)" in note
    assert "a medium inside an emitter (line 4)" in note
    assert "gridvolume wrap_mode 'repeat' (clamp used) (line 5)" in note
    assert len(scene.media) == 1 and scene.shapes[0].interior is None


# -- TOML ----------------------------------------------------------------------------------------
def test07_toml_media(write, tmp_path):
    write_vol(tmp_path / "smoke.vol", GRID, BOX)
    path = write("s.toml", toml("""
[media.fog]
sigma_t = [0.1, 0.2, 0.3]
albedo = 0.9
scale = 2
sample_emitters = false
phase = { type = "hg", g = 0.7 }

[media.milk]
phase = "hg"

[media.smoke]
type = "heterogeneous"
sigma_t = { file = "smoke.vol", transform = [{ scale = 2 }, { translate = [0, 1, 0] }], filter = "nearest", use_grid_bbox = true }
albedo = 0.5
""", shape='interior = "smoke"\nexterior = "fog"', camera='medium = "milk"'))
    scene = glrender.load(path)
    media = _by_name(scene)
    fog, milk, smoke = media["fog"], media["milk"], media["smoke"]
    assert (fog.kind, fog.sigma_t, fog.albedo, fog.scale, fog.sample_emitters, fog.phase, fog.g) == (
        "homogeneous", (0.1, 0.2, 0.3), (0.9, 0.9, 0.9), 2.0, False, "hg", 0.7)
    assert (milk.sigma_t, milk.albedo, milk.phase, milk.g) == ((1.0,) * 3, (0.75,) * 3, "hg", 0.8)
    assert smoke.kind == "heterogeneous" and smoke.albedo == (0.5, 0.5, 0.5)
    np.testing.assert_array_equal(smoke.sigma_t.data, GRID[..., None])
    np.testing.assert_allclose(smoke.sigma_t.world_from_object, m.translate((0, 1, 0)) @ m.scale(2)
                               @ m.translate(BOX[0]) @ m.scale((2, 2, 2)))
    assert smoke.sigma_t.filter == "nearest"
    shape = scene.shapes[0]
    assert scene.media[shape.interior] is smoke and scene.media[shape.exterior] is fog
    assert scene.media[scene.camera.medium] is milk
    assert scene.materials[shape.material].kind == "null"


@pytest.mark.parametrize("fields, sigma_t, albedo", [
    ("sigma_a = 0.1\nsigma_s = 0.3", (0.4,) * 3, (0.75,) * 3),
    ("sigma_a = [0.1, 0, 0]\nsigma_s = [0.3, 0, 0.5]", (0.4, 0.0, 0.5), (0.75, 0.0, 1.0)),
    ("sigma_a = [1, 2, 3]", (1.0, 2.0, 3.0), (0.0, 0.0, 0.0)),
    ("sigma_s = 2", (2.0,) * 3, (1.0,) * 3),
])
def test08_toml_absorption_and_scattering(write, fields, sigma_t, albedo):
    scene = glrender.load(write("s.toml", toml(f"[media.m]\n{fields}", shape='interior = "m"')))
    medium = scene.media[0]
    assert medium.sigma_t == pytest.approx(sigma_t) and medium.albedo == pytest.approx(albedo)


def test09_toml_npy_albedo_grid_in_a_homogeneous_medium(write, tmp_path):
    np.save(tmp_path / "a.npy", np.full((2, 2, 2, 3), 0.5))
    scene = glrender.load(write("s.toml", toml('[media.m]\nalbedo = { file = "a.npy" }',
                                               shape='interior = "m"')))
    albedo = scene.media[0].albedo
    assert isinstance(albedo, m.Volume) and albedo.data.shape == (2, 2, 2, 3)


# -- glTF ----------------------------------------------------------------------------------------
def _gltf(material: dict) -> str:
    doc = gltf_doc()
    doc["materials"] = [material]
    doc["nodes"].append({"mesh": 0, "translation": [0, 0, 2]})     # the mesh twice
    doc["scenes"][0]["nodes"].append(2)
    return json.dumps(doc)


TRANSMISSION = {"KHR_materials_transmission": {"transmissionFactor": 1.0}}


@pytest.mark.parametrize("volume, sigma_t", [
    (None, None),
    ({}, None),                                                 # thicknessFactor 0: thin-walled
    ({"thicknessFactor": 0, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1}, None),
    ({"thicknessFactor": 0.1}, (0.0, 0.0, 0.0)),                # no attenuation: a clear interior
    ({"thicknessFactor": 1, "attenuationColor": [0.5, 0.25, 1], "attenuationDistance": 2},
     (math.log(2) / 2, math.log(4) / 2, 0.0)),
    ({"thicknessFactor": 1, "attenuationColor": [0.5, 0.5, 0.5]}, (0.0, 0.0, 0.0)),  # distance +inf
    ({"thicknessFactor": 1, "attenuationColor": [0, 1, 1], "attenuationDistance": 1},
     (-math.log(np.finfo(np.float32).tiny), 0.0, 0.0)),     # absorbs all red, finitely
])
def test10_gltf_materials_volume(write, volume, sigma_t):
    extensions = dict(TRANSMISSION, **({"KHR_materials_volume": volume} if volume is not None else {}))
    scene = glrender.load(write("s.gltf", _gltf({"name": "glass", "extensions": extensions})))
    (first,) = scene.shapes            # one mesh, two nodes: its instances
    assert len(first.instances) == 2
    if sigma_t is None:
        assert scene.media == [] and first.interior is None
        return
    (medium,) = scene.media
    assert first.interior == 0 and first.exterior is None
    assert medium.kind == "homogeneous" and medium.name == "glass"
    assert medium.sigma_t == pytest.approx(sigma_t) and medium.albedo == (0.0, 0.0, 0.0)
    assert scene.materials[first.material].kind in ("dielectric", "roughdielectric")


def test11_gltf_volume_needs_transmission(write, caught):
    path = write("s.gltf", _gltf({"extensions": {"KHR_materials_volume": {"thicknessFactor": 1}}}))
    with caught as messages:
        scene = glrender.load(path)
    assert scene.media == [] and scene.shapes[0].interior is None
    (note,) = [w for w in messages if "unsupported glTF features" in w]
    assert "KHR_materials_volume without KHR_materials_transmission (no medium)" in note
    assert "extension KHR_materials_volume" not in note


# -- bad input -----------------------------------------------------------------------------------
def _bad_vol_files(tmp_path: Path) -> None:
    write_vol(tmp_path / "ok.vol", GRID)
    write_vol(tmp_path / "six.vol", np.zeros((1, 1, 1, 6)))
    write_vol(tmp_path / "nan.vol", np.full((1, 1, 2), np.nan))
    write_vol(tmp_path / "negative.vol", GRID - 0.5)
    write_vol(tmp_path / "bright.vol", GRID * 2)
    write_vol(tmp_path / "flat.vol", GRID, ((0, 0, 0), (1, 0, 1)))
    (tmp_path / "short.vol").write_bytes((tmp_path / "ok.vol").read_bytes()[:-8])
    (tmp_path / "magic.vol").write_bytes(b"VOX" + (tmp_path / "ok.vol").read_bytes()[3:])
    data = bytearray((tmp_path / "ok.vol").read_bytes())
    data[4:8] = (2).to_bytes(4, "little")
    (tmp_path / "encoding.vol").write_bytes(bytes(data))
    data[4:8], data[20:24] = (1).to_bytes(4, "little"), (2).to_bytes(4, "little")
    (tmp_path / "channels.vol").write_bytes(bytes(data))
    np.save(tmp_path / "nan.npy", np.full((2, 2, 2), np.nan))


def _medium_xml(inner: str = "", kind: str = "homogeneous") -> str:
    return xml(f'<shape type="sphere"><medium type="{kind}" name="interior">{inner}</medium></shape>')


def _grid_xml(file: str, name: str = "sigma_t", extra: str = "") -> str:
    return _medium_xml(f'<volume type="gridvolume" name="{name}"><string name="filename" '
                       f'value="{file}"/>{extra}</volume>', "heterogeneous")


GRIDVOLUME = r'bad\.xml:2: <volume type="gridvolume">: '
BAD = {
    # Mitsuba XML
    "xml unknown medium type": ("xml", _medium_xml(kind="fog"),
                                r'bad\.xml:2: <medium type="fog">: unknown medium type \(expected '
                                r'homogeneous or heterogeneous\)'),
    "xml unknown phase type": ("xml", _medium_xml('<phase type="rayleigh"/>'),
                               r'bad\.xml:2: <phase type="rayleigh">: unsupported phase function '
                               r'\(expected isotropic or hg\)'),
    "xml two phases": ("xml", _medium_xml('<phase type="hg"/><phase type="isotropic"/>'),
                       r"only a single phase function can be specified per medium"),
    "xml g = 1": ("xml", _medium_xml('<phase type="hg"><float name="g" value="1"/></phase>'),
                  r"bad\.xml:2: g: expected a mean cosine in \(-1, 1\), got 1$"),
    "xml g = -1.5": ("xml", _medium_xml('<phase type="hg"><float name="g" value="-1.5"/></phase>'),
                     r"bad\.xml:2: g: expected a mean cosine in \(-1, 1\), got -1\.5$"),
    "xml negative sigma_t": ("xml", _medium_xml('<rgb name="sigma_t" value="1, -1, 1"/>'),
                             r"bad\.xml:2: sigma_t: expected finite non-negative numbers, got "
                             r"\[1\.0, -1\.0, 1\.0\]"),
    "xml albedo above 1": ("xml", _medium_xml('<float name="albedo" value="1.5"/>'),
                           r"bad\.xml:2: albedo: expected numbers in \[0, 1\], got \[1\.5, 1\.5, 1\.5\]"),
    "xml negative scale": ("xml", _medium_xml('<float name="scale" value="-2"/>'),
                           r"bad\.xml:2: scale: expected a finite number >= 0, got -2"),
    "xml undefined medium": ("xml", xml('<shape type="sphere"><ref name="interior" id="fog"/></shape>'),
                             r'bad\.xml:2: <ref id="fog"> refers to an undefined id'),
    "xml two interiors": ("xml", xml('<shape type="sphere"><medium type="homogeneous" name="interior"/>'
                                     '<medium type="homogeneous" name="interior"/></shape>'),
                          r'<shape type="sphere">: only a single interior medium can be specified '
                          r'per shape'),
    "xml grid in a homogeneous medium": ("xml", _medium_xml(
        '<volume type="gridvolume" name="sigma_t"><string name="filename" value="ok.vol"/></volume>'),
        GRIDVOLUME + r'a homogeneous medium\'s sigma_t is a constant'),
    "xml unknown volume type": ("xml", _medium_xml('<volume type="vdb" name="albedo"/>'),
                                r'bad\.xml:2: <volume type="vdb">: unknown volume type \(expected '
                                r'constvolume or gridvolume\)'),
    "xml constvolume albedo above 1": ("xml", _medium_xml(
        '<volume type="constvolume" name="albedo"><float name="value" value="2"/></volume>'),
        r'<volume type="constvolume">: albedo value: expected numbers in \[0, 1\]'),
    "xml missing grid file": ("xml", _grid_xml("no.vol"),
                              r"bad\.xml:2: volume file 'no\.vol' not found"),
    "xml grid outside the folder": ("xml", _grid_xml("/etc/passwd"),
                                    r"bad\.xml:2: volume file '/etc/passwd' resolves to /etc/passwd, "
                                    r"outside the scene's folder .*: refused"),
    "xml truncated vol": ("xml", _grid_xml("short.vol"),
                          GRIDVOLUME + r"volume file 'short\.vol': the header declares 4 x 3 x 2 "
                          r"voxels of 1 channel \(96 bytes of float32\), the file has 88 bytes "
                          r"after the header \(truncated\)$"),
    "xml wrong magic": ("xml", _grid_xml("magic.vol"),
                        GRIDVOLUME + r"volume file 'magic\.vol': not a Mitsuba volume file"),
    "xml unsupported encoding": ("xml", _grid_xml("encoding.vol"),
                                 GRIDVOLUME + r"volume file 'encoding\.vol': encoding 2 is not "
                                 r"supported \(only 1, float32\)"),
    "xml 2 channels": ("xml", _grid_xml("channels.vol"),
                       GRIDVOLUME + r"volume file 'channels\.vol': 2 channels: expected 1, 3 or 6"),
    "xml 6 channels for sigma_t": ("xml", _grid_xml("six.vol"),
                                   GRIDVOLUME + r"sigma_t from 'six\.vol': a grid of 6 channels: "
                                   r"sigma_t takes 1 \(grey\) or 3 \(RGB\)"),
    "xml NaN grid": ("xml", _grid_xml("nan.vol"),
                     GRIDVOLUME + r"sigma_t from 'nan\.vol': the grid holds NaN or infinite values"),
    "xml negative grid": ("xml", _grid_xml("negative.vol"),
                          GRIDVOLUME + r"sigma_t from 'negative\.vol': the grid's values lie in "
                          r"\[-0\.5, 0\.458333\]: sigma_t takes finite non-negative numbers"),
    "xml albedo grid above 1": ("xml", _grid_xml("bright.vol", "albedo"),
                                GRIDVOLUME + r"albedo from 'bright\.vol': the grid's values lie in "
                                r"\[0, 1\.91667\]: albedo takes numbers in \[0, 1\]"),
    "xml empty grid box": ("xml", _grid_xml("flat.vol", extra='<boolean name="use_grid_bbox" value="true"/>'),
                           GRIDVOLUME + r"use_grid_bbox: the file's bounding box \[0, 0, 0\] - "
                           r"\[1, 0, 1\] is empty or not finite"),
    "xml two sensor media": ("xml", xml('<shape type="sphere"/><sensor type="perspective">'
                                        '<medium type="homogeneous"/><medium type="homogeneous"/></sensor>'),
                             r'bad\.xml:2: <sensor type="perspective">: only a single medium can be '
                             r'specified per sensor'),
    # TOML
    "toml unknown medium type": ("toml", toml('[media.m]\ntype = "fog"'),
                                 r"bad\.toml: media\.m\.type: expected one of 'homogeneous', "
                                 r"'heterogeneous', got \"fog\""),
    "toml unknown phase type": ("toml", toml('[media.m]\nphase = "rayleigh"'),
                                r"bad\.toml: media\.m\.phase\.type: expected one of 'isotropic', "
                                r"'hg', got \"rayleigh\""),
    "toml g = 1": ("toml", toml('[media.m]\nphase = { type = "hg", g = 1.0 }'),
                   r"bad\.toml: media\.m\.phase\.g: expected a mean cosine in \(-1, 1\), got 1$"),
    "toml g on isotropic": ("toml", toml('[media.m]\nphase = { type = "isotropic", g = 0.5 }'),
                            r"media\.m\.phase\.g: an isotropic phase function has no g"),
    "toml negative sigma_t": ("toml", toml("[media.m]\nsigma_t = [1, -1, 1]"),
                              r"bad\.toml: media\.m\.sigma_t: expected finite non-negative numbers"),
    "toml NaN sigma_t": ("toml", toml("[media.m]\nsigma_t = nan"),
                         r"bad\.toml: media\.m\.sigma_t: expected a number, got nan"),
    "toml albedo above 1": ("toml", toml("[media.m]\nalbedo = [0.5, 2, 0.5]"),
                            r"bad\.toml: media\.m\.albedo: expected numbers in \[0, 1\], got "
                            r"\[0\.5, 2\.0, 0\.5\]"),
    "toml negative scale": ("toml", toml("[media.m]\nscale = -1"),
                            r"bad\.toml: media\.m\.scale: expected a finite number >= 0, got -1"),
    "toml negative sigma_a": ("toml", toml("[media.m]\nsigma_a = -1"),
                              r"bad\.toml: media\.m\.sigma_a: expected finite non-negative numbers"),
    "toml sigma_a with sigma_t": ("toml", toml("[media.m]\nsigma_a = 1\nsigma_t = 2"),
                                  r"bad\.toml: media\.m\.sigma_t: give sigma_t and albedo, or "
                                  r"sigma_a and sigma_s, not both"),
    "toml unknown medium field": ("toml", toml("[media.m]\ndensity = 1"),
                                  r"bad\.toml: media\.m\.density: unknown field"),
    "toml undefined interior": ("toml", toml("[media.m]", shape='interior = "fog"'),
                                r"bad\.toml: shapes\[0\]\.interior: no medium named 'fog' "
                                r"\(defined: m\)"),
    "toml undefined camera medium": ("toml", toml("", camera='medium = "fog"'),
                                     r"bad\.toml: camera\.medium: no medium named 'fog' \(defined: none\)"),
    "toml heterogeneous constant": ("toml", toml('[media.m]\ntype = "heterogeneous"\nsigma_t = 1'),
                                    r"bad\.toml: media\.m\.sigma_t: a heterogeneous medium's sigma_t "
                                    r"is a grid: expected \{ file = \.\.\. \}, got 1"),
    "toml homogeneous grid": ("toml", toml('[media.m]\nsigma_t = { file = "ok.vol" }'),
                              r"bad\.toml: media\.m\.sigma_t: a homogeneous medium's sigma_t is a "
                              r"constant"),
    "toml NaN grid": ("toml", toml('[media.m]\ntype = "heterogeneous"\nsigma_t = { file = "nan.npy" }'),
                      r"bad\.toml: media\.m\.sigma_t\.file: volume 'nan\.npy': the grid holds NaN "
                      r"or infinite values"),
    "toml truncated vol": ("toml", toml('[media.m]\ntype = "heterogeneous"\nsigma_t = { file = "short.vol" }'),
                           r"bad\.toml: media\.m\.sigma_t\.file: volume 'short\.vol': the header "
                           r"declares 4 x 3 x 2 voxels"),
    "toml unknown grid field": ("toml", toml('[media.m]\nalbedo = { file = "ok.vol", wrap = "repeat" }'),
                                r"bad\.toml: media\.m\.albedo\.wrap: unknown field"),
    "toml grid outside the folder": ("toml", toml('[media.m]\nalbedo = { file = "../x.vol" }'),
                                     r"bad\.toml: media\.m\.albedo\.file: file '\.\./x\.vol' "
                                     r"resolves to \S+, outside the scene's folder"),
    "toml missing grid file": ("toml", toml('[media.m]\nalbedo = { file = "no.vol" }'),
                               r"bad\.toml: media\.m\.albedo\.file: no such file 'no\.vol'"),
    # glTF
    "gltf attenuationDistance 0": ("gltf", _gltf({"extensions": dict(TRANSMISSION, KHR_materials_volume={
        "thicknessFactor": 1, "attenuationDistance": 0})}),
        r"bad\.gltf: materials\[0\]\.extensions\.KHR_materials_volume\.attenuationDistance: "
        r"expected a distance > 0, got 0"),
    "gltf attenuationColor above 1": ("gltf", _gltf({"extensions": dict(TRANSMISSION, KHR_materials_volume={
        "thicknessFactor": 1, "attenuationColor": [2, 0, 0]})}),
        r"bad\.gltf: materials\[0\]\.extensions\.KHR_materials_volume\.attenuationColor: "
        r"expected 3 numbers in \[0, 1\], got \[2, 0, 0\]"),
    "gltf negative thickness": ("gltf", _gltf({"extensions": dict(TRANSMISSION, KHR_materials_volume={
        "thicknessFactor": -1})}),
        r"KHR_materials_volume\.thicknessFactor: expected a thickness >= 0, got -1"),
}


@pytest.mark.parametrize("name", list(BAD))
def test12_bad_input_is_one_line_naming_the_cause(write, tmp_path, name):
    ext, text, pattern = BAD[name]
    _bad_vol_files(tmp_path)
    path = write(f"bad.{ext}", text)
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)), message
    assert re.search(pattern, message), message


def test13_command_line_exits_2_with_one_line(write, tmp_path):
    path = write("bad.xml", BAD["xml g = 1"][1])
    line = one_error_line(glrender_cli("render", path, "-o", tmp_path / "o.pfm", "--spp", 1))
    assert line.startswith("glrender: error: ") and str(path) in line
    assert line.endswith(": g: expected a mean cosine in (-1, 1), got 1")
