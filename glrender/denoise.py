"""Denoising with Intel Open Image Denoise (OIDN 2, the optional extra ``denoise``: pyoidn).

The denoised image is always a separate output: the unbiased accumulation is never
replaced. The input is the film's mean in linear radiance (OIDN's ``hdr`` mode) with the
renderer's AOVs as auxiliary images: albedo and shading normal averaged over each pixel's
samples, taken by the path tracer at the first non-delta hit (through mirrors and glass;
see ``shaders/integrators/path.glsl``) and by the other integrators at the first hit.

What OIDN filters is the light surfaces reflect: the beauty minus the ``emission`` AOV
(the radiance of the lights and environment the camera sees, along the same delta chain
as the albedo, accumulated with the same pixel-filter weights and sample counts as the
beauty), and the emission is added back after: a light's face stays exact instead of
the few percent OIDN's filter moves it (an emitter is often far brighter than any
surface it lights, so those few pixels would outweigh the rest of the image's error).

The light's partly covered edge pixels have antialiasing noise only, but the fraction
of a pixel's camera samples that find the light, times a radiance 18x that of the lit
surfaces in the Cornell box, is most of the noisy image's error at low sample counts
(72% of its MSE at 4 spp, 48% at 16, seed 5). So the emission added back is rendered
again on its own at :func:`~glrender.render.emission_pass.emission_spp` samples per pixel
(``emission_only``: camera rays followed through delta surfaces, no shading;
:func:`~glrender.render.emission_pass.render_seen_emission`); the
one taken with the beauty's own samples is what is subtracted, so the filtered part is
exactly the beauty's reflected light.

``cleanAux`` follows OIDN's guidance: the averaged AOVs count as noise-free unless the
scene makes them vary from sample to sample by more than pixel coverage: a thin lens
(depth of field), motion (of the camera or of shapes), or glass (its sampled reflection
or refraction decides what the albedo shows). :func:`aovs_are_clean` decides it.

OIDN picks its device (``device="auto"``: a GPU when the wheel's library supports one
on the machine, else the CPU) and its CPU thread count (``threads``; the preview uses
fewer than all cores so that llvmpipe keeps rendering while OIDN runs).
"""
from __future__ import annotations

import threading

import numpy as np

from .errors import MissingExtra, UsageError

EXTRA = "denoise"
QUALITIES = ("high", "balanced", "fast")
# OIDN_QUALITY_* values of OIDN 2
_QUALITY_CODES = {"high": 6, "balanced": 5, "fast": 4}
# OIDN_DEVICE_TYPE_*: 0 default (the fastest supported), 1 CPU
_DEVICE_TYPES = {"auto": 0, "cpu": 1}
_DEVICE_NAMES = {1: "CPU", 2: "SYCL", 3: "CUDA", 4: "HIP", 5: "Metal"}
_FLOAT3 = 3                          # OIDN_FORMAT_FLOAT3


def load_oidn():
    """The pyoidn module, or a one-line :class:`UsageError` naming the extra."""
    try:
        import pyoidn
    except ImportError as exc:
        raise MissingExtra("denoising (Intel Open Image Denoise)", "pyoidn", EXTRA) from exc
    return pyoidn


def available() -> bool:
    try:
        load_oidn()
    except UsageError:
        return False
    return True


def aovs_are_clean(scene) -> bool:
    """Whether the averaged AOVs of ``scene`` vary between a pixel's samples only by pixel
    coverage (OIDN's ``cleanAux``): no thin lens, no motion, no glass."""
    cam = scene.camera
    if getattr(cam, "aperture_radius", 0.0) > 0 or getattr(cam, "world_from_camera_close", None) is not None:
        return False
    if any(getattr(s, "world_from_object_close", None) is not None for s in scene.shapes):
        return False
    return not any(mat.kind in ("dielectric", "thindielectric") for mat in scene.materials)


