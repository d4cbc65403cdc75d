"""Image files by extension: PNG/JPEG (tonemapped 8-bit), PFM, EXR (with layers), Radiance
HDR, NPY. Every write is atomic: a temporary file in the same folder, then a rename; a write
that fails raises :class:`WriteError` naming the file and the system's reason, and leaves
the old file as it was. :func:`check_writable` is the one check, before any work, that a
file or folder can be written there.

Reading: :func:`read_image` reads an image's size from its header (:func:`declared_size`,
every format) and refuses one of more than ``max_pixels`` before decoding a pixel
(:class:`ImageTooLarge`); PIL's own decompression-bomb check, a warning at 89 million pixels
and an error at twice that, is replaced by this one wherever PIL opens a file
(:func:`open_pil`)."""
from __future__ import annotations

import os
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator

import numpy as np

from ..errors import MissingExtra, UsageError
from .tonemap import linear_to_srgb, srgb_to_linear, tonemap  # noqa: F401 (re-exported)

#: The most pixels :func:`read_image` decodes by default, whatever the image's shape and format
#: (a render may be far larger than a texture: scenes hold their images to a limit of their
#: own, glrender.scene.loaders.diagnostics.MAX_TEXTURE_PIXELS).
MAX_DECODE_PIXELS = 1 << 28

LDR_FORMATS = (".png", ".jpg", ".jpeg")
HDR_FORMATS = (".exr", ".pfm", ".npy", ".hdr")
FORMAT_NAMES = ".exr, .pfm, .hdr, .npy, .png or .jpg"


def write_pfm(path: Path, image: np.ndarray) -> None:
    img = np.asarray(image, np.float32)
    color = img.ndim == 3 and img.shape[2] == 3
    h, w = img.shape[:2]
    with open(path, "wb") as f:
        f.write(b"PF\n" if color else b"Pf\n")
        f.write(f"{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


def read_pfm(path: Path) -> np.ndarray:
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"PF", b"Pf"):
            raise UsageError(f"{path}: not a PFM file (header {kind!r})")
        try:
            w, h = map(int, f.readline().split())
            scale = float(f.readline())
        except ValueError:
            raise UsageError(f"{path}: malformed PFM header") from None
        channels = 3 if kind == b"PF" else 1
        data = np.frombuffer(f.read(), "<f4" if scale < 0 else ">f4")
        if data.size != w * h * channels:
            raise UsageError(f"{path}: expected {w}x{h}x{channels} floats, found {data.size}")
    img = data.reshape(h, w, channels)[::-1].astype(np.float32)
    return img if channels == 3 else img[..., 0]


def write_exr(path: Path, image: np.ndarray, aovs: dict | None = None, half: bool = False) -> None:
    try:
        import OpenEXR
    except ImportError:
        raise MissingExtra("EXR output", "OpenEXR", "exr") from None
    dtype = np.float16 if half else np.float32
    channels = {"RGB": np.ascontiguousarray(image[..., :3], dtype)}
    for name, value in (aovs or {}).items():
        arr = np.asarray(value, dtype)
        if arr.ndim == 3:
            for k, ch in enumerate("RGB"[:arr.shape[2]] if name != "normal" else "XYZ"):
                channels[f"{name}.{ch}"] = np.ascontiguousarray(arr[..., k])
        else:
            channels[f"{name}.{'Z' if name == 'depth' else 'Y'}"] = np.ascontiguousarray(arr)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        try:
            f.write(str(path))
        except RuntimeError as exc:     # OpenEXR's error for a failed write (a full disk, ...)
            why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise OSError(f"OpenEXR: {why}") from exc


