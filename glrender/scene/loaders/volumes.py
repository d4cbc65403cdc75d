"""Voxel grids of participating media: Mitsuba's ``.vol`` files and numpy ``.npy`` arrays.

A ``.vol`` file (Mitsuba 0.6 to 3, little-endian) is a 48-byte header - the bytes ``VOL``,
the version 3 (one byte), the encoding (int32; 1 = float32, the only one Mitsuba reads),
the resolution along x, y and z and the number of channels (int32 each), the bounding box
(6 float32: xmin, ymin, zmin, xmax, ymax, zmax) - followed by the voxels, x fastest:
``data[((z * yres + y) * xres + x) * channels + c]``, which is a C-order (Z, Y, X, C)
array. A ``.npy`` file holds a (Z, Y, X) or (Z, Y, X, C) array of numbers in the same
order; its box is the unit cube.

Every size a header declares is checked against the bytes that follow it and against
:data:`MAX_GRID_VALUES` before anything is allocated. The SceneErrors say only why: the
caller names the scene file, its line or field, and the grid file as the scene names it
(as image errors do).
"""
from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass

import numpy as np

from ...errors import SceneError
from .. import model as m
from .diagnostics import cause, excerpt

VOL_MAGIC = b"VOL"
VOL_VERSION = 3
VOL_FLOAT32 = 1
_VOL_HEADER = struct.Struct("<3sB5i6f")      # magic, version, encoding, x, y, z, channels, bbox
CHANNELS = (1, 3, 6)
#: The most values (voxels x channels) a grid may hold: 2^28, 1 GiB of float32.
MAX_GRID_VALUES = 1 << 28
UNIT_BOX = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))


@dataclass
class Grid:
    """A grid file's voxels, float32 (Z, Y, X, C), and the box its header declares
    ((xmin, ymin, zmin), (xmax, ymax, zmax)); the unit cube for ``.npy`` files."""

    data: np.ndarray
    bbox: tuple = UNIT_BOX


def _check_shape(z: int, y: int, x: int, c: int) -> None:
    if min(x, y, z) < 1:
        raise SceneError(f"resolution {x} x {y} x {z} (x, y, z): expected at least one voxel "
                         f"along each axis")
    if c not in CHANNELS:
        raise SceneError(f"{c} channels: expected 1, 3 or 6")
    if x * y * z * c > MAX_GRID_VALUES:
        raise SceneError(f"{x} x {y} x {z} voxels of {c} channel{'s' if c > 1 else ''} is more "
                         f"than the {MAX_GRID_VALUES:,} values a grid may hold")


def _file_size(path) -> int:
    try:
        return os.stat(path).st_size
    except OSError as exc:
        raise SceneError(f"cannot read it ({exc.strerror or type(exc).__name__})") from None


def read_vol(path) -> Grid:
    """A Mitsuba ``.vol`` file (version 3, float32)."""
    size = _file_size(path)
    try:
        with open(path, "rb") as f:
            head = f.read(_VOL_HEADER.size)
    except OSError as exc:
        raise SceneError(f"cannot read it ({exc.strerror or type(exc).__name__})") from None
    if head[:3] != VOL_MAGIC[:len(head)]:
        raise SceneError(f"not a Mitsuba volume file (it starts with {excerpt(head[:3])}, "
                         f"expected 'VOL')")
    if len(head) < _VOL_HEADER.size:
        raise SceneError(f"truncated: the header has {len(head)} of its {_VOL_HEADER.size} bytes")
    _, version, encoding, x, y, z, c, *box = _VOL_HEADER.unpack(head)
    if version != VOL_VERSION:
        raise SceneError(f"version {version}: only version {VOL_VERSION} is supported")
    if encoding != VOL_FLOAT32:
        raise SceneError(f"encoding {encoding} is not supported (only {VOL_FLOAT32}, float32)")
    _check_shape(z, y, x, c)
    count = x * y * z * c
    present = size - _VOL_HEADER.size
    if present != 4 * count:
        raise SceneError(f"the header declares {x} x {y} x {z} voxels of {c} channel"
                         f"{'s' if c > 1 else ''} ({4 * count} bytes of float32), the file has "
                         f"{present} bytes after the header"
                         + (" (truncated)" if present < 4 * count else ""))
    try:
        data = np.fromfile(path, np.dtype("<f4"), count=count, offset=_VOL_HEADER.size)
    except (OSError, ValueError) as exc:
        raise SceneError(f"cannot read it ({cause(exc)})") from None
    if data.size != count:            # the file changed under us
        raise SceneError(f"truncated: {data.size} of {count} values present")
    bbox = (tuple(float(v) for v in box[:3]), tuple(float(v) for v in box[3:]))
    return Grid(data.astype(np.float32).reshape(z, y, x, c), bbox)


