"""Radiance RGBE (.hdr / .pic) images: reader and writer.

Format (Greg Ward, "Real Pixels", Graphics Gems II): a text header ending in a blank
line, a resolution line ``-Y H +X W`` (top row first; other orientations are
flipped to it), then scanlines of RGBE pixels, either flat or new-style run-length
encoded (each of the four channels separately: a count byte > 128 repeats the next
byte count - 128 times, otherwise that many literal bytes follow). The value is
(R, G, B) * 2^(E - 136) for E > 0 and 0 for E = 0.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError



def _fail(path, message):
    raise UsageError(f"{path}: {message}")


def _decode_rle_scanline(data: bytes, pos: int, width: int, path, row: int) -> tuple[np.ndarray, int]:
    """One new-style RLE scanline starting at data[pos] (after the 4-byte marker)."""
    out = np.empty((4, width), np.uint8)
    for channel in range(4):
        x = 0
        buf = out[channel]
        while x < width:
            if pos >= len(data):
                _fail(path, f"scanline {row}: the file ends inside a run")
            count = data[pos]
            pos += 1
            if count > 128:
                count -= 128
                if x + count > width or pos >= len(data):
                    _fail(path, f"scanline {row}: a run overflows the scanline")
                buf[x:x + count] = data[pos]
                pos += 1
            else:
                if count == 0 or x + count > width or pos + count > len(data):
                    _fail(path, f"scanline {row}: a literal run overflows the scanline")
                buf[x:x + count] = np.frombuffer(data, np.uint8, count, pos)
                pos += count
            x += count
    return out.T, pos


def read_header(path, data: bytes) -> tuple[int, int, list[str], int]:
    """(width, height, the resolution line's fields, the offset of the first scanline) from
    the start of a Radiance file's ``data``; the size is not checked against any limit."""
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        _fail(path, "not a Radiance HDR file (expected '#?RADIANCE' or '#?RGBE' on line 1)")
    end = data.find(b"\n\n")
    if end < 0:
        _fail(path, "header does not end with a blank line")
    header = data[:end].decode("latin-1").splitlines()
    for line in header:
        if line.startswith("FORMAT=") and line.strip() != "FORMAT=32-bit_rle_rgbe":
            _fail(path, f"unsupported pixel format {line.strip()!r} (expected 32-bit_rle_rgbe)")
    pos = end + 2
    nl = data.find(b"\n", pos)
    if nl < 0:
        _fail(path, "missing resolution line")
    parts = data[pos:nl].decode("latin-1").split()
    if len(parts) != 4 or parts[0][1:] not in "YX" or parts[2][1:] not in "YX":
        _fail(path, f"unsupported resolution line {data[pos:nl]!r}")
    try:
        n0, n1 = int(parts[1]), int(parts[3])
    except ValueError:
        _fail(path, f"malformed resolution line {data[pos:nl]!r}")
    if n0 <= 0 or n1 <= 0:
        _fail(path, f"image size {n0} x {n1}: expected positive sizes")
    height, width = (n0, n1) if parts[0][1] == "Y" else (n1, n0)
    return width, height, parts, nl + 1


def read_hdr(path, max_pixels: int | None = None) -> np.ndarray:
    """Linear RGB float32 (H, W, 3), top row first; an image of more than ``max_pixels``
    (default: glrender.film.io.MAX_DECODE_PIXELS) is refused from its header."""
    from .io import MAX_DECODE_PIXELS, ImageTooLarge

    path = Path(path)
    data = path.read_bytes()
    width, height, parts, pos = read_header(path, data)
    limit = MAX_DECODE_PIXELS if max_pixels is None else max_pixels
    if width * height > limit:
        raise ImageTooLarge(path, width, height, limit)
    n0, n1 = int(parts[1]), int(parts[3])
    rows_are_y = parts[0][1] == "Y"
    scan_len, scans = (n1, n0)
    rgbe = np.empty((scans, scan_len, 4), np.uint8)
    for row in range(scans):
        if (8 <= scan_len < 32768 and pos + 4 <= len(data) and data[pos] == 2 and data[pos + 1] == 2
                and (data[pos + 2] & 0x80) == 0):
            if (data[pos + 2] << 8 | data[pos + 3]) != scan_len:
                _fail(path, f"scanline {row}: length marker does not match the width {scan_len}")
            rgbe[row], pos = _decode_rle_scanline(data, pos + 4, scan_len, path, row)
        else:  # flat (or old-style RLE, which no current writer produces: rejected below)
            need = 4 * scan_len
            if pos + need > len(data):
                _fail(path, f"scanline {row}: the file ends early ({len(data) - pos} of {need} bytes)")
            flat = np.frombuffer(data, np.uint8, need, pos).reshape(scan_len, 4)
            if np.any((flat[:, 0] == 1) & (flat[:, 1] == 1) & (flat[:, 2] == 1)):
                _fail(path, "old-style run-length encoding is not supported")
            rgbe[row] = flat
            pos += need
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0).astype(np.float32)
    img = rgbe[..., :3].astype(np.float32) * scale[..., None]
    # orientation: make rows top to bottom, columns left to right
    if not rows_are_y:
        img = img.transpose(1, 0, 2)
    if parts[0][0] == "+" and rows_are_y:
        img = img[::-1]
    if parts[2][0] == "-" and rows_are_y:
        img = img[:, ::-1]
    return np.ascontiguousarray(img)


def write_hdr(path, image: np.ndarray) -> None:
    """Flat (uncompressed) RGBE, top row first."""
    img = np.asarray(image, np.float64)[..., :3]
    h, w = img.shape[:2]
    m = img.max(axis=-1)
    e = np.zeros(m.shape, np.int32)
    mant = np.zeros(m.shape)
    ok = m > 1e-32
    mant[ok], e[ok] = np.frexp(m[ok])
    rgbe = np.zeros((h, w, 4), np.uint8)
    scale = np.where(ok, mant * 256.0 / np.where(ok, m, 1.0), 0.0)
    rgbe[..., :3] = np.clip(img * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(ok, e + 128, 0)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode())
        f.write(rgbe.tobytes())