def read_exr(path: Path) -> np.ndarray:
    try:
        import OpenEXR
    except ImportError:
        raise MissingExtra("EXR input", "OpenEXR", "exr") from None
    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        if "RGB" in channels:
            return np.asarray(channels["RGB"].pixels, np.float32)[..., :3]
        if "RGBA" in channels:
            return np.asarray(channels["RGBA"].pixels, np.float32)[..., :3]
        names = [c for c in ("R", "G", "B") if c in channels]
        if len(names) == 3:
            return np.stack([np.asarray(channels[c].pixels, np.float32) for c in names], axis=-1)
        raise UsageError(f"{path}: no RGB channels (found {', '.join(channels)})")


_CHANNEL_ORDER = {c: i for i, c in enumerate("RGBXYZA")}


def read_exr_layers(path) -> dict[str, np.ndarray]:
    """Every layer of an EXR file: ``{"RGB": (H, W, 3), "albedo": (H, W, 3), "depth": (H, W),
    ...}`` (a layer's channels in R, G, B / X, Y, Z order; one channel gives a 2D array)."""
    try:
        import OpenEXR
    except ImportError:
        raise MissingExtra("EXR input", "OpenEXR", "exr") from None
    groups: dict[str, list[tuple[str, np.ndarray]]] = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for name, channel in f.channels().items():
            layer, _, ch = name.rpartition(".")
            groups.setdefault(layer or "RGB", []).append((ch, np.asarray(channel.pixels)))
    layers = {}
    for layer, chans in groups.items():
        chans.sort(key=lambda c: _CHANNEL_ORDER.get(c[0], len(_CHANNEL_ORDER)))
        arrays = [a for _, a in chans]
        layers[layer] = arrays[0] if len(arrays) == 1 else np.stack(arrays, axis=-1)
    return layers


def _output_format(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in LDR_FORMATS + HDR_FORMATS:
        raise UsageError(f"{path}: unknown output format {ext or '(no extension)'} "
                         f"(use {FORMAT_NAMES})")
    return ext


class WriteError(UsageError):
    """A file could not be written (a full disk, a permission, a folder gone): the message
    names the file and the system's reason; the file that was there is intact."""


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc) or type(exc).__name__


