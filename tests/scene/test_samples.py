"""Every scene in scenes/ renders from the command line at 8x8 and 1 spp: exit code 0 and not
all black. That covers the native TOML scenes and the samples of the other formats
(scenes/sample-gltf, -obj, -ply, -mitsuba), so a fresh clone has a working example of each.

A folder's scene files are the files a loader reads (by extension) that no other file of the
same folder names; the files that one names are its parts (meshes, included fragments): the
meshes among them load on their own too, with a default camera and no light."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import glrender

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
LOADABLE = (".toml", ".xml", ".gltf", ".glb", ".obj", ".ply")
MESHES = (".gltf", ".glb", ".obj", ".ply")
# scenes whose own integrator shows nothing at 8x8 and 1 spp, and the options that do
OPTIONS = {
    # lit only through the gap of a door: 1 path-traced sample per pixel finds no light
    "door/scene.toml": ["--integrator", "bdpt"],
    "door/scene.xml": ["--integrator", "bdpt"],
}
# scenes given in two formats: the same scene from either file, and the integrator that
# compares them (bdpt where it can; media render only by the path tracer)
TWINS = [("door/scene.toml", "door/scene.xml", "bdpt"),
         ("cornell-fog/scene.toml", "cornell-fog/scene.xml", "path"),
         ("smoke/scene.toml", "smoke/scene.xml", "path"),
         ("volumetric-caustic/scene.toml", "volumetric-caustic/scene.xml", "path"),
         ("window-fog/scene.toml", "window-fog/scene.xml", "path"),
         ("many-lights/scene.toml", "many-lights/scene.xml", "path")]


def _files() -> tuple[list[Path], list[Path]]:
    scenes, parts = [], []
    for folder in sorted(p for p in SCENES.iterdir() if p.is_dir()):
        files = sorted(p for p in folder.rglob("*") if p.is_file())
        loadable = [p for p in files if p.suffix.lower() in LOADABLE]
        for path in loadable:
            named = any(path.name.encode() in other.read_bytes() for other in files
                        if other != path and other.suffix.lower() in LOADABLE + (".mtl",))
            (parts if named else scenes).append(path)
    return scenes, parts


SCENE_FILES, PARTS = _files()


def _id(path: Path) -> str:
    return path.relative_to(SCENES).as_posix()


def test01_every_folder_has_a_scene_and_every_format_a_sample():
    folders = {p.parent for p in SCENE_FILES}
    assert folders == {p for p in SCENES.iterdir() if p.is_dir()}
    assert {p.suffix for p in SCENE_FILES} >= set(LOADABLE) - {".ply"}
    assert any(p.suffix == ".ply" for p in PARTS if p.parent.name.startswith("sample-"))
    for folder in SCENES.glob("sample-*"):
        assert (folder / "README.md").is_file(), f"{folder.name}: no README.md (origin, licence)"


@pytest.mark.parametrize("path", SCENE_FILES, ids=_id)
def test02_renders_from_the_command_line(path, tmp_path, gl_ctx, monkeypatch):
    from glrender.commands.cli import main

    # the session's context instead of a new one per command (contexts are not released)
    monkeypatch.setattr("glrender.gl.context.create_context", lambda *args, **kwargs: gl_ctx)
    out = tmp_path / "out.npy"
    rc = main(["render", str(path), "--width", "8", "--height", "8", "--spp", "1", "--quiet",
               "-o", str(out), *OPTIONS.get(_id(path), [])])
    assert rc == 0
    image = np.load(out)
    assert image.shape == (8, 8, 3) and np.all(np.isfinite(image))
    assert image.max() > 0, f"{_id(path)}: the 8x8 image is black"


@pytest.mark.parametrize("path", [p for p in PARTS if p.suffix.lower() in MESHES], ids=_id)
def test03_meshes_load_on_their_own(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # no camera, no light
        scene = glrender.load(path)
    assert sum(len(s.triangles) for s in scene.shapes if s.kind == "mesh") > 0


@pytest.mark.parametrize("a,b,integrator", TWINS, ids=[a.split("/")[0] for a, *_ in TWINS])
def test04_a_scene_in_two_formats_is_one_scene(a, b, integrator, gl_ctx):
    """A scene whose folder holds it in glrender's TOML and in Mitsuba's XML (the peers
    render the XML): both load to the same image, bit for bit (32x32, 4 samples of one
    sampler; the XML names the peers' independent one; one light selection: the XML keeps
    Mitsuba's uniform one, where the TOML may ask for another)."""
    images = []
    for name in (a, b):
        scene = glrender.load(SCENES / name)
        scene.film.width = scene.film.height = 32
        images.append(glrender.render(scene, spp=4, integrator=integrator, sampler="sobol", seed=3,
                                      light_selection="uniform", progress=False).mean)
    assert np.array_equal(images[0], images[1]) and images[0].max() > 0
