"""The render commands' shared option checks (``glrender render``, on one machine or a cluster,
and ``glrender preview``): every value a user can get wrong is checked here before any work."""
from __future__ import annotations

import math
import os
from pathlib import Path

from ..errors import SceneError, UsageError
from ..render.job import SPP_LIMIT
from ..scene.model import SPLIT_LIMIT, parse_rr


AOV_NAMES = ("albedo", "normal", "depth", "emission", "variance", "radius", "photons")   # the last two: photon, sppm


FIRST_HIT_AOVS = ("albedo", "normal", "depth", "emission")


# the options a checkpoint remembers; --resume takes those not given again
RESUMABLE = ("spp", "seed", "sampler", "integrator", "strategy", "max_depth", "width", "height",
             "clamp", "crop", "strategy_images", "strategy_depth", "rr", "rr_depth",
             "light_samples", "split", "light_selection")


def parse_defines(items: list[str]) -> dict[str, str]:
    """``-D key=value`` pairs -> {key: value} (values stay strings; the loader types them)."""
    params = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise UsageError(f"-D {item}: expected KEY=VALUE with KEY a name (letters, digits, _)")
        params[key] = value
    return params


def parse_aovs(text: str | None) -> list[str]:
    if text is None:
        return []
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in AOV_NAMES]
    if unknown or not names:
        raise UsageError(f"--aov {text}: unknown AOV {', '.join(unknown) or '(none)'} "
                         f"(choose from {','.join(AOV_NAMES)})")
    return list(dict.fromkeys(names))


def check_options(args) -> None:
    def need(name, value, ok, what):
        if value is not None and not ok(value):
            raise UsageError(f"{name} {value}: expected {what}")

    need("--spp", args.spp, lambda v: 1 <= v < SPP_LIMIT, "a positive number of samples per pixel")
    need("--time", args.time, lambda v: math.isfinite(v) and v > 0, "a positive number of seconds")
    need("--checkpoint-every", args.checkpoint_every, lambda v: math.isfinite(v) and v > 0,
         "a positive number of seconds")
    need("--width", args.width, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--height", args.height, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--threads", args.threads, lambda v: v >= 1, "a positive number of threads")
    need("--exposure", args.exposure, math.isfinite, "a finite number of stops")
    need("--seed", args.seed, lambda v: 0 <= v < 1 << 32, "an integer in 0..2^32-1")
    need("--max-depth", args.max_depth, lambda v: v == -1 or v >= 1,
         "-1 (unbounded) or a number of path segments >= 1")
    need("--rr-depth", args.rr_depth, lambda v: 1 <= v <= 1 << 20, "a number of path segments >= 1")
    for name, value in (("--light-samples", args.light_samples), ("--split", args.split)):
        need(name, value, lambda v: 1 <= v <= SPLIT_LIMIT, f"an integer in 1..{SPLIT_LIMIT}")
    if args.rr is not None:
        try:
            parse_rr(args.rr)
        except SceneError as exc:
            want = str(exc).split("expected ", 1)[1].rsplit(", got", 1)[0]
            raise UsageError(f"--rr {args.rr}: expected {want}") from None
    need("--clamp", args.clamp, lambda v: math.isfinite(v) and v > 0,
         "a positive number (the largest RGB component a sample keeps)")
    need("--noise-threshold", args.noise_threshold, lambda v: 0 < v < 1,
         "a relative error in (0, 1), e.g. 0.02 for 2%")
    if args.crop is not None:
        parse_crop(args.crop)


def parse_crop(text, width: int | None = None, height: int | None = None) -> list[int]:
    """``X0,Y0,X1,Y1`` (or the list a checkpoint saved) -> [x0, y0, x1, y1] (pixels, x1 and
    y1 excluded), inside the film when its size is given."""
    if isinstance(text, (list, tuple)):
        text = ",".join(map(str, text))
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 4 or not all(p.lstrip("-").isdigit() for p in parts):
        raise UsageError(f"--crop {text}: expected X0,Y0,X1,Y1 in whole pixels")
    x0, y0, x1, y1 = map(int, parts)
    if not (0 <= x0 < x1 and 0 <= y0 < y1):
        raise UsageError(f"--crop {text}: expected 0 <= X0 < X1 and 0 <= Y0 < Y1")
    if width is not None and height is not None and (x1 > width or y1 > height):
        raise UsageError(f"--crop {text}: outside the {width}x{height} film (X1 <= {width}, "
                         f"Y1 <= {height})")
    return [x0, y0, x1, y1]


def check_scene_file(path: Path) -> None:
    if path.is_dir():
        hint = f" (e.g. {path / 'scene.toml'})" if (path / "scene.toml").is_file() else ""
        raise UsageError(f"{path}: is a folder; give the scene file inside it{hint}")
    if not path.exists():
        raise UsageError(f"{path}: no such scene file (check the path)")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{path}: cannot read the scene file (permission denied)")


def _available_memory() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def check_memory(width: int, height: int, aovs: bool, on_host_device: bool) -> None:
    """Refuse images whose buffers cannot fit, before allocating them."""
    pixels = width * height
    from ..render.accumulation import AOV_BYTES, SQUARE_BYTES, SUM_BYTES

    accumulation = SUM_BYTES + SQUARE_BYTES
    device = pixels * (accumulation + (AOV_BYTES if aovs else 0)) * 2   # and the undo copy
    host = pixels * (accumulation + 76 + 24)               # read-back, Film arrays, encoding
    need = host + (device if on_host_device else 0)
    have = _available_memory()
    if have is not None and need > have:
        raise UsageError(f"a {width}x{height} image needs about {need / 2**30:.1f} GiB of memory "
                         f"for its buffers, more than the {have / 2**30:.1f} GiB available: render "
                         f"fewer pixels (--width/--height){' or without --aov' if aovs else ''}")


def add_search_path(parser) -> None:
    """``--search-path DIR`` (repeatable), for the commands that load scene files."""
    parser.add_argument("--search-path", dest="search_path", action="append", default=[],
                        metavar="DIR",
                        help="a folder besides the scene file's own that the files a scene "
                             "refers to (includes, meshes, textures, ...) may come from "
                             "(repeatable); references leading anywhere else are refused")


def search_folders(items) -> list[Path]:
    """The ``--search-path`` folders, each checked to be one."""
    folders = []
    for item in items or ():
        folder = Path(item)
        if not folder.is_dir():
            what = "is not a folder" if folder.exists() else "no such folder"
            raise UsageError(f"--search-path {item}: {what}")
        folders.append(folder)
    return folders