def check_folder(path, what: str = "image") -> Path:
    """The folder ``path`` goes into, or an error saying why it cannot."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{path}: {folder} is a file, not a folder (choose another path for "
                         f"the {what})")
    if not folder.is_dir():
        raise UsageError(f"{path}: the folder {folder} for the {what} does not exist "
                         f"(create it first)")
    return folder


def check_writable(path, what: str, option: str | None = None, *, folder: bool = False) -> Path:
    """Fail early, before any work, unless the ``what`` can be written at ``path``: a file
    (its folder exists, is a folder and takes a new file; ``path`` is not a folder) or, with
    ``folder``, a folder of files (created with its parents when missing). The probe is
    real: a temporary file created beside it and removed again, so permissions, read-only
    file systems, quotas and pseudo file systems (``/proc``, where ``os.access`` answers yes
    to root) are all caught. ``option`` (``--stats``, ...) opens the message and names what
    to change."""
    path = Path(path)
    name = f"{option} {path}" if option else str(path)
    fix = f"choose another {option}" if option else "choose another path"
    if folder:
        if path.exists() and not path.is_dir():
            raise UsageError(f"{name}: is a file, expected a folder for the {what}")
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"{name}: cannot create the folder for the {what} ({_why(exc)}); "
                             f"{fix}") from None
        where = path
    else:
        try:
            where = check_folder(path, what)
        except UsageError as exc:
            raise UsageError(f"{option} {exc}" if option else str(exc)) from None
        if path.is_dir():
            raise UsageError(f"{name}: is a folder, expected a file name for the {what}")
        if path.exists() and not path.is_file():
            raise UsageError(f"{name}: is not a regular file (a device, a pipe or a socket), "
                             f"expected a file name for the {what}")
    try:
        fd, probe = tempfile.mkstemp(prefix=".glrender-probe-", dir=where)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise UsageError(f"{name}: cannot write to the folder {where} ({_why(exc)}); "
                         f"{fix}") from None
    return path


def check_output(path) -> Path:
    """Fail early (before a render) if the image ``path`` cannot be written: unknown
    extension, EXR without its package, then :func:`check_writable`."""
    path = Path(path)
    ext = _output_format(path)
    if ext == ".exr":
        try:
            import OpenEXR  # noqa: F401
        except ImportError:
            raise MissingExtra(f"{path}: EXR output (or write .pfm)", "OpenEXR", "exr") from None
    return check_writable(path, "image", "-o")


def atomic_write(path, write) -> None:
    """``write(tmp)`` into a temporary file beside ``path``, then rename it over ``path``:
    an interrupted or failed write never leaves a broken file, and the file that was there
    stays as it was. A failure of the system (:class:`OSError`: a full disk, a permission,
    a folder gone; writers turn their library's I/O errors into one) is a
    :class:`WriteError` naming ``path``; other exceptions pass through."""
    path = Path(path)
    tmp = None
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix,
                                    dir=path.parent if str(path.parent) else ".")
        os.close(fd)
        tmp = Path(name)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # as open() would create it, not mkstemp's 0600
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        raise WriteError(f"{path}: cannot write ({_why(exc)})") from exc
    finally:
        if tmp is not None:
            try:
                tmp.unlink()
            except OSError:
                pass            # renamed into place, or the folder is gone


def write_image(path, image: np.ndarray, aovs: dict | None = None, exposure: float = 0.0,
                half: bool = False, curve: str = "clamp", srgb: bool = True) -> None:
    """Write by extension, atomically: .png/.jpg (exposure, tone curve, sRGB: 8-bit),
    .exr (float32, or half, with ``aovs`` as extra layers), .pfm, .hdr (Radiance RGBE),
    .npy (float32). Only EXR stores ``aovs``; other formats write RGB alone."""
    path = Path(path)
    ext = _output_format(path)
    check_folder(path)
    image = np.asarray(image)
    rgb = image[..., :3] if image.ndim == 3 else image

    def write(tmp: Path) -> None:
        if ext in LDR_FORMATS:
            from PIL import Image

            pixels = tonemap(rgb, exposure, curve, srgb)
            if ext == ".png":
                Image.fromarray(pixels).save(tmp, format="PNG")
            else:
                Image.fromarray(pixels).save(tmp, format="JPEG", quality=95)
        elif ext == ".pfm":
            write_pfm(tmp, rgb)
        elif ext == ".npy":
            with open(tmp, "wb") as f:
                np.save(f, np.asarray(rgb, np.float32))
        elif ext == ".hdr":
            from .radiance_hdr import write_hdr

            write_hdr(tmp, rgb)
        else:
            write_exr(tmp, image, aovs=aovs, half=half)

    atomic_write(path, write)


class ImageTooLarge(UsageError):
    """An image whose header declares more pixels than the reader allows."""

    def __init__(self, path, width: int, height: int, limit: int, what: str = "an image"):
        self.width, self.height, self.limit = width, height, limit
        side = int(limit ** 0.5)
        shape = f" ({side} x {side})" if side * side == limit else ""
        super().__init__(f"{path}: {width} x {height} pixels is more than the {limit:,}{shape} "
                         f"{what} may have")


_PIL_CHECK = threading.RLock()


@contextmanager
def open_pil(source: str | os.PathLike[str] | IO[bytes]) -> Iterator:
    """``PIL.Image.open`` without PIL's decompression-bomb warning or error: the caller
    checks the size (``im.size``) against its own limit before decoding, as
    :func:`read_image` does."""
    from PIL import Image

    with _PIL_CHECK:          # PIL's limit is global: ours holds while this file is open
        saved, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
        try:
            with Image.open(source) as im:
                yield im
        finally:
            Image.MAX_IMAGE_PIXELS = saved


def declared_size(path) -> tuple[int, int]:
    """(width, height) an image file's header declares, read without decoding a pixel."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".pfm":
        with open(path, "rb") as f:
            f.readline()
            fields = f.readline().split()
        if len(fields) != 2 or not all(x.isdigit() for x in fields):
            raise UsageError(f"{path}: malformed PFM header")
        return int(fields[0]), int(fields[1])
    if ext == ".npy":
        with open(path, "rb") as f:
            try:
                fmt = np.lib.format
                major = fmt.read_magic(f)[0]
                header = fmt.read_array_header_1_0 if major == 1 else fmt.read_array_header_2_0
                shape = header(f, max_header_size=1 << 16)[0]
            except (ValueError, OSError, SyntaxError, TypeError) as exc:
                raise UsageError(f"{path}: not a numpy array file ({exc})") from None
        if len(shape) < 2:            # not an image: its elements count, its reader says why
            return int(np.prod(shape, dtype=np.int64)), 1
        return int(shape[1]), int(shape[0])
    if ext == ".exr":
        try:
            import OpenEXR
        except ImportError:
            raise MissingExtra("EXR input", "OpenEXR", "exr") from None
        with OpenEXR.File(str(path), header_only=True) as f:
            lo, hi = f.header()["dataWindow"]
        return int(hi[0]) - int(lo[0]) + 1, int(hi[1]) - int(lo[1]) + 1
    if ext == ".hdr":
        from .radiance_hdr import read_header

        with open(path, "rb") as f:
            return read_header(path, f.read(1 << 20))[:2]
    with open_pil(path) as im:
        return im.size


def read_image(path, max_pixels: int = MAX_DECODE_PIXELS, what: str = "an image") -> np.ndarray:
    """Read linear RGB float32 (H, W, 3) from .exr, .hdr, .pfm, .npy; LDR files are
    sRGB-decoded. An image of more than ``max_pixels`` is refused from its header
    (:class:`ImageTooLarge`, saying ``what`` may have at most that many)."""
    path = Path(path)
    ext = path.suffix.lower()
    if not path.exists():
        raise UsageError(f"{path}: no such file")
    width, height = declared_size(path)
    if width * height > max_pixels:
        raise ImageTooLarge(path, width, height, max_pixels, what)
    if ext == ".pfm":
        return read_pfm(path)
    if ext == ".npy":
        return np.load(path).astype(np.float32)
    if ext == ".exr":
        return read_exr(path)
    if ext == ".hdr":
        from .radiance_hdr import read_hdr

        return read_hdr(path)
    if ext == ".png" and _png_depth_and_colour(path) in ((16, 2), (16, 6)):
        return _read_png_rgb16(path)
    with open_pil(path) as im:
        if im.mode in ("I;16", "I;16L", "I;16B", "I"):     # 16-bit grey (PNG, TIFF)
            grey = np.asarray(im, np.float64) / 65535.0
            return np.repeat(srgb_to_linear(np.clip(grey, 0.0, 1.0))[..., None], 3, axis=-1) \
                .astype(np.float32)
        if im.mode == "F":                                   # 32-bit float grey (TIFF): linear
            return np.repeat(np.asarray(im, np.float32)[..., None], 3, axis=-1)
        return srgb_to_linear(np.asarray(im.convert("RGB"), np.float64) / 255.0).astype(np.float32)


def _png_depth_and_colour(path: Path) -> tuple[int, int] | None:
    """(bit depth, colour type) from a PNG's IHDR chunk, None if the file is not a PNG."""
    with open(path, "rb") as f:
        head = f.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    return head[24], head[25]


def _read_png_rgb16(path: Path) -> np.ndarray:
    """A 16-bit RGB or RGBA PNG at full precision (Pillow reduces these to 8 bits)."""
    import png

    width, height, rows, info = png.Reader(filename=str(path)).asDirect()
    planes = info["planes"]
    data = np.vstack([np.asarray(row, np.uint16) for row in rows]).reshape(height, width, planes)
    rgb = data[..., :3].astype(np.float64) / 65535.0
    return srgb_to_linear(rgb).astype(np.float32)
