"""Checkpoints mutated at random, byte by byte and field by field: each one either resumes
or is refused with one line naming the file (a UsageError: exit code 2 on the command line),
through the loader, the job's resume path (check, then restore into a driver) and the
command's check of the options it saved. The same for the cluster's band checkpoints."""
from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import glrender
from glrender.commands.cli import build_parser
from glrender.commands.options import RESUMABLE
from glrender.commands.photon_options import OPTIONS as PHOTON_OPTIONS
from glrender.commands.render import _saved_options
from glrender.drivers import create_driver
from glrender.errors import UsageError
from glrender.render.checkpoint import (band_checkpoint_unit_size, describe_checkpoint,
                                        load_band_checkpoint, load_checkpoint,
                                        restore_checkpoint, save_band_checkpoint)
from glrender.render.job import Job, JobOptions, job_settings, make_driver

CORNELL = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"
FUZZ = settings(max_examples=300, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])

JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats() |
    st.sampled_from([0, 1, -1, 8, 2**31, 2**31 + 1, 65537, "", "a" * 64, "0" * 64]) |
    st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                                max_size=4),
    max_leaves=8)


class Fixture(dict):
    """A fixture's values, shown briefly in Hypothesis' reports."""

    def __repr__(self) -> str:
        return f"<{', '.join(self)}>"


@pytest.fixture(scope="module")
def world(tmp_path_factory, gl_ctx):
    """A real checkpoint of a small render (its bytes, arrays and record), a driver of the
    same settings to resume it into, the arguments of a `glrender render --resume`, and a
    file to write the mutants to."""
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=8, height=16)
    folder = tmp_path_factory.mktemp("fuzz")
    path = folder / "base.ckpt"
    options = dict(spp=4, seed=2, settings={"samples_per_pass": 2}, ctx=gl_ctx)
    with Job(scene, JobOptions(**options, checkpoint=path, keep_checkpoint=True,
                               record={"options": {"spp": 4, "seed": 2, "width": 8,
                                                   "height": 16},
                                       "params": {}, "aov_names": []}),
             create_driver) as job:
        job.run()
    data = path.read_bytes()
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    driver = make_driver(scene, job_settings(scene, JobOptions(**options)), create_driver,
                         ctx=gl_ctx)
    args = build_parser().parse_args(["render", str(CORNELL), "--resume"])
    yield Fixture(bytes=data, arrays=arrays, meta=json.loads(str(arrays["meta"][()])),
                  driver=driver, args=args, mutant=folder / "mutant.ckpt")
    driver.release()


def resume_or_refuse(world, path: Path) -> str:
    """'resumed' or 'refused' (one line naming the file); anything else fails the test."""
    assert isinstance(describe_checkpoint(path), str)
    try:
        ckpt = load_checkpoint(path)
        spp = restore_checkpoint(ckpt, world["driver"])
        _saved_options(world["args"], ckpt, RESUMABLE + PHOTON_OPTIONS)
    except UsageError as exc:
        text = str(exc)
        assert exc.exit_code == 2
        assert text.startswith(f"{path}: ") and "\n" not in text and len(text) < 600, text
        return "refused"
    assert 0 <= spp <= 1 << 31
    film = world["driver"].film()
    assert film.spp == spp and film.mean.shape == (16, 8, 3)
    return "resumed"


def test01_the_base_checkpoint_resumes(world):
    world["mutant"].write_bytes(world["bytes"])
    assert resume_or_refuse(world, world["mutant"]) == "resumed"
    assert describe_checkpoint(world["mutant"]) == "a checkpoint of 4 spp (of 4)"


@FUZZ
@given(edits=st.lists(st.tuples(
    st.one_of(st.integers(0, 700), st.integers(0, 1 << 20), st.integers(-400, -1)),
    st.integers(0, 255)), min_size=1, max_size=6),
    cut=st.one_of(st.none(), st.integers(0, 1 << 20)))
def test02_bytes(world, edits, cut):
    data = bytearray(world["bytes"])
    for position, value in edits:
        data[position % len(data)] = value
    if cut is not None:
        data = data[:cut % (len(data) + 1)]
    world["mutant"].write_bytes(bytes(data))
    resume_or_refuse(world, world["mutant"])


FIELDS = ["format", "version", "fingerprint", "spp_done", "spp_start", "spp_target", "settings",
          "settings.width", "settings.height", "settings.sampler", "rows", "files", "options",
          "params", "aov_names", "device", "scene", *(f"options.{k}" for k in RESUMABLE),
          "options.photons_per_iteration", "options.final_gather"]
ARRAY_NAMES = ["sums", "squares", "aov", "splat", "strategies", "meta"]


def _arrays():
    shapes = st.lists(st.integers(0, 6), max_size=3).map(tuple)
    dtypes = st.sampled_from([np.uint32, np.int32, np.float64, np.uint8, np.bool_, "U3"])
    return st.builds(lambda shape, dtype: np.zeros(shape, dtype), shapes, dtypes)


@FUZZ
@given(changes=st.lists(st.tuples(st.sampled_from(FIELDS), st.one_of(st.just("delete"), JSON)),
                        max_size=4),
       arrays=st.lists(st.tuples(st.sampled_from(ARRAY_NAMES),
                                 st.one_of(st.just("delete"), st.just("resize"), _arrays())),
                       max_size=2))
