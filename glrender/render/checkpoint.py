"""Checkpoints: a render's accumulation on disk, to continue it after an interrupt.

A checkpoint holds what :meth:`Renderer.state` returns (per-pixel exact fixed-point sums
of the samples and their squares, sample and dropped-sample counts, sums of the first-hit
AOVs, the next sample index) plus a JSON record:
the renderer's fingerprint (the hash of the scene as rendered and every setting that
decides a sample) and its parts' digests, the settings themselves and the files the scene
read (to explain a refusal: which file changed, which part of the render differs), the
target sample count and where the render came from. Continuing it with :meth:`Renderer.restore` gives
the image of an uninterrupted render, bitwise, on the same device.

The file is an uncompressed ``.npz`` (numpy's zip of arrays, read with
``allow_pickle=False``: nothing in it is executed) written atomically.

A render whose units run elsewhere (a cluster, :class:`~glrender.render.job.UnitsJob`)
checkpoints its finished bands instead (:func:`save_band_checkpoint`): each band's exact
sums, sums of squares, AOV and splat sums and its sample range, keyed (frame, band), and a
record naming the job (the scene, settings and plan) and its unit size. The bands are the
caller's objects, read by attribute and made again by the ``make_band`` it gives
:func:`load_band_checkpoint`.

Nothing in a checkpoint is trusted: the zip's members must be arrays numpy stored (no
compression, no objects, no larger than the file), and every field of the record is
checked for its type, range and size before it is used (the sample counts, the tile rows,
the image size, the fingerprint, the files, the command's options, each band's arrays and
sample range). A file that fails is refused in one line naming it and the field.
"""
from __future__ import annotations

import json
import math
import os
import re
import struct
import zipfile
import zlib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..film.io import atomic_write
from .accumulation import TILE
from .driver import PART_DIGITS

FORMAT = "glrender-checkpoint"
VERSION = 2     # 2: exact fixed-point sums (1: float32 Welford means)
ARRAYS = ("sums", "squares", "aov")
BAND_FORMAT = "glrender-distributed-checkpoint"
BAND_VERSION = 2    # 2: exact fixed-point sums per band (1: float32 means and M2)
MAX_SIZE = 65536    # pixels of a side (the command line's --width/--height)
FRESH = "render without --resume to start afresh"
# what reading a zip of arrays may raise for a damaged or crafted file (zipfile raises
# RuntimeError for an encrypted member)
_UNREADABLE = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile,
               zlib.error, struct.error, RuntimeError, OverflowError)


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
            "fingerprint_parts": _parts(renderer),
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
    """Read a checkpoint, every field checked; anything else is refused with a message
    naming the file (and the field)."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"{path}: no checkpoint to resume (render without --resume to start, "
                         f"or name the file with --checkpoint)")
    arrays = _read_arrays(path, ("meta", *ARRAYS, "splat", "strategies"),
                          "not a readable glrender checkpoint")
    meta = _meta(path, arrays, FORMAT, "not a glrender checkpoint")
    if meta.get("version") != VERSION:
        raise UsageError(f"{path}: checkpoint version {_show(meta.get('version'))} is not "
                         f"supported (this glrender reads version {VERSION}); render "
                         f"without --resume")
    _check_record(path, meta)
    state = {"fingerprint": meta["fingerprint"], "spp_done": meta["spp_done"],
             "spp_start": meta.get("spp_start", 0),
             "width": meta["settings"]["width"], "height": meta["settings"]["height"]}
    for name in ARRAYS + ("splat", "strategies"):
        if name not in arrays:
            if name in ARRAYS:
                raise UsageError(f"{path}: the checkpoint has no {name} array: {FRESH}")
            continue
        words = arrays[name]
        if words.dtype != np.uint32 or words.ndim != 1:
            raise UsageError(f"{path}: the checkpoint's {name} array is {words.dtype} of shape "
                             f"{words.shape}, expected uint32 words (one dimension): {FRESH}")
        state[name] = words
    if "rows" in meta:    # the tile rows held (a crop or a distributed band)
        state["rows"] = tuple(meta["rows"])
    return Checkpoint(path, meta, state)


def restore_checkpoint(checkpoint: Checkpoint, driver) -> int:
    """Continue ``checkpoint`` in ``driver``: refused (:func:`check_resumable`) for another
    scene or other settings, and for arrays of another size than the driver's; the samples
    per pixel it holds."""
    check_resumable(checkpoint, driver)
    try:
        driver.restore(checkpoint.state)
    except UsageError as exc:
        raise UsageError(f"{checkpoint.path}: {exc}: {FRESH}") from None
    return driver.spp_done


def describe_checkpoint(path) -> str:
    """What the checkpoint ``path`` holds, in a few words: "a checkpoint of 2496 spp (of
    4096)", "a checkpoint of 12 finished bands", or that it is not a readable one."""
    path = Path(path)
    try:
        arrays = _read_arrays(path, ("meta",), "unreadable")
        meta = _meta(path, arrays, None, "unreadable")
    except UsageError:
        return "a file that is not a readable checkpoint"
    if meta.get("format") == FORMAT and _is_int(meta.get("spp_done")):
        target = meta.get("spp_target")
        return (f"a checkpoint of {meta['spp_done']} spp"
                + (f" (of {target})" if _is_int(target) else ""))
    if meta.get("format") == BAND_FORMAT and isinstance(meta.get("bands"), list):
        n = len(meta["bands"])
        return f"a checkpoint of {n} finished band{'' if n == 1 else 's'}"
    return "a file that is not a readable checkpoint"


