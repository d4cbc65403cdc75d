"""EGL and raw OpenGL entry points through ctypes: the one place glrender talks to
the driver below moderngl.

moderngl covers programs, buffers and dispatches; what it lacks (EGL device
enumeration, buffer textures, a few ``glGetIntegerv`` queries) is loaded here,
from the same libEGL that moderngl's EGL backend uses.
"""
from __future__ import annotations

import ctypes
import ctypes.util
from dataclasses import dataclass
from functools import lru_cache

from ..errors import DeviceError

EGL_EXTENSIONS = 0x3055
EGL_DRM_DEVICE_FILE_EXT = 0x3233
EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377

# Debian package names that provide what is missing, for error messages.
APT_PACKAGES = "libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri"
INSTALL_HINT = f"install EGL and Mesa with `sudo apt-get install {APT_PACKAGES}`"


@lru_cache(maxsize=None)
def library_paths() -> tuple[str, str]:
    """(libEGL, libGL) sonames, or DeviceError naming the package to install."""
    from . import mesa

    mesa.activate()  # before anything loads EGL
    egl = ctypes.util.find_library("EGL")
    gl = ctypes.util.find_library("GL")
    missing = [name for name, path in (("libEGL", egl), ("libGL", gl)) if path is None]
    if missing:
        raise DeviceError(f"{' and '.join(missing)} not found: {INSTALL_HINT}")
    return egl, gl


@lru_cache(maxsize=None)
def _libegl() -> ctypes.CDLL:
    egl_path, _ = library_paths()
    try:
        lib = ctypes.CDLL(egl_path)
    except OSError as exc:  # pragma: no cover - broken installation
        raise DeviceError(f"cannot load {egl_path} ({exc}): {INSTALL_HINT}") from None
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return lib


def get_proc_address(name: str) -> int:
    """Address of an EGL or GL function (0 when the driver does not have it)."""
    return _libegl().eglGetProcAddress(name.encode()) or 0


def _proc(name: str, restype, *argtypes):
    address = get_proc_address(name)
    if not address:
        raise DeviceError(f"the EGL/GL driver has no {name}: {INSTALL_HINT}")
    return ctypes.CFUNCTYPE(restype, *argtypes)(address)


@dataclass(frozen=True)
class EglDevice:
    """One EGL device, in the order eglQueryDevicesEXT (and moderngl) number them."""

    index: int
    extensions: tuple[str, ...]
    drm_file: str | None

    @property
    def software(self) -> bool:
        return "EGL_MESA_device_software" in self.extensions

    @property
    def kind(self) -> str:
        return "cpu" if self.software else "gpu"

    def describe(self) -> str:
        where = f" ({self.drm_file})" if self.drm_file else ""
        return f"#{self.index} {self.kind}{where}"


@lru_cache(maxsize=None)
def list_devices() -> tuple[EglDevice, ...]:
    """Every EGL device of this machine (EGL_EXT_device_enumeration)."""
    query_devices = _proc("eglQueryDevicesEXT", ctypes.c_uint, ctypes.c_int,
                          ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int))
    query_string = _proc("eglQueryDeviceStringEXT", ctypes.c_char_p, ctypes.c_void_p,
                         ctypes.c_int)
    count = ctypes.c_int(0)
    if not query_devices(0, None, ctypes.byref(count)):
        raise DeviceError(f"eglQueryDevicesEXT failed: {INSTALL_HINT}")
    handles = (ctypes.c_void_p * max(count.value, 1))()
    if count.value and not query_devices(count.value, handles, ctypes.byref(count)):
        raise DeviceError(f"eglQueryDevicesEXT failed: {INSTALL_HINT}")
    devices = []
    for index in range(count.value):
        extensions = (query_string(handles[index], EGL_EXTENSIONS) or b"").decode().split()
        drm_file = None
        if "EGL_EXT_device_drm" in extensions:
            raw = query_string(handles[index], EGL_DRM_DEVICE_FILE_EXT)
            drm_file = raw.decode() if raw else None
        devices.append(EglDevice(index, tuple(extensions), drm_file))
    return tuple(devices)


class GL:
    """The handful of raw GL calls moderngl does not expose.

    Functions are resolved lazily through eglGetProcAddress, so this is usable
    only while a context is current (every moderngl standalone context is).
    """

    TEXTURE_BUFFER = 0x8C2A
    TEXTURE0 = 0x84C0
    R32F, RG32F, RGBA32F = 0x822E, 0x8230, 0x8814
    R32UI, RG32UI, RGBA32UI = 0x8236, 0x823C, 0x8D70
    R32I, RG32I, RGBA32I = 0x8235, 0x823B, 0x8D82
    MAX_COMPUTE_SHARED_MEMORY_SIZE = 0x8262
    TEXTURE_BINDING_BUFFER = 0x8C2C
    ACTIVE_TEXTURE = 0x84E0

    _signatures = {
        "glGenTextures": (None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)),
        "glDeleteTextures": (None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)),
        "glBindTexture": (None, ctypes.c_uint, ctypes.c_uint),
        "glActiveTexture": (None, ctypes.c_uint),
        "glTexBuffer": (None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint),
        "glGetIntegerv": (None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int)),
        "glGetError": (ctypes.c_uint,),
        "glFinish": (None,),
    }

    def __init__(self):
        self._cache = {}

    def __getattr__(self, name):
        if name not in self._signatures:
            raise AttributeError(name)
        fn = self._cache.get(name)
        if fn is None:
            restype, *argtypes = self._signatures[name]
            fn = self._cache[name] = _proc(name, restype, *argtypes)
        return fn

    def get_integer(self, pname: int) -> int:
        value = ctypes.c_int(0)
        self.glGetIntegerv(pname, ctypes.byref(value))
        return value.value


gl = GL()
