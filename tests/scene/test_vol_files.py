"""Voxel grid files (glrender/scene/loaders/volumes.py): Mitsuba's ``.vol`` format written
and read back, its byte layout against Mitsuba's index formula, numpy ``.npy`` grids, the
placement of a grid (to_world, use_grid_bbox), and every malformed file refused with the
reason."""
import struct

import numpy as np
import pytest

from glrender.errors import SceneError
from glrender.scene import model as m
from glrender.scene.loaders import volumes
from glrender.scene.loaders.volumes import Grid, grid_volume, read_grid, read_vol, write_vol


def _vol(x=2, y=3, z=4, c=1, values=None, magic=b"VOL", version=3, encoding=1,
         box=(0, 0, 0, 1, 1, 1)) -> bytes:
    """A .vol file written by hand from Mitsuba's specification (not by write_vol)."""
    head = magic + struct.pack("<B5i6f", version, encoding, x, y, z, c, *box)
    if values is None:
        values = np.arange(max(x * y * z * c, 0), dtype="<f4")
    return head + np.asarray(values, "<f4").tobytes()


@pytest.mark.parametrize("channels", [1, 3, 6])
def test01_round_trip(tmp_path, channels):
    rng = np.random.default_rng(channels)
    data = rng.random((4, 3, 2, channels), dtype=np.float32)
    box = ((-1.0, 0.5, 2.0), (3.0, 1.5, 2.25))
    write_vol(tmp_path / "g.vol", data, box)
    grid = read_vol(tmp_path / "g.vol")
    assert grid.data.dtype == np.float32 and grid.data.shape == (4, 3, 2, channels)
    np.testing.assert_array_equal(grid.data, data)
    assert grid.bbox == box
    assert (tmp_path / "g.vol").stat().st_size == 48 + 4 * data.size


def test02_layout_is_mitsubas_index(tmp_path):
    """data[((z * yres + y) * xres + x) * channels + c] is voxel (x, y, z), channel c."""
    x_res, y_res, z_res, c_res = 5, 3, 2, 3
    flat = np.arange(x_res * y_res * z_res * c_res, dtype="<f4")
    (tmp_path / "g.vol").write_bytes(_vol(x_res, y_res, z_res, c_res, flat))
    grid = read_vol(tmp_path / "g.vol")
    for x, y, z, c in [(0, 0, 0, 0), (4, 0, 0, 1), (1, 2, 0, 2), (3, 1, 1, 0), (4, 2, 1, 2)]:
        assert grid.data[z, y, x, c] == flat[((z * y_res + y) * x_res + x) * c_res + c]
    assert m.Volume(grid.data).resolution == (x_res, y_res, z_res)
    # and write_vol writes the bytes Mitsuba's own writer would
    write_vol(tmp_path / "w.vol", grid.data)
    assert (tmp_path / "w.vol").read_bytes() == _vol(x_res, y_res, z_res, c_res, flat)


@pytest.mark.parametrize("array", [
    np.arange(24, dtype=np.float64).reshape(4, 3, 2),
    np.arange(72, dtype=np.int32).reshape(4, 3, 2, 3),
    np.asfortranarray(np.arange(24, dtype=np.float32).reshape(2, 3, 4)),
], ids=["zyx float64", "zyxc int32", "fortran order"])
def test03_npy_grids(tmp_path, array):
    np.save(tmp_path / "g.npy", array)
    grid = read_grid(tmp_path / "g.npy")
    expected = array if array.ndim == 4 else array[..., None]
    assert grid.data.dtype == np.float32 and grid.data.flags.c_contiguous
    np.testing.assert_array_equal(grid.data, expected)
    assert grid.bbox == volumes.UNIT_BOX