def _is_int(value) -> bool:
    return type(value) is int       # JSON integers: not bool, not float


def _show(value, width: int = 40) -> str:
    """A value of a record in a message: one line, at most ``width`` characters."""
    try:
        text = json.dumps(value)        # as the record writes it (true, null, "text")
    except (TypeError, ValueError):
        text = repr(value)
    return _line(text, width)


def _line(text: str, width: int = 120) -> str:
    """The first line of ``text``, at most ``width`` characters."""
    text = (text.strip().splitlines() or [""])[0]
    return text if len(text) <= width else text[:width - 3] + "..."


def _read_arrays(path: Path, names, unreadable: str) -> dict[str, np.ndarray]:
    """The arrays ``names`` of the .npz ``path`` (those it has; None: all but the record),
    read without trusting it: each member is one numpy stored uncompressed (as ``np.savez``
    does), no larger than the file, holding no objects, whose header's shape fits the
    member; ``unreadable`` opens the message of a file that is not one."""
    try:
        if not path.is_file():          # a device or a pipe would never end (or never start)
            raise ValueError("not a regular file")
        size = path.stat().st_size
        arrays = {}
        with zipfile.ZipFile(path) as zf:
            for info in zf.infolist():
                name = info.filename[:-4] if info.filename.endswith(".npy") else None
                wanted = name != "meta" if names is None else name in names
                if name is None or not wanted or name in arrays:
                    continue
                if info.compress_type != zipfile.ZIP_STORED or info.file_size > size:
                    raise ValueError(f"{info.filename} is not stored as numpy stores it")
                with zf.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(f)
                    elif version == (2, 0):
                        shape, _, dtype = np.lib.format.read_array_header_2_0(f)
                    else:
                        raise ValueError(f"{info.filename}: npy version {version}")
                    if dtype.hasobject or math.prod(shape) * dtype.itemsize > info.file_size:
                        raise ValueError(f"{info.filename}: the header claims more than the "
                                         f"member holds")
                with zf.open(info) as f:
                    arrays[name] = np.lib.format.read_array(f, allow_pickle=False)
    except _UNREADABLE as exc:
        raise UsageError(f"{path}: {unreadable} ({_line(str(exc)) or type(exc).__name__})") \
            from None
    return arrays


def _meta(path: Path, arrays: dict, fmt: str | None, other: str) -> dict:
    """The JSON record of a checkpoint's arrays (of format ``fmt``, unless None)."""
    meta = arrays.get("meta")
    if meta is None or meta.dtype.kind != "U" or meta.ndim != 0:
        raise UsageError(f"{path}: {other} (no record)")
    try:
        record = json.loads(str(meta[()]))
    except (ValueError, RecursionError) as exc:
        raise UsageError(f"{path}: {other} (its record is not JSON: "
                         f"{_line(str(exc), 80) or type(exc).__name__})") from None
    if not isinstance(record, dict) or (fmt is not None and record.get("format") != fmt):
        raise UsageError(f"{path}: {other}")
    return record