def test03_fields_and_arrays(world, changes, arrays):
    meta = json.loads(json.dumps(world["meta"]))
    for name, value in changes:
        *parents, key = name.split(".")
        node = meta
        for parent in parents:
            node = node.get(parent) if isinstance(node, dict) else None
        if not isinstance(node, dict):
            continue
        if isinstance(value, str) and value == "delete":
            node.pop(key, None)
        else:
            node[key] = value
    out = dict(world["arrays"])
    out["meta"] = np.array(json.dumps(meta))
    for name, value in arrays:
        if isinstance(value, str) and value == "delete":
            out.pop(name, None)
        elif isinstance(value, str):        # one word more or less
            words = out.get(name, np.zeros(4, np.uint32))
            out[name] = np.resize(words, max(words.size + (1 if words.size % 2 else -1), 0))
        else:
            out[name] = value
    with open(world["mutant"], "wb") as f:
        np.savez(f, **out)
    resume_or_refuse(world, world["mutant"])


def test04_known_refusals(world):
    """The issue's cases: a negative and a huge sample count, refused by name."""
    for value, shown in ((-5, "-5"), (1e30, "1e+30"), (2**40, str(2**40)), (True, "true")):
        meta = dict(world["meta"], spp_done=value)
        with open(world["mutant"], "wb") as f:
            np.savez(f, **dict(world["arrays"], meta=np.array(json.dumps(meta))))
        with pytest.raises(UsageError, match=rf"the checkpoint's spp_done is {re.escape(shown)}, "
                                                 rf"expected"):
            load_checkpoint(world["mutant"])


# -- the cluster's band checkpoints ---------------------------------------------------------
@pytest.fixture(scope="module")
def bands(tmp_path_factory):
    """A band checkpoint of two of the three bands of a 16x20 plan at 32 spp (with AOVs),
    its bytes, and the plan's layout to check it against."""
    from glrender.distributed.merge import Partial, band_layout
    from glrender.distributed.plan import Plan

    plan = Plan(16, 20, 32, 16 * 8 * 32, frames=(None,))
    assert len(plan.bands) == 3
    parts = {}
    for band in (0, 2):
        layout = band_layout(plan, None, band, aovs=True)
        parts[(None, band)] = Partial(*(np.full(layout[k], band + 1, np.uint32)
                                        for k in ("sums", "squares", "aov")), (0, 32))
    path = tmp_path_factory.mktemp("bands") / "bands.ckpt"
    save_band_checkpoint(path, {"job": "j", "plan": plan.record()}, parts)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    return Fixture(bytes=path.read_bytes(), arrays=arrays, path=path,
                   meta=json.loads(str(arrays["meta"][()])), make=Partial,
                   expect=lambda frame, band: band_layout(plan, frame, band, aovs=True))


def bands_or_refuse(bands, path: Path) -> str:
    try:
        band_checkpoint_unit_size(path)
        got = load_band_checkpoint(path, "j", bands["make"], bands["expect"])
    except UsageError as exc:
        text = str(exc)
        assert text.startswith(f"{path}: ") and "\n" not in text and len(text) < 600, text
        return "refused"
    for (frame, band), part in got.items():
        layout = bands["expect"](frame, band)
        assert part.sums.shape == layout["sums"] and part.aov.shape == layout["aov"]
    return "resumed"


def test05_the_band_checkpoint_resumes(bands):
    assert bands_or_refuse(bands, bands["path"]) == "resumed"
    assert describe_checkpoint(bands["path"]) == "a checkpoint of 2 finished bands"


@FUZZ
@given(edits=st.lists(st.tuples(st.one_of(st.integers(0, 700), st.integers(-600, -1)),
                                st.integers(0, 255)), min_size=1, max_size=4),
       bands_field=st.one_of(st.none(), JSON, st.lists(JSON, max_size=3)),
       unit_size=st.one_of(st.none(), JSON),
       array=st.one_of(st.none(), st.tuples(st.sampled_from(
           ["sums_s_0", "squares_s_2", "aov_s_0", "splat_s_0", "sums_s_2"]), _arrays())),
       mode=st.sampled_from(["bytes", "fields"]))
def test06_band_checkpoints(bands, edits, bands_field, unit_size, array, mode):
    path = bands["path"].with_name("mutant.ckpt")
    if mode == "bytes":
        data = bytearray(bands["bytes"])
        for position, value in edits:
            data[position % len(data)] = value
        path.write_bytes(bytes(data))
    else:
        meta = json.loads(json.dumps(bands["meta"]))
        if bands_field is not None:
            meta["bands"] = bands_field if not isinstance(bands_field, list) else \
                meta["bands"][:1] + bands_field
        if unit_size is not None:
            meta["plan"]["unit_size"] = unit_size
        out = dict(bands["arrays"], meta=np.array(json.dumps(meta)))
        if array is not None:
            out[array[0]] = array[1]
        with open(path, "wb") as f:
            np.savez(f, **out)
    bands_or_refuse(bands, path)
