"""Driving a real X11 window from the tests: Xvfb, xdotool, and the window manager's close
request (WM_DELETE_WINDOW), which xdotool 3.2016 cannot send, through libX11 with ctypes."""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import shutil
import subprocess
import time


class Xvfb:
    """A virtual X server on a free display number (Xvfb picks it: -displayfd)."""

    def __init__(self, size=(1024, 768)):
        read, write = os.pipe()
        self.process = subprocess.Popen(
            ["Xvfb", "-displayfd", str(write), "-screen", "0", f"{size[0]}x{size[1]}x24",
             "-nolisten", "tcp", "-noreset"],
            pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(write)
        with os.fdopen(read) as f:
            number = f.readline().strip()
        if not number:
            self.process.kill()
            raise RuntimeError("Xvfb did not start")
        self.display = f":{number}"

    def env(self, **extra) -> dict:
        return dict(os.environ, DISPLAY=self.display, **extra)

    def close(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(5)
        except subprocess.TimeoutExpired:
            self.process.kill()


def missing_tools() -> list[str]:
    return [tool for tool in ("Xvfb", "xdotool") if shutil.which(tool) is None]


def xdotool(display: str, *args: str) -> str:
    out = subprocess.run(["xdotool", *args], capture_output=True, text=True, timeout=20,
                         env=dict(os.environ, DISPLAY=display))
    if out.returncode != 0:
        raise RuntimeError(f"xdotool {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout.strip()


def window_name(display: str, window: str) -> str:
    return xdotool(display, "getwindowname", window)


def wait_for(condition, timeout: float, interval: float = 0.05, what: str = "condition"):
    """Poll ``condition()`` until it returns something truthy; returns it."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)


class _ClientMessage(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("serial", ctypes.c_ulong), ("send_event", ctypes.c_int),
                ("display", ctypes.c_void_p), ("window", ctypes.c_ulong),
                ("message_type", ctypes.c_ulong), ("format", ctypes.c_int),
                ("data", ctypes.c_long * 5)]


class _XEvent(ctypes.Union):
    _fields_ = [("client", _ClientMessage), ("pad", ctypes.c_long * 24)]


class _XImage(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int),
                ("format", ctypes.c_int), ("data", ctypes.POINTER(ctypes.c_ubyte)),
                ("byte_order", ctypes.c_int), ("bitmap_unit", ctypes.c_int),
                ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int),
                ("depth", ctypes.c_int), ("bytes_per_line", ctypes.c_int),
                ("bits_per_pixel", ctypes.c_int), ("red_mask", ctypes.c_ulong),
                ("green_mask", ctypes.c_ulong), ("blue_mask", ctypes.c_ulong)]


class _XWindowAttributes(ctypes.Structure):
    _fields_ = [("x", ctypes.c_int), ("y", ctypes.c_int), ("width", ctypes.c_int),
                ("height", ctypes.c_int), ("pad", ctypes.c_char * 256)]


_P = ctypes.c_void_p
_SIGNATURES = {   # name: (restype, argtypes) of the libX11 calls used here
    "XOpenDisplay": (_P, [ctypes.c_char_p]),
    "XCloseDisplay": (ctypes.c_int, [_P]),
    "XFlush": (ctypes.c_int, [_P]),
    "XFree": (ctypes.c_int, [_P]),
    "XInternAtom": (ctypes.c_ulong, [_P, ctypes.c_char_p, ctypes.c_int]),
    "XSendEvent": (ctypes.c_int, [_P, ctypes.c_ulong, ctypes.c_int, ctypes.c_long,
                                  ctypes.POINTER(_XEvent)]),
    "XGetWindowAttributes": (ctypes.c_int, [_P, ctypes.c_ulong, ctypes.POINTER(_XWindowAttributes)]),
    "XGetImage": (ctypes.POINTER(_XImage), [_P, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                                            ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong,
                                            ctypes.c_int]),
}


@contextlib.contextmanager
def _connection(display: str):
    """(libX11, Display*) for the duration of the block."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
    for name, (restype, argtypes) in _SIGNATURES.items():
        fn = getattr(x11, name)
        fn.restype, fn.argtypes = restype, argtypes
    dpy = x11.XOpenDisplay(display.encode())
    if not dpy:
        raise RuntimeError(f"cannot open display {display}")
    try:
        yield x11, dpy
    finally:
        x11.XCloseDisplay(dpy)


def request_close(display: str, window: int) -> None:
    """What a window manager sends when the user clicks the close button: a
    WM_PROTOCOLS client message carrying WM_DELETE_WINDOW."""
    with _connection(display) as (x11, dpy):
        event = _XEvent()
        event.client.type = 33                  # ClientMessage
        event.client.window = window
        event.client.message_type = x11.XInternAtom(dpy, b"WM_PROTOCOLS", 0)
        event.client.format = 32
        event.client.data[0] = x11.XInternAtom(dpy, b"WM_DELETE_WINDOW", 0)
        event.client.data[1] = 0                # CurrentTime
        if not x11.XSendEvent(dpy, window, 0, 0, ctypes.byref(event)):
            raise RuntimeError("XSendEvent failed")
        x11.XFlush(dpy)


def capture(display: str, window: int):
    """The window's pixels as the X server holds them (what a person sees): (H, W, 3) uint8."""
    import numpy as np

    all_planes = (1 << 8 * ctypes.sizeof(ctypes.c_ulong)) - 1
    with _connection(display) as (x11, dpy):
        attrs = _XWindowAttributes()
        x11.XGetWindowAttributes(dpy, window, ctypes.byref(attrs))
        w, h = attrs.width, attrs.height
        image = x11.XGetImage(dpy, window, 0, 0, w, h, all_planes, 2)   # ZPixmap
        if not image:
            raise RuntimeError("XGetImage failed")
        img = image.contents
        if img.bits_per_pixel != 32:
            raise RuntimeError(f"unexpected {img.bits_per_pixel} bits per pixel")
        stride = img.bytes_per_line
        raw = np.ctypeslib.as_array(img.data, shape=(h * stride,)).copy()
        masks = (img.red_mask, img.green_mask, img.blue_mask)
        x11.XFree(img.data)      # XDestroyImage is a macro: free the pixels, then the struct
        x11.XFree(image)
    words = raw.reshape(h, stride)[:, :4 * w].copy().view("<u4")
    channels = [(words & m) >> (int(m).bit_length() - 8) for m in masks]
    return np.stack(channels, axis=-1).astype(np.uint8)