def _check_record(path: Path, meta: dict) -> None:
    """Every field of a checkpoint's record that glrender uses, by type and range."""
    from .job import SPP_LIMIT

    def need(name: str, value, ok: bool, expected: str) -> None:
        if not ok:
            raise UsageError(f"{path}: the checkpoint's {name} is {_show(value)}, expected "
                             f"{expected}: {FRESH}")

    missing = object()
    fp = meta.get("fingerprint", missing)
    need("fingerprint", fp, isinstance(fp, str) and re.fullmatch("[0-9a-f]{64}", fp) is not None,
         "64 hexadecimal digits")
    parts = meta.get("fingerprint_parts", {})         # absent from older checkpoints
    need("fingerprint_parts", parts, isinstance(parts, dict) and len(parts) <= 32 and all(
        isinstance(k, str) and len(k) <= 40 and k.isprintable() and isinstance(v, str)
        and re.fullmatch(f"[0-9a-f]{{{PART_DIGITS}}}", v) is not None for k, v in parts.items()),
        f"a table of part names and {PART_DIGITS}-digit digests")
    done = meta.get("spp_done", missing)
    need("spp_done", done, _is_int(done) and 0 <= done <= SPP_LIMIT,
         f"a whole number of samples per pixel in 0..{SPP_LIMIT}")
    start = meta.get("spp_start", 0)
    need("spp_start", start, _is_int(start) and 0 <= start <= done,
         f"a whole number of samples in 0..{done} (spp_done)")
    target = meta.get("spp_target")
    need("spp_target", target, target is None or (_is_int(target) and 1 <= target <= SPP_LIMIT),
         f"a whole number of samples per pixel in 1..{SPP_LIMIT}, or null")
    settings = meta.get("settings", missing)
    need("settings", settings, isinstance(settings, dict), "an object of the render settings")
    for key in ("width", "height"):
        value = settings.get(key, missing)
        need(f"settings.{key}", value, _is_int(value) and 1 <= value <= MAX_SIZE,
             f"pixels in 1..{MAX_SIZE}")
    if "rows" in meta:
        rows, tiles = meta["rows"], -(-settings["height"] // TILE)
        need("rows", rows, isinstance(rows, list) and len(rows) == 2 and all(map(_is_int, rows))
             and 0 <= rows[0] < tiles and 1 <= rows[1] <= tiles - rows[0],
             f"[first, count] tile rows within the image's {tiles}")
    files = meta.get("files", {})
    need("files", files, isinstance(files, dict) and all(
        isinstance(k, str) and os.path.isabs(k) and "\0" not in k and isinstance(v, str)
        for k, v in files.items()), "an object of absolute file paths and their digests")
    for key, kind in (("options", "an object of options"), ("params", "an object of -D values")):
        value = meta.get(key, {})
        need(key, value, isinstance(value, dict), kind)
    params = meta.get("params", {})
    need("params", params, all(isinstance(k, str) and k.isidentifier() and isinstance(v, str)
                               for k, v in params.items()), "-D names and their text values")
    aovs = meta.get("aov_names", [])
    need("aov_names", aovs, isinstance(aovs, list) and all(isinstance(n, str) for n in aovs),
         "a list of AOV names")
    for key in ("device", "scene", "glrender"):
        value = meta.get(key)
        need(key, value, value is None or isinstance(value, str), "text")


def check_resumable(checkpoint: Checkpoint, renderer) -> None:
    """Refuse a checkpoint of another scene or settings, and one whose input files (scene,
    includes, meshes, images) changed since, naming what differs: the settings and their
    values, the files by name, and the parts of the render (geometry, materials, lights,
    textures, ...) whose digests differ."""
    same = checkpoint.fingerprint == renderer.fingerprint()
    parts = _differing_parts(checkpoint, renderer, same)
    _check_files(checkpoint, dict(getattr(renderer.scene, "files", {}) or {}), parts)
    if same:
        return
    then, now = _flatten(checkpoint.settings), _flatten(settings_record(renderer))
    differ = [f"{_printable(key)} {_value(then.get(key))} there, {_value(now.get(key))} here"
              for key in sorted(set(then) | set(now)) if then.get(key) != now.get(key)]
    fix = "resume with the same options, or render without --resume to start afresh"
    if differ:
        raise UsageError(f"{checkpoint.path}: the checkpoint belongs to a render with other "
                         f"settings ({'; '.join(differ)}): {fix}")
    what = f"its {_and(parts)} differ" if parts else "the scene or a file it uses changed since"
    raise UsageError(f"{checkpoint.path}: the checkpoint belongs to a different scene (same "
                     f"settings, but {what}): {fix}")


def _parts(renderer) -> dict[str, str]:
    parts = getattr(renderer, "fingerprint_parts", None)
    return dict(parts()) if callable(parts) else {}


def _differing_parts(checkpoint: Checkpoint, renderer, same: bool) -> list[str] | None:
    """The parts of the render whose digests differ ([] if none; None: the checkpoint
    did not record them)."""
    then = checkpoint.meta.get("fingerprint_parts") or {}
    if same:
        return []
    if not then:
        return None
    now = _parts(renderer)
    return [_printable(p) for p in list(now) + [p for p in then if p not in now]
            if then.get(p) != now.get(p)]


def _and(names: list[str]) -> str:
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


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


def _open_band_checkpoint(path: Path, arrays: bool = True) -> tuple[dict, dict]:
    """A band checkpoint of this version: (its record, its arrays, unless not ``arrays``)."""
    if not path.is_file():
        raise UsageError(f"{path}: no checkpoint to resume (render without --resume to start, "
                         f"or name the file with --checkpoint)")
    what = "not a readable checkpoint"
    meta = _meta(path, _read_arrays(path, ("meta",), what), BAND_FORMAT,
                 f"{what} (not a distributed render's checkpoint)")
    if meta.get("version") != BAND_VERSION:
        raise UsageError(f"{path}: a distributed checkpoint of version "
                         f"{_show(meta.get('version'))}, this glrender reads version "
                         f"{BAND_VERSION} (render without --resume)")
    return meta, (_read_arrays(path, None, what) if arrays else {})


def band_checkpoint_unit_size(path) -> int:
    """The unit size a band checkpoint's render used (its plan record)."""
    path = Path(path)
    meta, _ = _open_band_checkpoint(path, arrays=False)
    plan = meta.get("plan")
    size = plan.get("unit_size") if isinstance(plan, dict) else None
    if not (_is_int(size) and 1 <= size < 1 << 62):
        raise UsageError(f"{path}: the checkpoint's plan.unit_size is {_show(size)}, expected a "
                         f"positive number of pixel-samples: {FRESH}")
    return size


#: ``expect(frame, band)``: a band's arrays as its plan makes them, {"sums": shape,
#: "squares": shape, "aov": shape or None, "splat": shape or None, "samples": (start,
#: stop)}, or None for a band the plan does not have
BandLayout = Callable[[Any, int], "dict | None"]
_BAND_DTYPES = {"sums": np.uint32, "squares": np.uint32, "aov": np.uint32, "splat": np.int64}


def load_band_checkpoint(path, job: str, make_band: Callable[..., Any],
                         expect: BandLayout | None = None) -> dict:
    """The finished bands of a band checkpoint of ``job`` (refused for another job),
    {(frame, band): make_band(sums, squares, aov, samples, splat=splat)}. Each band's
    frame, index, sample range and arrays (their types and shapes; with ``expect``, those
    of its plan) are checked first."""
    path = Path(path)
    meta, arrays = _open_band_checkpoint(path)
    if meta.get("job") != job:
        raise UsageError(f"{path}: the checkpoint belongs to another scene, other "
                         f"settings or another unit size (render without --resume)")
    from .job import SPP_LIMIT

    def refuse(what: str) -> UsageError:
        return UsageError(f"{path}: the checkpoint's {what}: {FRESH}")

    entries = meta.get("bands")
    if not isinstance(entries, list):
        raise refuse(f"bands is {_show(entries)}, expected a list of [frame, band, samples]")
    bands = {}
    for i, entry in enumerate(entries):
        ok = isinstance(entry, list) and len(entry) == 3
        frame, band, samples = entry if ok else (None, None, None)
        ok = ok and (frame is None or _is_int(frame)) and _is_int(band) and band >= 0 and \
            isinstance(samples, list) and len(samples) == 2 and all(map(_is_int, samples)) and \
            0 <= samples[0] < samples[1] <= SPP_LIMIT
        if not ok:
            raise refuse(f"bands[{i}] is {_show(entry)}, expected [frame (an integer or null), "
                         f"band (an integer >= 0), [first sample, end sample]]")
        if (frame, band) in bands:
            raise refuse(f"bands[{i}] repeats band {band} of frame {frame}")
        tag = f"{'s' if frame is None else frame}_{band}"
        got = {name: arrays.get(f"{name}_{tag}") for name in _BAND_DTYPES}
        layout = expect(frame, band) if expect is not None else None
        if expect is not None and layout is None:
            raise refuse(f"bands[{i}]: band {band} of frame {frame} is not in this render's plan")
        if layout is not None and tuple(samples) != tuple(layout["samples"]):
            raise refuse(f"bands[{i}] holds samples {samples}, the plan's band "
                         f"{list(layout['samples'])}")
        pixels = None if got["sums"] is None else got["sums"].shape[:1]
        for name, dtype in _BAND_DTYPES.items():
            a, shown = got[name], _array(got[name])
            if layout is not None:              # the plan's: exactly these, or none
                want = "none" if layout[name] is None else \
                    f"{np.dtype(dtype)} of shape {tuple(layout[name])}"
                if shown != want:
                    raise refuse(f"{name}_{tag} is {shown}, the plan's band holds {want}")
            elif a is None:
                if name in ("sums", "squares"):
                    raise refuse(f"{name}_{tag} is none, expected an array of the band")
            elif a.dtype != dtype or a.ndim != (2 if name == "splat" else 3) or \
                    (name != "splat" and a.shape[:1] != pixels):
                raise refuse(f"{name}_{tag} is {shown}, expected {np.dtype(dtype)} with one "
                             f"row per pixel of the band")
        bands[(frame, band)] = make_band(got["sums"], got["squares"], got["aov"], tuple(samples),
                                         splat=got["splat"])
    return bands


def _array(a: np.ndarray | None) -> str:
    return "none" if a is None else f"{a.dtype} of shape {tuple(a.shape)}"


def _check_files(checkpoint: Checkpoint, now: dict, parts: list[str] | None = None) -> None:
    """Every file the checkpointed render read must be there with the same content. Files
    are matched by their path relative to the scene file's folder (the first one
    recorded), so a project folder moved as a whole resumes. ``parts``: the parts of the
    render that differ (None: unknown), said after the files."""
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
    if parts is None:
        effect = ""
    elif parts:
        effect = f": the render's {_and(parts)} differ"
    else:
        effect = ": the scene as rendered is the same"
    for names, what in ((changed, "changed since the checkpoint was written"),
                        (missing, "read by the checkpointed render but not by this one")):
        if names:
            shown = [_printable(os.path.normpath(os.path.join(base_now, n))) for n in names[:3]]
            more = [f"{len(names) - 3} more"] if len(names) > 3 else []
            verb = ("was " if len(names) == 1 else "were ") if what.startswith("read") else ""
            raise UsageError(f"{checkpoint.path}: {_and(shown + more)} {verb}{what}{effect}; "
                             f"{fix}")


def _printable(text: str) -> str:
    return text if text.isprintable() else _line(repr(text))


def _value(value) -> str:
    """A setting in a message: as Python writes it (``'path'``, ``4``), on one line."""
    return _line(repr(value), 60)


def _flatten(record: dict) -> dict:
    """A nested record's leaves, keyed by their dotted path."""
    flat, stack = {}, [("", record)]
    while stack:
        prefix, node = stack.pop()
        for key, value in node.items():
            if isinstance(value, dict):
                stack.append((f"{prefix}{key}.", value))
            else:
                flat[prefix + key] = value
    return flat


def _json_safe(record: dict) -> dict:
    """Infinite floats as strings, so the record is strict JSON."""
    return {k: (repr(v) if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in record.items()}