class Denoiser:
    """One OIDN device and RT filter, reused across images of any size (thread-safe: calls
    are serialized). ``threads`` limits OIDN's CPU threads (None: all cores)."""

    def __init__(self, *, device: str = "auto", threads: int | None = None,
                 quality: str = "high"):
        oidn = load_oidn()
        if device not in _DEVICE_TYPES:
            raise UsageError(f"denoise device {device!r}: expected one of {', '.join(_DEVICE_TYPES)}")
        if quality not in _QUALITY_CODES:
            raise UsageError(f"denoise quality {quality!r}: expected one of {', '.join(QUALITIES)}")
        self._oidn = oidn
        self._lock = threading.Lock()
        self.quality = quality
        self._device = oidn.Device(_DEVICE_TYPES[device])
        if threads is not None:
            self._device.set_int("numThreads", int(threads))
            # pinning OIDN's threads to cores would fight llvmpipe's for the same cores
            self._device.set_bool("setAffinity", False)
        self._device.commit()
        self._check("device creation")
        self.device_name = _DEVICE_NAMES.get(self._device.get_int("type"), "unknown")
        self.threads = self._device.get_int("numThreads") if self.device_name == "CPU" else None
        self._filter = oidn.Filter(self._device, "RT")
        self._check("filter creation")

    def _check(self, what: str) -> None:
        error = self._device.get_error()
        if error is not None:
            raise UsageError(f"Open Image Denoise: {what} failed: {error}")

    def denoise(self, color: np.ndarray, albedo: np.ndarray | None = None,
                normal: np.ndarray | None = None, emission: np.ndarray | None = None, *,
                clean_aux: bool = False, seen_emission: np.ndarray | None = None) -> np.ndarray:
        """The denoised ``color`` (H, W, 3, linear radiance, HDR). ``albedo`` in [0, 1] and
        ``normal`` in [-1, 1] (both (H, W, 3)) guide it; a normal needs an albedo (OIDN).
        ``emission`` (H, W, 3), the part of ``color`` emitted by what the camera sees, is
        kept out of the filter: OIDN gets ``color - emission``, and ``emission`` is added
        back to its output, or ``seen_emission`` where given: the same quantity rendered
        with more samples (:func:`render_seen_emission`)."""
        color = _image(color, "color")
        shape = color.shape
        add_back = None
        if emission is not None:
            emission = _image(emission, "emission")
            add_back = emission if seen_emission is None else _image(seen_emission, "seen emission")
            for name, image in (("emission", emission), ("seen emission", add_back)):
                if image.shape != shape:
                    raise UsageError(f"denoise: {name} is {image.shape[:2]}, color {shape[:2]}")
            color = color - emission
        aux = {"albedo": albedo, "normal": normal if albedo is not None else None}
        out = np.empty_like(color)
        with self._lock:
            f = self._filter
            f.set_image("color", color, _FLOAT3)
            keep = [color]      # OIDN reads the arrays in place: keep them alive until done
            for name, image in aux.items():
                if image is None:
                    f.unset_image(name)
                    continue
                image = _image(image, name)
                if image.shape != shape:
                    raise UsageError(f"denoise: {name} is {image.shape[:2]}, color {shape[:2]}")
                if name == "albedo":
                    image = np.clip(image, 0.0, 1.0)
                keep.append(image)
                f.set_image(name, image, _FLOAT3)
            f.set_image("output", out, _FLOAT3)
            f.set_bool("hdr", True)
            f.set_bool("cleanAux", bool(clean_aux) and aux["albedo"] is not None)
            f.set_int("quality", _QUALITY_CODES[self.quality])
            f.commit()
            self._check("filter setup")
            f.execute()
            self._check("denoising")
            del keep
        if add_back is not None:
            out += add_back
        return out

    def denoise_film(self, film, *, clean_aux: bool = False,
                     seen_emission: np.ndarray | None = None) -> np.ndarray:
        """The denoised mean of a :class:`~glrender.film.film.Film`, guided by its albedo and
        normal AOVs and with its emission AOV kept out of the filter, when it has them
        (``seen_emission``: see :meth:`denoise`)."""
        return self.denoise(film.mean, *film_aux(film), clean_aux=clean_aux,
                            seen_emission=seen_emission)

    def close(self) -> None:
        with self._lock:
            if self._filter is not None:
                self._filter.release()
                self._device.release()
                self._filter = None

    def __enter__(self) -> "Denoiser":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def film_aux(film) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """A film's albedo, normal and emission AOVs (None for those it lacks), as
    :meth:`Denoiser.denoise` takes them: ``denoise(film.mean, *film_aux(film))``."""
    return tuple(film.aovs.get(name) for name in ("albedo", "normal", "emission"))


def _image(a, name: str) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise UsageError(f"denoise: {name} must be (H, W, 3), got {a.shape}")
    # non-finite values would spread over the whole neighbourhood
    if not np.isfinite(a).all():
        a = np.where(np.isfinite(a), a, 0.0).astype(np.float32)
    return a
