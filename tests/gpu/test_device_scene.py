"""The device scene (glrender/gpu/device_scene.py): what of a scene the kernels read, built
once per scene and context, and the light table each render's settings make from it."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from glrender.errors import UsageError
from glrender.gpu import layout
from glrender.gpu.device_scene import DeviceScene
from glrender.sampling.distributions import DistributionPacker
from glrender.scene import model as m

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))
from render_scenes import base  # noqa: E402


def lit_scene(env: bool = True) -> m.Scene:
    """Three emitters of unequal power: a square and a sheared parallelogram (edges not
    orthogonal), a point light, and optionally an environment image."""
    scene = base(16, 16)
    grey = scene.add_material(m.Material("diffuse", reflectance=(0.5, 0.5, 0.5)))
    scene.shapes.append(m.Shape("rectangle", material=grey, emission=m.Emission((4.0, 4.0, 4.0)),
                                world_from_object=m.translate((0.0, 0.0, 2.0))))
    shear = np.eye(4)
    shear[0, 1] = 0.5
    scene.shapes.append(m.Shape("rectangle", material=grey, emission=m.Emission((1.0, 1.0, 1.0)),
                                world_from_object=m.translate((0.0, 3.0, 2.0)) @ shear))
    scene.lights.append(m.Light("point", position=(0.0, 0.0, 5.0), intensity=(2.0, 2.0, 2.0)))
    if env:
        rng = np.random.default_rng(4)
        image = rng.uniform(0.0, 1.0, (8, 16, 3)).astype(np.float32)
        scene.lights.append(m.Light("envmap", image=image))
    return scene


def test01_light_table_follows_the_selection_rule(gl_ctx):
    ds = DeviceScene(gl_ctx, lit_scene())
    try:
        p = ds.packed
        n = len(p.lights)
        assert n == 4 and p.environment
        uniform = ds.light_table("uniform", "area")
        np.testing.assert_array_equal(uniform.lights["selection_pmf"], np.full(n, 1.0 / n, np.float32))
        power = ds.light_table("power", "area")
        pmf = power.lights["selection_pmf"].astype(np.float64)
        np.testing.assert_allclose(pmf, p.light_weights / p.light_weights.sum(), rtol=1e-6)
        assert len(set(np.round(pmf, 6))) > 1, "the lights must differ in power"
        # the power table holds the alias table before the environment's distribution
        expected = DistributionPacker()
        expected.add_alias_table(p.light_weights)
        env_at = expected.add_distribution_2d(ds.env_weights)
        np.testing.assert_array_equal(power.distributions, expected.array())
        assert power.lights[p.environment - 1]["info"][3] == env_at
        # settings never change the device scene's own records
        assert not p.lights["selection_pmf"].any()
    finally:
        ds.release()


def test02_spherical_rectangles_only_for_rectangles(gl_ctx):
    ds = DeviceScene(gl_ctx, lit_scene(env=False))
    try:
        kinds = ds.packed.lights["info"][:, 0]
        area = ds.light_table("uniform", "area").lights["info"][:, 1]
        solid = ds.light_table("uniform", "solid-angle").lights["info"][:, 1]
        parallelograms = np.nonzero(kinds == layout.LIGHT_KINDS["parallelogram"])[0]
        assert len(parallelograms) == 2
        flagged = [i for i in range(len(kinds)) if solid[i] & 2]
        assert flagged == [int(parallelograms[0])], "only the square (orthogonal edges) is flagged"
        assert not (area & 2).any()
        np.testing.assert_array_equal(solid & ~np.uint32(2), area)
    finally:
        ds.release()


def test03_shared_until_the_last_release(gl_ctx):
    ds = DeviceScene(gl_ctx, lit_scene())
    assert ds.env_texture is not None
    assert ds.acquire() is ds and ds.users == 2
    ds.release()
    assert ds.env_texture is not None and ds.users == 1
    ds.bind()                                 # still bindable
    ds.release()
    assert ds.users == 0 and ds.bvh is None
    with pytest.raises(UsageError, match="released"):
        ds.acquire()
