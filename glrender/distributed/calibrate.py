"""The default unit size: measured once per device and scene kind, then kept on disk.

A render without ``--unit-size`` asks one worker for its device (the GL renderer
string) and looks up ``(device, --device, integrator)`` in the cache file. On a miss the
worker renders a short calibration on the render's own scene (its middle tile row, two
passes, timing the second) and the unit size becomes about UNIT_SECONDS of that work,
rounded to a power of two (plan.calibrated_unit_size); it is written to the cache and
every later render of that kind on that device reuses it. The unit size in use is
recorded with the render (``--stats``, the checkpoint), and ``--resume`` takes the
checkpoint's.

The cache file is ``$GLRENDER_CACHE_DIR/unit-size.json``, else
``$XDG_CACHE_HOME/glrender/unit-size.json``, else ``~/.cache/glrender/unit-size.json``.
Delete it to calibrate again; ``--unit-size`` overrides it for one render. The unit size
decides only how the work is split: the image is bitwise the same for every unit size.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from ..errors import UsageError
from .plan import calibrated_unit_size

CACHE_NAME = "unit-size.json"
CACHE_FORMAT = "glrender-unit-size"


def cache_path() -> Path:
    base = os.environ.get("GLRENDER_CACHE_DIR")
    if base:
        return Path(base) / CACHE_NAME
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(xdg) / "glrender" / CACHE_NAME


def kind_key(renderer: str, device, integrator: str) -> str:
    """The cache key of a device and scene kind."""
    return f"{renderer} | device={device if device is not None else 'default'} | {integrator}"


def _read(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: not a readable unit-size cache ({exc}); delete it to "
                         f"calibrate again") from None
    if not isinstance(data, dict) or data.get("format") != CACHE_FORMAT \
            or not isinstance(data.get("entries"), dict):
        raise UsageError(f"{path}: not a glrender unit-size cache; delete it to calibrate again")
    return data["entries"]


def _write(path: Path, entries: dict) -> None:
    from ..film.io import atomic_write

    path.parent.mkdir(parents=True, exist_ok=True)

    def write(tmp: Path) -> None:
        tmp.write_text(json.dumps({"format": CACHE_FORMAT, "entries": entries}, indent=1,
                                  sort_keys=True) + "\n")

    atomic_write(path, write)


def measure(job) -> dict:
    """On a worker: the render rate of ``job``'s scene on this worker's device, in
    pixel-samples per second (the middle tile row, the second of two passes timed)."""
    from .worker import _renderer, _context

    r = _renderer(job, None)
    passes = r.samples_per_pass
    r.reset(rows=(r.tiles_y // 2, 1))
    r.step(passes)                       # first touch of the buffers and caches
    t0 = time.perf_counter()
    r.step(passes)
    seconds = time.perf_counter() - t0
    return {"renderer": _context(job.device).renderer,
            "rate": r.width * r.band_height * passes / max(seconds, 1e-9),
            "seconds": seconds}


def device_name(job) -> str:
    """On a worker: the GL renderer string of ``job``'s device."""
    from .worker import _context

    return _context(job.device).renderer


def unit_size(client, job, job_future) -> tuple[int, dict]:
    """The calibrated unit size for ``job`` on ``client``'s cluster and how it was found:
    (size, {"unit_size", "source": "cache" | "calibrated", "key", "rate", "cache"}).
    ``job_future``: the cluster's task holding the job (``client.job_future``)."""
    path = cache_path()
    entries = _read(path)
    name = client.submit(device_name, job_future, pure=False).result()
    key = kind_key(name, job.device, job.settings.integrator.kind)
    entry = entries.get(key)
    if isinstance(entry, dict) and isinstance(entry.get("unit_size"), int):
        return entry["unit_size"], {**entry, "source": "cache", "key": key, "cache": str(path)}
    m = client.submit(measure, job_future, pure=False).result()
    size = calibrated_unit_size(m["rate"])
    entry = {"unit_size": size, "rate": m["rate"], "measured": time.strftime("%Y-%m-%dT%H:%M:%S")}
    entries[key] = entry
    _write(path, entries)
    return size, {**entry, "source": "calibrated", "key": key, "cache": str(path)}