def test04_placement():
    grid = Grid(np.zeros((1, 1, 1, 1), np.float32), ((1.0, 2.0, 3.0), (2.0, 4.0, 7.0)))
    to_world = m.translate((10, 0, 0))
    plain = grid_volume(grid, to_world, "nearest", name="g")
    np.testing.assert_array_equal(plain.world_from_object, to_world)
    assert plain.filter == "nearest" and plain.name == "g"
    boxed = grid_volume(grid, to_world, use_grid_bbox=True)
    np.testing.assert_array_equal(boxed.world_from_object,
                                  to_world @ m.translate((1, 2, 3)) @ m.scale((1, 2, 4)))
    corners = m.transform_points(boxed.world_from_object, [[0, 0, 0], [1, 1, 1]])
    np.testing.assert_allclose(corners, [[11, 2, 3], [12, 4, 7]])
    with pytest.raises(SceneError, match=r"use_grid_bbox: the file's bounding box \[1, 2, 3\] - "
                                         r"\[1, 4, 7\] is empty or not finite"):
        grid_volume(Grid(grid.data, ((1, 2, 3), (1, 4, 7))), use_grid_bbox=True)
    with pytest.raises(SceneError, match="the grid's transform is not finite and invertible"):
        grid_volume(grid, m.scale((1, 0, 1)))


BAD_VOL = {
    "empty": (b"", r"truncated: the header has 0 of its 48 bytes"),
    "truncated header": (_vol()[:20], r"truncated: the header has 20 of its 48 bytes"),
    "wrong magic": (b"PLY" + _vol()[3:], r"not a Mitsuba volume file \(it starts with 'PLY', "
                                         r"expected 'VOL'\)"),
    "version 2": (_vol(version=2), r"version 2: only version 3 is supported"),
    "encoding 2": (_vol(encoding=2), r"encoding 2 is not supported \(only 1, float32\)"),
    "4 channels": (_vol(c=4), r"4 channels: expected 1, 3 or 6"),
    "no voxels": (_vol(x=0), r"resolution 0 x 3 x 4 \(x, y, z\): expected at least one voxel"),
    "negative size": (_vol(y=-3), r"resolution 2 x -3 x 4"),
    "truncated data": (_vol()[:-4], r"the header declares 2 x 3 x 4 voxels of 1 channel \(96 bytes "
                                    r"of float32\), the file has 92 bytes after the header \(truncated\)"),
    "extra data": (_vol() + b"\0" * 4, r"the file has 100 bytes after the header$"),
    "sizes beyond the limit": (_vol(4096, 4096, 4096, values=[]),
                               r"4096 x 4096 x 4096 voxels of 1 channel is more than the "
                               r"268,435,456 values a grid may hold"),
}


def _npy_bytes(array) -> bytes:
    import io

    out = io.BytesIO()
    np.save(out, array)
    return out.getvalue()


BAD_NPY = {
    "not numpy": (b"hello", r"not a numpy array file"),
    "2-d": (_npy_bytes(np.zeros((2, 2))), r"expected a \(Z, Y, X\) or \(Z, Y, X, C\) array, got shape \(2, 2\)"),
    "5 channels": (_npy_bytes(np.zeros((1, 1, 1, 5))), r"5 channels: expected 1, 3 or 6"),
    "complex": (_npy_bytes(np.zeros((1, 1, 1), complex)), r"expected an array of real numbers, got complex128"),
    "truncated": (_npy_bytes(np.zeros((4, 4, 4)))[:-8], r"\(512 bytes\), the file has 504 bytes after the "
                                                        r"header \(truncated\)"),
}


BAD_FILES = {**{f"g.vol: {name}": case for name, case in BAD_VOL.items()},
             **{f"g.npy: {name}": case for name, case in BAD_NPY.items()}}


@pytest.mark.parametrize("name", list(BAD_FILES))
def test05_malformed_files(tmp_path, name):
    content, pattern = BAD_FILES[name]
    path = tmp_path / name.split(":")[0]
    path.write_bytes(content)
    with pytest.raises(SceneError, match=pattern):
        read_grid(path)


def test06_other_extensions_are_refused(tmp_path):
    (tmp_path / "g.vdb").write_bytes(b"")
    with pytest.raises(SceneError, match=r"expected a \.vol \(Mitsuba\) or \.npy \(numpy\) grid file"):
        read_grid(tmp_path / "g.vdb")


def test07_writer_refuses_what_is_not_a_grid(tmp_path):
    with pytest.raises(SceneError, match="2 channels: expected 1, 3 or 6"):
        write_vol(tmp_path / "g.vol", np.zeros((1, 1, 1, 2)))
    with pytest.raises(SceneError, match=r"got shape \(3,\)"):
        write_vol(tmp_path / "g.vol", np.zeros(3))
