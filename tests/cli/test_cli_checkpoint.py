"""Checkpoint files: atomic, complete, and refused for another scene or other settings."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from cli_run import CORNELL, glrender, one_error_line
from glrender.render import accum
from glrender.render.checkpoint import FORMAT, load_checkpoint

SMALL = ["--width", 24, "--height", 16, "--spp", 8]


@pytest.fixture
def checkpointed(tmp_path):
    """A finished small render that kept its checkpoint."""
    out, ckpt = tmp_path / "a.npy", tmp_path / "a.ckpt"
    r = glrender("render", CORNELL, "-o", out, *SMALL, "--seed", 4, "--checkpoint", ckpt)
    assert r.returncode == 0, r.stderr
    assert f"checkpoint -> {ckpt}" in r.stderr
    return out, ckpt


def test01_contents(checkpointed):
    out, ckpt = checkpointed
    c = load_checkpoint(ckpt)
    assert c.meta["format"] == FORMAT and c.spp_done == 8 and len(c.fingerprint) == 64
    assert c.settings["sampler"]["seed"] == 4 and c.settings["width"] == 24
    assert c.meta["options"] == {"spp": 8, "seed": 4, "width": 24, "height": 16}
    mean, _, count, _, _ = accum.statistics(c.state["sums"], c.state["squares"])
    np.testing.assert_array_equal(mean.reshape(16, 24, 3), np.load(out))   # the image is the mean
    assert (count == 8).all()                                               # per-pixel sample counts
    assert [p.name for p in ckpt.parent.iterdir() if p.name.startswith(".")] == []  # no temp files


def test02_resume_of_a_finished_render_renders_nothing(checkpointed):
    out, ckpt = checkpointed
    before = np.load(out)
    r = glrender("render", CORNELL, "-o", out, "--checkpoint", ckpt, "--resume")
    assert r.returncode == 0, r.stderr
    assert "no new samples" in r.stderr
    np.testing.assert_array_equal(np.load(out), before)


def test03_other_settings_are_refused(checkpointed):
    out, ckpt = checkpointed
    line = one_error_line(glrender("render", CORNELL, "-o", out, "--checkpoint", ckpt, "--resume",
                                   "--seed", 5, "--max-depth", 3))
    assert "other settings" in line
    assert "sampler.seed 4 there, 5 here" in line and "integrator.max_depth 8 there, 3 here" in line
    assert "without --resume" in line


def test04_another_scene_is_refused(tmp_path):
    scene = tmp_path / "scene.toml"
    shutil.copy(CORNELL, scene)
    out, ckpt = tmp_path / "a.npy", tmp_path / "a.ckpt"
    assert glrender("render", scene, "-o", out, *SMALL, "--checkpoint", ckpt).returncode == 0
    scene.write_text(scene.read_text().replace("0.570068, 0.0430135", "0.570068, 0.0430136"))
    line = one_error_line(glrender("render", scene, "-o", out, "--checkpoint", ckpt, "--resume"))
    assert f"{scene} changed since the checkpoint was written" in line and "without --resume" in line


def test05_broken_checkpoint_is_refused(tmp_path):
    ckpt = tmp_path / "a.ckpt"
    ckpt.write_bytes(b"PK\x03\x04 not really a zip")
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "a.npy", "--checkpoint",
                                   ckpt, "--resume"))
    assert "not a readable glrender checkpoint" in line
    with ckpt.open("wb") as f:
        np.savez(f, meta=np.array('{"format": "something else"}'))
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "a.npy", "--checkpoint",
                                   ckpt, "--resume"))
    assert "not a glrender checkpoint" in line


def test06_a_changed_input_file_is_refused_by_name(tmp_path):
    """The checkpoint records every file the render read: a mesh edited since (even in a way
    that leaves the rendered data equal) is named; the same files in a moved folder resume."""
    folder = tmp_path / "a"
    folder.mkdir()
    scene = folder / "scene.toml"
    scene.write_text(CORNELL.read_text() + '\n[[shapes]]\ntype = "mesh"\nfile = "tri.obj"\n'
                     'material = "white"\n')
    mesh = folder / "tri.obj"
    mesh.write_text("v -0.5 0.5 0\nv 0.5 0.5 0\nv 0 1 0\nf 1 2 3\n")
    out, ckpt = tmp_path / "a.npy", tmp_path / "a.ckpt"
    r = glrender("render", scene, "-o", out, *SMALL, "--checkpoint", ckpt)
    assert r.returncode == 0, r.stderr
    assert sorted(load_checkpoint(ckpt).meta["files"]) == [str(scene), str(mesh)]

    moved = shutil.copytree(folder, tmp_path / "b")
    r = glrender("render", moved / "scene.toml", "-o", out, "--checkpoint", ckpt, "--resume",
                 "--spp", 16)
    assert r.returncode == 0, r.stderr

    mesh.write_text(mesh.read_text() + "# edited\n")
    line = one_error_line(glrender("render", scene, "-o", out, "--checkpoint", ckpt, "--resume"))
    assert f"{mesh} changed since the checkpoint was written" in line


# What a changed scene says it changed: (the edit, the parts named).
CHANGES = [
    ("0.570068, 0.0430135", "0.570068, 0.0430136", "materials"),       # a colour
    ("# ", "#  ", None),                                                # a comment only
]


@pytest.mark.parametrize("old, new, part", CHANGES, ids=["a material", "a comment"])
def test07_a_changed_scene_names_what_differs(tmp_path, old, new, part):
    scene = tmp_path / "scene.toml"
    shutil.copy(CORNELL, scene)
    out, ckpt = tmp_path / "a.npy", tmp_path / "a.ckpt"
    assert glrender("render", scene, "-o", out, *SMALL, "--checkpoint", ckpt).returncode == 0
    assert set(load_checkpoint(ckpt).meta["fingerprint_parts"]) >= {
        "kernel", "materials", "lights", "geometry", "textures", "camera, film and sampler"}
    text = scene.read_text()
    assert old in text
    scene.write_text(text.replace(old, new, 1))
    line = one_error_line(glrender("render", scene, "-o", out, "--checkpoint", ckpt, "--resume"))
    said = f"{scene} changed since the checkpoint was written: "
    said += f"the render's {part} differ;" if part else "the scene as rendered is the same;"
    assert said in line and line.endswith("render without --resume to start afresh"), line
