"""Checkpoints: a render's accumulation on disk, to continue it after an interrupt.

A checkpoint holds what :meth:`Renderer.state` returns (per-pixel exact fixed-point sums
of the samples and their squares, sample and dropped-sample counts, sums of the first-hit
AOVs, the next sample index) plus a JSON record:
the renderer's fingerprint (the hash of the scene as rendered and every setting that
decides a sample), the settings themselves (to explain a refusal), the target sample
count and where the render came from. Continuing it with :meth:`Renderer.restore` gives
the image of an uninterrupted render, bitwise, on the same device.

The file is an uncompressed ``.npz`` (numpy's zip of arrays, read with
``allow_pickle=False``: nothing in it is executed) written atomically.

A render whose units run elsewhere (a cluster, :class:`~glrender.render.job.UnitsJob`)
checkpoints its finished bands instead (:func:`save_band_checkpoint`): each band's exact
sums, sums of squares, AOV and splat sums and its sample range, keyed (frame, band), and a
record naming the job (the scene, settings and plan) and its unit size. The bands are the
caller's objects, read by attribute and made again by the ``make_band`` it gives
:func:`load_band_checkpoint`.
"""
from __future__ import annotations

import json
import math
import os
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..film.io import atomic_write

FORMAT = "glrender-checkpoint"
VERSION = 2     # 2: exact fixed-point sums (1: float32 Welford means)
ARRAYS = ("sums", "squares", "aov")
BAND_FORMAT = "glrender-distributed-checkpoint"
BAND_VERSION = 2    # 2: exact fixed-point sums per band (1: float32 means and M2)


@dataclass
class Checkpoint:
    """A loaded checkpoint: ``meta`` (the JSON record) and ``state`` (for ``restore``)."""

    path: Path
    meta: dict
    state: dict

    @property
    def spp_done(self) -> int:
        return int(self.meta["spp_done"])

    @property
    def fingerprint(self) -> str:
        return self.meta["fingerprint"]

    @property
    def settings(self) -> dict:
        return self.meta["settings"]


def settings_record(renderer) -> dict:
    """The settings that decide a renderer's samples, as plain JSON values."""
    s = renderer.settings
    return {"width": renderer.width, "height": renderer.height,
            "integrator": _json_safe(asdict(s.integrator)), "sampler": asdict(s.sampler),
            "aovs": bool(s.aovs), "strategy_depth": int(s.strategy_depth)}


def save_checkpoint(path, renderer, **info) -> None:
    """Write ``renderer``'s accumulation (whole passes) and its record to ``path``,
    atomically. ``info`` adds JSON fields to the record (target spp, scene, ...)."""
    state = renderer.state()
    meta = {"format": FORMAT, "version": VERSION, "fingerprint": state["fingerprint"],
            "spp_done": int(state["spp_done"]), "spp_start": int(state.get("spp_start", 0)),
            "settings": settings_record(renderer),
            "files": dict(getattr(renderer.scene, "files", {}) or {}),
            "rows": [int(r) for r in state.get("rows", (0, 0))], **info}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)),
                     **{name: np.ascontiguousarray(state[name], np.uint32) for name in ARRAYS},
                     splat=np.ascontiguousarray(state["splat"], np.uint32),
                     **({"strategies": np.ascontiguousarray(state["strategies"], np.uint32)}
                        if renderer.settings.strategy_depth else {}))

    atomic_write(path, write)


