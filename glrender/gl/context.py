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

Window contexts (the preview) come from :func:`create_window_context`: a glfw
window whose OpenGL >= 4.3 core context runs the same compute kernels; its
driver is the display's, so ``Context.device`` is None there.
"""
from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import moderngl

from ..errors import DeviceError, MissingExtra
from . import egl, mesa

T = TypeVar("T")

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
    "GL_ARB_shader_ballot",
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
    """A live OpenGL context and the EGL device it runs on (None for a window's
    context, whose driver is the display's; ``window`` is then its glfw window)."""

    gl: moderngl.Context
    device: egl.EglDevice | None
    choice: str | int
    _lock: threading.RLock = field(default_factory=threading.RLock, repr=False)
    window: object = field(default=None, repr=False)

    @property
    def renderer(self) -> str:
        return self.gl.info["GL_RENDERER"]

    @property
    def is_llvmpipe(self) -> bool:
        return "llvmpipe" in self.renderer

    def make_current(self) -> None:
        """Make this context the current one of the calling thread. A process may hold
        several (other devices, a command run in-process), and GL calls go to whichever
        is current: the renderers call this at each entry point (see :func:`current`)."""
        self.gl.__enter__()

    def has_extension(self, name: str) -> bool:
        return name in self.gl.extensions

    def traversal(self) -> str:
        """Which BVH traversal the kernels run here, in words (``glrender info``)."""
        ballot = self.has_extension("GL_ARB_shader_ballot") and \
            self.has_extension("GL_ARB_gpu_shader_int64")
        return ("4-wide BVH, per lane (render kernels); 8-wide cooperative traversal and the "
                "wavefront's one-atomic-per-subgroup queues " +
                ("available (subgroup ballots)" if ballot else
                 "fall back to per lane and per path (no subgroup ballots)"))

    def info(self) -> dict:
        """Renderer, version, limits and the settings that decide speed."""
        info = self.gl.info
        limits = {name: info.get(name) for name in LIMIT_NAMES}
        limits["GL_MAX_COMPUTE_SHARED_MEMORY_SIZE"] = egl.gl.get_integer(
            egl.GL.MAX_COMPUTE_SHARED_MEMORY_SIZE)
        if self.device is None:
            device = {"index": None, "kind": "window", "drm_file": None, "choice": str(self.choice)}
        else:
            device = {"index": self.device.index, "kind": self.device.kind,
                      "drm_file": self.device.drm_file, "choice": str(self.choice)}
        return {
            "device": device,
            "GL_RENDERER": info["GL_RENDERER"],
            "GL_VENDOR": info["GL_VENDOR"],
            "GL_VERSION": info["GL_VERSION"],
            "limits": {k: list(v) if isinstance(v, tuple) else v for k, v in limits.items()},
            "extensions": {name: self.has_extension(name) for name in EXTENSIONS_OF_INTEREST},
            "traversal": self.traversal(),
            "llvmpipe_threads": llvmpipe_threads() if self.is_llvmpipe else None,
            "shader_cache": shader_cache_location(),
            "bundled_mesa": mesa.active_root(),
        }


def current(method: Callable[..., T]) -> Callable[..., T]:
    """Decorator for the methods of an object with a ``ctx`` (:class:`Context`) that touch
    the device: its context is made current first."""
    @functools.wraps(method)
    def run(self: Any, *args: Any, **kwargs: Any) -> T:
        self.ctx.make_current()
        return method(self, *args, **kwargs)
    return run


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


# -- window contexts (glfw) -------------------------------------------------------------------
NO_DISPLAY_HINT = ("render to a file with `glrender render SCENE -o image.png`, or run under a "
                   "virtual display: `xvfb-run -a glrender preview SCENE`")


def _glfw():
    try:
        import glfw
    except ImportError:
        raise MissingExtra("a window", "glfw", "preview") from None
    return glfw


def _window_hints(glfw, api: int, visible: bool) -> None:
    glfw.default_window_hints()
    glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_GL // 100)
    glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_GL % 100 // 10)
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
    glfw.window_hint(glfw.CONTEXT_CREATION_API, api)
    glfw.window_hint(glfw.VISIBLE, visible)
    glfw.window_hint(glfw.DOUBLEBUFFER, True)


def create_window_context(width: int, height: int, title: str = "glrender", *,
                          device: str | int | None = None, threads: int | None = None,
                          visible: bool = True) -> Context:
    """Open a glfw window with an OpenGL >= 4.3 core context, current on this thread.

    The context is made through EGL first (so the bundled Mesa of ``glrender.gl.mesa``
    serves the window as it serves headless contexts), else through the platform's
    native API (GLX). ``device``: ``auto`` takes the display's driver, ``cpu`` forces
    Mesa's software rasteriser, ``gpu`` refuses llvmpipe; an EGL device index cannot
    choose a window's driver. Without a display this raises a one-line DeviceError
    that names the alternatives. The caller owns the window: destroy it and call
    ``glfw.terminate()`` when done (``Context.window``).
    """
    glfw = _glfw()
    choice = parse_device(device)
    if isinstance(choice, int):
        raise DeviceError(f"device {choice}: an EGL device index picks a headless device; a "
                          f"window runs on the display's driver (use auto, cpu or gpu)")
    if threads is not None:
        if threads < 1:
            raise DeviceError(f"threads: expected a positive integer, got {threads}")
        os.environ["LP_NUM_THREADS"] = str(threads)
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise DeviceError(f"no display for a window (DISPLAY is not set): {NO_DISPLAY_HINT}")
    errors: list[str] = []
    glfw.set_error_callback(lambda code, text: errors.append(
        text.decode(errors="replace") if isinstance(text, bytes) else str(text)))
    if not glfw.init():
        where = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        raise DeviceError(f"cannot open the display {where} ({'; '.join(errors) or 'glfw.init failed'}):"
                          f" {NO_DISPLAY_HINT}")
    saved_env = {}
    if choice == "cpu":  # Mesa's software rasteriser, whatever the display's driver is
        saved_env = {k: os.environ.get(k) for k in ("LIBGL_ALWAYS_SOFTWARE", "__GLX_VENDOR_LIBRARY_NAME")}
        os.environ.update(LIBGL_ALWAYS_SOFTWARE="1", __GLX_VENDOR_LIBRARY_NAME="mesa")
    try:
        window, gl = _open_window(glfw, width, height, title, visible, errors)
    finally:
        for key, value in saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    renderer = gl.info["GL_RENDERER"]
    software = "llvmpipe" in renderer
    if (choice == "gpu" and software) or (choice == "cpu" and not software):
        glfw.destroy_window(window)
        glfw.terminate()
        raise DeviceError(f"device {choice}: the display's OpenGL driver is {renderer}; "
                          f"use device auto")
    return Context(gl, None, choice, window=window)


def _open_window(glfw, width: int, height: int, title: str, visible: bool, errors: list[str]):
    """(window, moderngl context): EGL first, then the native API."""
    try:
        egl.library_paths()  # activates the bundled Mesa (if any) before EGL loads
    except DeviceError:
        pass
    attempts = [("EGL", glfw.EGL_CONTEXT_API), ("native", glfw.NATIVE_CONTEXT_API)]
    failures = []
    for name, api in attempts:
        restore = None
        root = mesa.active_root()
        drivers = os.environ.get("LIBGL_DRIVERS_PATH", "")
        if api == glfw.NATIVE_CONTEXT_API and root and drivers.startswith(root):
            # GLX loads the system's libGLX_mesa: it needs the system's DRI drivers
            restore = os.environ.pop("LIBGL_DRIVERS_PATH")
        del errors[:]
        _window_hints(glfw, api, visible)
        window = glfw.create_window(int(width), int(height), title, None, None)
        if restore is not None:
            os.environ["LIBGL_DRIVERS_PATH"] = restore
        if not window:
            failures.append(f"{name}: {'; '.join(errors) or 'no window'}")
            continue
        glfw.make_context_current(window)
        try:
            gl = moderngl.create_context(require=REQUIRED_GL)
        except Exception as exc:  # moderngl raises plain Exception for context failures
            failures.append(f"{name}: {str(exc).strip().splitlines()[0]}")
            glfw.destroy_window(window)
            continue
        return window, gl
    glfw.terminate()
    raise DeviceError(f"cannot create an OpenGL {REQUIRED_GL // 100}.{REQUIRED_GL % 100 // 10} core "
                      f"context for a window ({'; '.join(failures)})")