def write_vol(path, data, bbox=UNIT_BOX) -> None:
    """Write ``data`` ((Z, Y, X) or (Z, Y, X, C) numbers, C in 1, 3, 6) as a Mitsuba
    ``.vol`` file whose header declares ``bbox`` ((min x, y, z), (max x, y, z))."""
    grid = as_grid_array(data)
    z, y, x, c = grid.shape
    lo, hi = (tuple(float(v) for v in corner) for corner in bbox)
    with open(path, "wb") as f:
        f.write(_VOL_HEADER.pack(VOL_MAGIC, VOL_VERSION, VOL_FLOAT32, x, y, z, c, *lo, *hi))
        f.write(grid.astype("<f4").tobytes())


def as_grid_array(data) -> np.ndarray:
    """``data`` ((Z, Y, X) or (Z, Y, X, C) real numbers) as a C-order float32 (Z, Y, X, C)
    array, after SceneError when its shape or type cannot be a grid."""
    arr = np.asarray(data)
    if arr.dtype.kind not in "fiu":
        raise SceneError(f"expected real numbers, got an array of {arr.dtype}")
    if arr.ndim == 3:
        arr = arr[..., None]
    if arr.ndim != 4:
        raise SceneError(f"expected a (Z, Y, X) or (Z, Y, X, C) array, got shape {arr.shape}")
    z, y, x, c = arr.shape
    _check_shape(z, y, x, c)
    return np.ascontiguousarray(arr, np.float32)


def read_npy(path) -> Grid:
    """A numpy ``.npy`` file holding a (Z, Y, X) or (Z, Y, X, C) array (x fastest, as a
    ``.vol`` file); the grid's box is the unit cube."""
    size = _file_size(path)
    fmt = np.lib.format
    try:
        with open(path, "rb") as f:
            major = fmt.read_magic(f)[0]
            header = fmt.read_array_header_1_0 if major == 1 else fmt.read_array_header_2_0
            shape, _, dtype = header(f, max_header_size=1 << 16)
            offset = f.tell()
    except (ValueError, OSError, SyntaxError, TypeError) as exc:
        raise SceneError(f"not a numpy array file ({cause(exc)})") from None
    if dtype.kind not in "fiu" or dtype.hasobject:
        raise SceneError(f"expected an array of real numbers, got {dtype}")
    if len(shape) not in (3, 4):
        raise SceneError(f"expected a (Z, Y, X) or (Z, Y, X, C) array, got shape {tuple(shape)}")
    z, y, x = shape[:3]
    _check_shape(z, y, x, shape[3] if len(shape) == 4 else 1)
    need = math.prod(shape) * dtype.itemsize
    if size - offset != need:
        raise SceneError(f"the header declares shape {tuple(shape)} of {dtype} ({need} bytes), "
                         f"the file has {size - offset} bytes after the header"
                         + (" (truncated)" if size - offset < need else ""))
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise SceneError(f"cannot read it ({cause(exc)})") from None
    return Grid(as_grid_array(data))


def read_grid(path) -> Grid:
    """A grid file by its extension: ``.vol`` or ``.npy``."""
    suffix = os.path.splitext(str(path))[1].lower()
    if suffix == ".vol":
        return read_vol(path)
    if suffix == ".npy":
        return read_npy(path)
    raise SceneError("expected a .vol (Mitsuba) or .npy (numpy) grid file")


def grid_volume(grid: Grid, to_world=None, filter: str = "trilinear", use_grid_bbox: bool = False,
                name: str = "") -> m.Volume:
    """A :class:`~glrender.scene.model.Volume` of ``grid``'s voxels over the unit cube that
    ``to_world`` places (Mitsuba's ``gridvolume``); with ``use_grid_bbox`` the cube is first
    mapped onto the box the file declares: world_from_object = to_world T(min) S(max - min)."""
    M = np.eye(4) if to_world is None else np.asarray(to_world, np.float64)
    if use_grid_bbox:
        lo, hi = (np.asarray(corner, np.float64) for corner in grid.bbox)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise SceneError(f"use_grid_bbox: the file's bounding box {_box(grid.bbox)} is empty "
                             f"or not finite")
        M = M @ m.translate(lo) @ m.scale(hi - lo)
    check_placement(M)
    return m.Volume(data=grid.data, world_from_object=M, filter=filter, name=name)


def constant_volume(value, to_world=None, name: str = "") -> m.Volume:
    """A constant over the unit cube that ``to_world`` places, as a one-voxel grid (one
    channel when the three values agree): Mitsuba's ``constvolume`` where a medium needs
    a box (a heterogeneous medium's sigma_t)."""
    rgb = np.asarray(value, np.float32).reshape(3)
    data = rgb[:1] if rgb[0] == rgb[1] == rgb[2] else rgb
    return grid_volume(Grid(data.reshape(1, 1, 1, -1).copy()), to_world, "nearest", name=name)


def check_placement(M: np.ndarray) -> None:
    """A grid's world_from_object must be finite and invertible (lookups go to object space)."""
    if not np.all(np.isfinite(M)) or abs(np.linalg.det(M[:3, :3])) < 1e-30:
        raise SceneError("the grid's transform is not finite and invertible")


def _box(bbox) -> str:
    lo, hi = bbox
    return "[" + ", ".join(f"{v:g}" for v in lo) + "] - [" + ", ".join(f"{v:g}" for v in hi) + "]"
