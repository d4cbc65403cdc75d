"""Image input edge cases: 16-bit PNG (grey, RGB, RGBA) at full precision, EXR with half and
float channels, and one-line errors for truncated or corrupt files."""
from __future__ import annotations

import numpy as np
import png
import pytest

from glrender.errors import SceneError
from glrender.film.io import read_image
from glrender.film.tonemap import srgb_to_linear
from glrender.scene.loaders.diagnostics import read_image_checked

RNG = np.random.default_rng(7)


def write_png16(path, data: np.ndarray) -> None:
    h, w = data.shape[:2]
    planes = 1 if data.ndim == 2 else data.shape[2]
    writer = png.Writer(w, h, bitdepth=16, greyscale=planes in (1, 2), alpha=planes in (2, 4))
    with open(path, "wb") as f:
        writer.write(f, data.reshape(h, w * planes).tolist())


def expected(values16: np.ndarray) -> np.ndarray:
    return srgb_to_linear(values16.astype(np.float64) / 65535.0).astype(np.float32)


@pytest.mark.parametrize("planes", [1, 3, 4])
def test01_png16_full_precision(tmp_path, planes):
    shape = (5, 7) if planes == 1 else (5, 7, planes)
    data = RNG.integers(0, 65536, shape, dtype=np.uint16)
    data.flat[0] = 1000          # 8 bits would make this 3/255 (0.0118 linear: 1000/65535 is 0.0012)
    write_png16(tmp_path / "t.png", data)
    got = read_image(tmp_path / "t.png")
    rgb = np.repeat(data[..., None], 3, axis=-1) if planes == 1 else data[..., :3]
    assert got.shape == (5, 7, 3) and got.dtype == np.float32
    np.testing.assert_allclose(got, expected(rgb), rtol=1e-6, atol=1e-9)


def test02_png8_unchanged(tmp_path):
    from PIL import Image

    data = RNG.integers(0, 256, (4, 6, 3), dtype=np.uint8)
    Image.fromarray(data).save(tmp_path / "t.png")
    got = read_image(tmp_path / "t.png")
    np.testing.assert_allclose(got, srgb_to_linear(data / 255.0).astype(np.float32), rtol=1e-6)


@pytest.mark.parametrize("half", [True, False])
def test03_exr_half_and_float_channels(tmp_path, half):
    import OpenEXR

    data = RNG.uniform(0.0, 50.0, (6, 9, 3)).astype(np.float32)
    pixels = data.astype(np.float16) if half else data
    channels = {c: np.ascontiguousarray(pixels[..., i]) for i, c in enumerate("RGB")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(tmp_path / "t.exr"))
    got = read_image(tmp_path / "t.exr")
    assert got.dtype == np.float32 and got.shape == data.shape
    np.testing.assert_array_equal(got, pixels.astype(np.float32))


@pytest.mark.parametrize("name, content", [
    ("cut16.png", "truncated 16-bit"),
    ("cut8.png", "truncated 8-bit"),
    ("garbage.png", "not an image"),
    ("cut.exr", "truncated EXR"),
])
def test04_corrupt_images_give_one_line_errors(tmp_path, name, content):
    path = tmp_path / name
    if content == "truncated 16-bit":
        write_png16(path, RNG.integers(0, 65536, (64, 64, 3), dtype=np.uint16))
        path.write_bytes(path.read_bytes()[:200])
    elif content == "truncated 8-bit":
        from PIL import Image

        Image.fromarray(RNG.integers(0, 256, (64, 64, 3), dtype=np.uint8)).save(path)
        path.write_bytes(path.read_bytes()[:200])
    elif content == "not an image":
        path.write_bytes(b"this is not a PNG file at all")
    else:
        import OpenEXR

        channels = {c: np.ones((32, 32), np.float32) for c in "RGB"}
        with OpenEXR.File({"compression": OpenEXR.NO_COMPRESSION,
                           "type": OpenEXR.scanlineimage}, channels) as f:
            f.write(str(path))
        path.write_bytes(path.read_bytes()[:300])
    with pytest.raises(SceneError) as info:       # the reason alone: the loader names the file
        read_image_checked(path)
    message = str(info.value)
    assert message.startswith("cannot decode it (") and "\n" not in message, message
    assert str(path) not in message and name not in message, message
