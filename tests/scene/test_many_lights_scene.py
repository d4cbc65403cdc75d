"""scenes/many-lights, the many-lights benchmark's street at night: what the scene promises
(5,000 lit windows that are quads 0.2 x 0.3, 250 spot and 250 point lights, each kind's
powers log-uniform over three decades, a dim sky) holds in the files as loaded, and
tools/make_many_lights.py makes the same files again. Its TOML and XML give the same image
(tests/scene/test_samples.py, TWINS)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

import glrender

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "scenes" / "many-lights"
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def scene():
    return glrender.load(FOLDER / "scene.toml")


def _powers(scene) -> dict[str, np.ndarray]:
    """Each kind's powers up to a factor common to the kind (luminance; windows: radiance x
    area, lamps: intensity)."""
    windows = []
    for s in scene.shapes:
        if s.emission is not None:
            p = np.c_[s.vertices, np.ones(len(s.vertices))] @ s.world_from_object.T
            area = sum(0.5 * np.linalg.norm(np.cross(p[b, :3] - p[a, :3], p[c, :3] - p[a, :3]))
                       for a, b, c in s.triangles)
            windows.append(area * LUMINANCE @ s.emission.radiance)
    return {"window": np.array(windows),
            **{kind: np.array([LUMINANCE @ lt.intensity for lt in scene.lights if lt.kind == kind])
               for kind in ("spot", "point")}}


def test01_lit_windows_are_5000_quads_of_0_2_by_0_3(scene):
    windows = [s for s in scene.shapes if s.emission is not None]
    assert len(windows) == 5000
    for s in windows:
        assert s.kind == "mesh" and len(s.triangles) == 2 and not s.emission.two_sided
        corners = (np.c_[s.vertices, np.ones(4)] @ s.world_from_object.T)[:, :3]
        sides = sorted(np.linalg.norm(corners[[1, 2, 3, 0]] - corners, axis=1))
        assert np.allclose(sides, [0.2, 0.2, 0.3, 0.3])


def test02_500_lamps_and_a_dim_sky(scene):
    kinds = [lt.kind for lt in scene.lights]
    assert kinds.count("spot") == 250 and kinds.count("point") == 250
    assert kinds.count("constant") == 1 and len(kinds) == 501
    sky = next(lt for lt in scene.lights if lt.kind == "constant")
    assert max(sky.radiance) < 0.01
    # the street lamps shine down
    for lt in scene.lights:
        if lt.kind == "spot":
            axis = lt.world_from_light[:3, :3] @ [0, 0, 1]
            assert np.allclose(axis, [0, -1, 0], atol=1e-9)


@pytest.mark.parametrize("kind", ["window", "spot", "point"])
def test03_powers_are_log_uniform_over_three_decades(scene, kind):
    power = _powers(scene)[kind]
    decades = np.log10(power / power.max())
    assert -3.0 <= decades.min() < -2.95
    # a third in each decade: with 250 lamps, 0.1 is 3.3 standard deviations of a third
    thirds = np.histogram(decades, bins=[-3, -2, -1, 0])[0] / len(power)
    assert np.allclose(thirds, 1 / 3, atol=0.05 if kind == "window" else 0.1)


def test04_the_generator_makes_the_same_files(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("make_many_lights", ROOT / "tools" / "make_many_lights.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)   # its dataclasses look themselves up there
    spec.loader.exec_module(module)
    module.write(tmp_path)
    for name in ("scene.toml", "scene.xml", "window.ply"):
        assert (tmp_path / name).read_bytes() == (FOLDER / name).read_bytes(), name
