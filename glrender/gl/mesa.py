"""Use a newer Mesa (llvmpipe) than the system's when one was installed beside glrender.

Debian 12 ships Mesa 22.3, whose llvmpipe executes both sides of every branch,
even uniform ones; Mesa 25 (bookworm-backports) has NIR divergence analysis and
measured 1.8x faster on the Cornell box with bitwise-identical images. ``dev.sh``
unpacks Mesa 25's EGL/gallium libraries into ``<venv>/mesa`` without touching the
system, and :func:`activate` makes this process use them:

1. the bundled libraries are loaded first (``RTLD_GLOBAL``), so that when EGL opens
   the bundled ``libEGL_mesa.so.0`` its dependencies resolve to them by soname;
2. ``__EGL_VENDOR_LIBRARY_FILENAMES`` lists the system's non-Mesa EGL vendors (an
   NVIDIA driver, say) plus the bundled Mesa, so GPUs stay available.

It must run before the process first touches EGL; glrender calls it from the one
place EGL is loaded. ``GLRENDER_MESA=system`` keeps the system's Mesa;
``GLRENDER_MESA=/path`` names another unpacked Mesa root.
"""
from __future__ import annotations

import ctypes
import glob
import json
import os
import sys
from pathlib import Path

ENV = "GLRENDER_MESA"
VENDOR_FILE = "glrender_egl_vendor.json"
_VENDOR_DIRS = ("/usr/share/glvnd/egl_vendor.d", "/etc/glvnd/egl_vendor.d")
_state: dict = {"active": None, "handles": []}


def bundled_root() -> Path | None:
    choice = os.environ.get(ENV, "").strip()
    if choice.lower() == "system":
        return None
    root = Path(choice) if choice else Path(sys.prefix) / "mesa"
    return root if root.is_dir() else None


def _libdir(root: Path) -> Path | None:
    hits = glob.glob(str(root / "usr" / "lib" / "*" / "libEGL_mesa.so.0"))
    return Path(hits[0]).parent if hits else None


def activate() -> str | None:
    """Make EGL use the bundled Mesa, if there is one; returns its root (or None)."""
    if _state["active"] is not None:
        return _state["active"] or None
    _state["active"] = ""
    chosen = os.environ.get("__EGL_VENDOR_LIBRARY_FILENAMES", "")
    if chosen and VENDOR_FILE not in chosen:
        return None  # the user chose the EGL vendors explicitly (a child of ours inherits ours)
    root = bundled_root()
    libdir = _libdir(root) if root else None
    if libdir is None:
        return None
    wanted = ["libdrm.so.2", "libdrm_amdgpu.so.1", "libdrm_intel.so.1", "libgbm.so.1"]
    gallium = sorted(libdir.glob("libgallium-*.so"))
    if not gallium or not all((libdir / w).exists() for w in wanted):
        return None
    handles = []
    try:
        for name in wanted:
            handles.append(ctypes.CDLL(str(libdir / name), mode=ctypes.RTLD_GLOBAL))
        handles.append(ctypes.CDLL(str(gallium[-1]), mode=ctypes.RTLD_GLOBAL))
        handles.append(ctypes.CDLL(str(libdir / "libEGL_mesa.so.0"), mode=ctypes.RTLD_GLOBAL))
    except OSError:
        return None  # an incomplete bundle: keep the system's Mesa
    vendor = root / VENDOR_FILE
    text = json.dumps({"file_format_version": "1.0.0",
                       "ICD": {"library_path": str(libdir / "libEGL_mesa.so.0")}})
    try:
        # processes start side by side (workers, tests): never let one read a half-written
        # file (EGL would then find no Mesa): write only when it differs, and atomically
        if not vendor.is_file() or vendor.read_text() != text:
            tmp = vendor.with_name(f".{VENDOR_FILE}.{os.getpid()}")
            tmp.write_text(text)
            os.replace(tmp, vendor)
    except OSError:
        return None
    others = []
    for folder in _VENDOR_DIRS:
        others += [f for f in sorted(glob.glob(os.path.join(folder, "*.json")))
                   if "mesa" not in os.path.basename(f).lower()]
    os.environ["__EGL_VENDOR_LIBRARY_FILENAMES"] = ":".join(others + [str(vendor)])
    os.environ.setdefault("LIBGL_DRIVERS_PATH", str(libdir / "dri"))
    _state["handles"] = handles
    _state["active"] = str(root)
    return str(root)


def active_root() -> str | None:
    return _state["active"] or None
