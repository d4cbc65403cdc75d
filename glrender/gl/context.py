"""The one place an OpenGL context is made.

Headless contexts come from EGL with an explicit device choice:

- ``auto``: the first hardware EGL device that gives an OpenGL 4.3 core context,
  else Mesa's software rasteriser (llvmpipe);
- ``cpu``: the device whose extensions include ``EGL_MESA_device_software``;
- ``gpu``: the first device without that extension;
- an integer: that EGL device index.

The choice comes from the argument, else the environment variable
``GLRENDER_DEVICE``, else ``auto``. Never ``fork()`` a process that holds a live
llvmpipe context (the child hangs): worker processes must use ``spawn``.
"""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field

import moderngl

from ..errors import DeviceError
from . import egl, mesa

REQUIRED_GL = 430
ENV_DEVICE = "GLRENDER_DEVICE"
DEVICE_CHOICES = ("auto", "cpu", "gpu")

# The limits the renderer relies on, reported by `glrender info`.
LIMIT_NAMES = (
    "GL_MAX_SHADER_STORAGE_BLOCK_SIZE",
    "GL_MAX_TEXTURE_BUFFER_SIZE",
    "GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS",
    "GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS",
    "GL_MAX_COMPUTE_WORK_GROUP_COUNT",
    "GL_MAX_COMPUTE_WORK_GROUP_SIZE",
    "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS",
    "GL_MAX_TEXTURE_SIZE",
    "GL_MAX_ARRAY_TEXTURE_LAYERS",
)
EXTENSIONS_OF_INTEREST = (
    "GL_NV_shader_atomic_float",
    "GL_ARB_gpu_shader_int64",
    "GL_ARB_shader_clock",
)


def parse_device(spec: str | int | None) -> str | int:
    """Normalise a device choice; ``None`` reads ``GLRENDER_DEVICE``."""
    source = "device"
    if spec is None:
        spec, source = os.environ.get(ENV_DEVICE, "auto"), ENV_DEVICE
    if isinstance(spec, int):
        return spec
    text = str(spec).strip().lower()
    if text in DEVICE_CHOICES:
        return text
    if text.isdigit():
        return int(text)
    raise DeviceError(f"{source}: expected auto, cpu, gpu or a device index, got {spec!r}")


def candidate_devices(spec: str | int | None) -> list[egl.EglDevice]:
    """The EGL devices to try, in order, for a device choice."""
    choice = parse_device(spec)
    devices = list(egl.list_devices())
    listing = ", ".join(d.describe() for d in devices) or "none"
    if not devices:
        raise DeviceError(f"no EGL device found: {egl.INSTALL_HINT}")
    if isinstance(choice, int):
        if choice >= len(devices):
            raise DeviceError(f"no EGL device #{choice} (devices: {listing})")
        return [devices[choice]]
    software = [d for d in devices if d.software]
    hardware = [d for d in devices if not d.software]
    if choice == "cpu":
        if not software:
            raise DeviceError(f"no software (llvmpipe) EGL device (devices: {listing}); "
                              f"{egl.INSTALL_HINT}")
        return software[:1]
    if choice == "gpu":
        if not hardware:
            raise DeviceError(f"no GPU EGL device on this machine (devices: {listing}); "
                              f"use --device cpu or auto")
        return hardware
    return hardware + software


@dataclass
class Context:
    """A live OpenGL context and the EGL device it runs on."""

    gl: moderngl.Context
    device: egl.EglDevice
    choice: str | int
    _lock: threading.RLock = field(default_factory=threading.RLock, repr=False)

    @property
    def renderer(self) -> str:
        return self.gl.info["GL_RENDERER"]

    @property
    def is_llvmpipe(self) -> bool:
        return "llvmpipe" in self.renderer

    def has_extension(self, name: str) -> bool:
        return name in self.gl.extensions

    def info(self) -> dict:
        """Renderer, version, limits and the settings that decide speed."""
        info = self.gl.info
        limits = {name: info.get(name) for name in LIMIT_NAMES}
        limits["GL_MAX_COMPUTE_SHARED_MEMORY_SIZE"] = egl.gl.get_integer(
            egl.GL.MAX_COMPUTE_SHARED_MEMORY_SIZE)
        return {
            "device": {"index": self.device.index, "kind": self.device.kind,
                       "drm_file": self.device.drm_file, "choice": str(self.choice)},
            "GL_RENDERER": info["GL_RENDERER"],
            "GL_VENDOR": info["GL_VENDOR"],
            "GL_VERSION": info["GL_VERSION"],
            "limits": {k: list(v) if isinstance(v, tuple) else v for k, v in limits.items()},
            "extensions": {name: self.has_extension(name) for name in EXTENSIONS_OF_INTEREST},
            "llvmpipe_threads": llvmpipe_threads() if self.is_llvmpipe else None,
            "shader_cache": shader_cache_location(),
            "bundled_mesa": mesa.active_root(),
        }


def llvmpipe_threads() -> int:
    """Worker threads llvmpipe uses: LP_NUM_THREADS, else the usable core count."""
    value = os.environ.get("LP_NUM_THREADS")
    if value and value.strip().isdigit():
        return int(value)
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def shader_cache_location() -> str:
    """Where Mesa keeps compiled shaders between runs (or 'disabled')."""
    if os.environ.get("MESA_SHADER_CACHE_DISABLE", "").lower() in ("1", "true", "yes"):
        return "disabled"
    for name in ("MESA_SHADER_CACHE_DIR", "MESA_GLSL_CACHE_DIR"):
        if os.environ.get(name):
            return os.environ[name]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "mesa_shader_cache")


def create_context(device: str | int | None = None, threads: int | None = None) -> Context:
    """Make a headless OpenGL >= 4.3 core context on the chosen EGL device.

    ``threads`` sets llvmpipe's worker count; it only takes effect for the first
    llvmpipe context of the process.
    """
    if threads is not None:
        if threads < 1:
            raise DeviceError(f"threads: expected a positive integer, got {threads}")
        os.environ["LP_NUM_THREADS"] = str(threads)
    choice = parse_device(device)
    libegl, libgl = egl.library_paths()
    errors = []
    for dev in candidate_devices(choice):
        saved = os.environ.pop("GLCONTEXT_DEVICE_INDEX", None)  # our choice wins
        try:
            ctx = moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL,
                                          libgl=libgl, libegl=libegl, device_index=dev.index)
        except Exception as exc:  # moderngl raises plain Exception for EGL failures
            errors.append(f"{dev.describe()}: {str(exc).strip().splitlines()[0]}")
            continue
        finally:
            if saved is not None:
                os.environ["GLCONTEXT_DEVICE_INDEX"] = saved
        return Context(ctx, dev, choice)
    raise DeviceError(f"cannot create an OpenGL {REQUIRED_GL // 100}.{REQUIRED_GL % 100 // 10} "
                      f"core context ({'; '.join(errors)}); {egl.INSTALL_HINT}")


_default: dict[str, Context] = {}
_default_lock = threading.Lock()


def default_context(device: str | int | None = None) -> Context:
    """A process-wide context per device choice, made on first use."""
    key = str(parse_device(device))
    with _default_lock:
        ctx = _default.get(key)
        if ctx is None:
            ctx = _default[key] = create_context(device)
        return ctx
