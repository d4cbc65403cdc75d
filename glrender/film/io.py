"""Image files: PNG (tonemapped sRGB), PFM, EXR, NPY by extension; Radiance HDR and EXR input."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import UsageError

LDR_FORMATS = (".png", ".jpg", ".jpeg")
HDR_FORMATS = (".exr", ".pfm", ".npy", ".hdr")


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def tonemap(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear RGB -> 8-bit sRGB (exposure in stops, then clamp)."""
    scaled = np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0) * (2.0 ** exposure)
    return np.round(linear_to_srgb(scaled) * 255.0).astype(np.uint8)


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
        raise UsageError("EXR output needs the OpenEXR package: pip install 'glrender[exr]'") from None
    dtype = np.float16 if half else np.float32
    channels = {"RGB": np.ascontiguousarray(image[..., :3], dtype)}
    for name, value in (aovs or {}).items():
        arr = np.asarray(value, dtype)
        if arr.ndim == 3:
            for k, ch in enumerate("RGB"[:arr.shape[2]] if name != "normal" else "XYZ"):
                channels[f"{name}.{ch}"] = np.ascontiguousarray(arr[..., k])
        else:
            channels[f"{name}.Y"] = np.ascontiguousarray(arr)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


def read_exr(path: Path) -> np.ndarray:
    try:
        import OpenEXR
    except ImportError:
        raise UsageError("EXR input needs the OpenEXR package: pip install 'glrender[exr]'") from None
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


def write_image(path, image: np.ndarray, aovs: dict | None = None, exposure: float = 0.0,
                half: bool = False) -> None:
    """Write by extension: .png/.jpg (tonemapped sRGB), .pfm, .exr (with AOV layers), .npy."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in LDR_FORMATS + HDR_FORMATS or ext == ".hdr":
        raise UsageError(f"{path}: unsupported output format {ext or '(none)'} "
                         f"(expected .png, .jpg, .exr, .pfm or .npy)")
    if path.parent and not path.parent.exists():
        raise UsageError(f"{path}: the folder {path.parent} does not exist")
    tmp = path.with_name(path.name + ".part" + ext)
    try:
        if ext in LDR_FORMATS:
            from PIL import Image

            Image.fromarray(tonemap(image[..., :3], exposure)).save(tmp, quality=95) \
                if ext != ".png" else Image.fromarray(tonemap(image[..., :3], exposure)).save(tmp)
        elif ext == ".pfm":
            write_pfm(tmp, image[..., :3])
        elif ext == ".npy":
            np.save(tmp, np.asarray(image[..., :3], np.float32))
            if not tmp.exists() and Path(str(tmp) + ".npy").exists():
                os.replace(str(tmp) + ".npy", tmp)
        else:
            write_exr(tmp, image, aovs=aovs, half=half)
        os.replace(tmp, path)  # atomic: an interrupted write never leaves a broken file
    finally:
        if tmp.exists():
            tmp.unlink()


def read_image(path) -> np.ndarray:
    """Read linear RGB float32 (H, W, 3) from .exr, .hdr, .pfm, .npy; LDR files are sRGB-decoded."""
    path = Path(path)
    ext = path.suffix.lower()
    if not path.exists():
        raise UsageError(f"{path}: no such file")
    if ext == ".pfm":
        return read_pfm(path)
    if ext == ".npy":
        return np.load(path).astype(np.float32)
    if ext == ".exr":
        return read_exr(path)
    if ext == ".hdr":
        from .radiance_hdr import read_hdr

        return read_hdr(path)
    from PIL import Image

    with Image.open(path) as im:
        return srgb_to_linear(np.asarray(im.convert("RGB"), np.float64) / 255.0).astype(np.float32)