def load_checkpoint(path) -> Checkpoint:
    """Read a checkpoint; anything else is refused with a message naming the file."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"{path}: no checkpoint to resume (render without --resume to start, "
                         f"or name the file with --checkpoint)")
    unreadable = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile)
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"][()]))
            if not isinstance(meta, dict) or meta.get("format") != FORMAT:
                raise UsageError(f"{path}: not a glrender checkpoint")
            if meta.get("version") != VERSION:
                raise UsageError(f"{path}: checkpoint version {meta.get('version')} is not "
                                 f"supported (this glrender reads version {VERSION}); render "
                                 f"without --resume")
            state = {"fingerprint": str(meta["fingerprint"]), "spp_done": int(meta["spp_done"]),
                     "spp_start": int(meta.get("spp_start", 0)),
                     "width": int(meta["settings"]["width"]),
                     "height": int(meta["settings"]["height"]),
                     **{name: np.array(data[name], np.uint32) for name in ARRAYS}}
            if "rows" in meta:    # the tile rows held (a crop or a distributed band)
                state["rows"] = tuple(int(r) for r in meta["rows"])
            if "splat" in data:   # light tracing's and BDPT's fixed-point splat sums
                state["splat"] = np.array(data["splat"], np.uint32)
            if "strategies" in data:   # bdpt's strategy images (--strategy-images)
                state["strategies"] = np.array(data["strategies"], np.uint32)
    except unreadable as exc:
        if isinstance(exc, UsageError):
            raise
        raise UsageError(f"{path}: not a readable glrender checkpoint ({exc})") from None
    return Checkpoint(path, meta, state)


def check_resumable(checkpoint: Checkpoint, renderer) -> None:
    """Refuse, with the settings that differ, a checkpoint of another scene or settings,
    and one whose input files (scene, includes, meshes, images) changed since, by name."""
    _check_files(checkpoint, dict(getattr(renderer.scene, "files", {}) or {}))
    if checkpoint.fingerprint == renderer.fingerprint():
        return
    then, now = _flatten(checkpoint.settings), _flatten(settings_record(renderer))
    differ = [f"{key} {then.get(key)!r} there, {now.get(key)!r} here"
              for key in sorted(set(then) | set(now)) if then.get(key) != now.get(key)]
    fix = "resume with the same options, or render without --resume to start afresh"
    if differ:
        raise UsageError(f"{checkpoint.path}: the checkpoint belongs to a render with other "
                         f"settings ({'; '.join(differ)}): {fix}")
    raise UsageError(f"{checkpoint.path}: the checkpoint belongs to a different scene (same "
                     f"settings, but the scene or a file it uses changed since): {fix}")


def save_band_checkpoint(path, record: dict, bands: dict) -> None:
    """Write finished bands ({(frame, band): band}, each with ``sums``, ``squares``, ``aov``,
    ``splat`` and ``samples``) and ``record`` (JSON: the job, its plan, ...) to ``path``,
    atomically."""
    arrays = {}
    for (frame, band), p in bands.items():
        tag = f"{'s' if frame is None else frame}_{band}"
        arrays[f"sums_{tag}"] = p.sums
        arrays[f"squares_{tag}"] = p.squares
        if p.aov is not None:
            arrays[f"aov_{tag}"] = p.aov
        if p.splat is not None:
            arrays[f"splat_{tag}"] = p.splat
    meta = {**record, "format": BAND_FORMAT, "version": BAND_VERSION,
            "bands": [[frame, band, list(p.samples)] for (frame, band), p in bands.items()]}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)

    atomic_write(path, write)


def _open_band_checkpoint(path: Path):
    """A band checkpoint of this version: (its record, its arrays: an open npz)."""
    if not path.is_file():
        raise UsageError(f"{path}: no checkpoint to resume (render without --resume to start, "
                         f"or name the file with --checkpoint)")
    try:
        z = np.load(path, allow_pickle=False)
        meta = json.loads(str(z["meta"]))
        if not isinstance(meta, dict) or meta.get("format") != BAND_FORMAT:
            raise ValueError("not a distributed render's checkpoint")
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise UsageError(f"{path}: not a readable checkpoint ({exc})") from None
    if meta.get("version") != BAND_VERSION:
        z.close()
        raise UsageError(f"{path}: a distributed checkpoint of version {meta.get('version')}, "
                         f"this glrender reads version {BAND_VERSION} (render without "
                         f"--resume)")
    return meta, z


def band_checkpoint_unit_size(path) -> int:
    """The unit size a band checkpoint's render used (its plan record)."""
    path = Path(path)
    meta, z = _open_band_checkpoint(path)
    z.close()
    try:
        return int(meta["plan"]["unit_size"])
    except (KeyError, TypeError, ValueError) as exc:
        raise UsageError(f"{path}: not a readable checkpoint (no unit size: {exc})") from None


def load_band_checkpoint(path, job: str, make_band: Callable[..., Any]) -> dict:
    """The finished bands of a band checkpoint of ``job`` (refused for another job),
    {(frame, band): make_band(sums, squares, aov, samples, splat=splat)}."""
    path = Path(path)
    meta, z = _open_band_checkpoint(path)
    with z:
        if meta.get("job") != job:
            raise UsageError(f"{path}: the checkpoint belongs to another scene, other "
                             f"settings or another unit size (render without --resume)")
        try:
            bands = {}
            for frame, band, samples in meta["bands"]:
                tag = f"{'s' if frame is None else frame}_{band}"
                aov = z[f"aov_{tag}"] if f"aov_{tag}" in z.files else None
                splat = z[f"splat_{tag}"] if f"splat_{tag}" in z.files else None
                bands[(frame, band)] = make_band(z[f"sums_{tag}"], z[f"squares_{tag}"], aov,
                                                 tuple(samples), splat=splat)
            return bands
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise UsageError(f"{path}: not a readable checkpoint ({exc})") from None


def _check_files(checkpoint: Checkpoint, now: dict) -> None:
    """Every file the checkpointed render read must be there with the same content. Files
    are matched by their path relative to the scene file's folder (the first one
    recorded), so a project folder moved as a whole resumes."""
    then = checkpoint.meta.get("files") or {}
    if not then or not now:
        return                  # a scene built in code, or a checkpoint without the record

    def relative(files: dict) -> tuple[str, dict]:
        base = os.path.dirname(next(iter(files)))
        return base, {os.path.relpath(p, base): digest for p, digest in files.items()}

    _, then_rel = relative(then)
    base_now, now_rel = relative(now)
    changed = sorted(r for r, digest in then_rel.items() if r in now_rel and now_rel[r] != digest)
    missing = sorted(r for r in then_rel if r not in now_rel)
    fix = "render without --resume to start afresh"
    for names, what in ((changed, "changed since the checkpoint was written"),
                        (missing, "was read by the checkpointed render but not by this one")):
        if names:
            more = f" (and {len(names) - 1} more)" if len(names) > 1 else ""
            path = os.path.normpath(os.path.join(base_now, names[0]))
            raise UsageError(f"{checkpoint.path}: {path}{more} {what}: {fix}")


def _flatten(record: dict, prefix: str = "") -> dict:
    flat = {}
    for key, value in record.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


def _json_safe(record: dict) -> dict:
    """Infinite floats as strings, so the record is strict JSON."""
    return {k: (repr(v) if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in record.items()}
