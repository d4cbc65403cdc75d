"""Stochastic progressive photon mapping on the device (Hachisuka & Jensen 2009).

Each iteration runs a camera pass (``shaders/photon/sppm_camera.comp.glsl``: one
visible point per pixel, found through delta surfaces, with the emission and direct
light the camera path collects), builds a hash grid over the visible points in numpy
(:mod:`glrender.photon.grid`), and a photon pass (``photon_trace.comp.glsl``) that
deposits flux into the visible points around every photon hit. The per-pixel state
(radius r, photon count N, flux tau, the camera passes' radiance) lives on the host in
float64 and follows Hachisuka & Jensen's rule: with M new photons and flux Phi,

    N' = N + alpha M,   r' = r sqrt(N' / (N + M)),   tau' = (tau + Phi) (r' / r)^2,

and the image is L = Ld / n + tau / (n P pi r^2) after n iterations of P photons
(pbrt-v3's SPPMIntegrator). The radius shrinks like n^((alpha - 1) / 2), so the bias
(proportional to r^2) and the noise both vanish: the estimate is consistent.

In participating media a camera path may scatter in a medium before it reaches a surface:
its visible point is then a point of the medium, which photons reach at their scattering
events (volume photons, shaders/photon/sppm_deposit.glsl) inside a sphere of radius r_v.
A pixel keeps a second state for those (r_v, N_v, tau_v), updated by the same rule in
three dimensions (the sphere's volume in place of the disk's area),

    r_v' = r_v (N_v' / (N_v + M))^(1/3),   tau_v' = (tau_v + Phi) (r_v' / r_v)^3,

so that tau_v / r_v^3 is the sum over iterations of each one's flux over its own r_v^3,
and the image adds tau_v / (n P (4/3) pi r_v^3). An iteration's visible point is of one
kind: the other kind's state is left as it is.

An image whose visible points exceed one storage-block binding runs each iteration in
slices of pixel rows (a camera pass and the same photons per slice), and a slice whose
grid exceeds a binding is traced grid by grid: the deposits are the one-slice image's.

The scene is packed, uploaded and compiled by a :class:`Renderer` held inside (its
scene buffers, parameter block and defines); only the photon kernels are compiled here.
"""
from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..film import Film
from ..gl import shaders
from ..gl.context import Context, current
from ..gpu import bindings
from ..render import accum
from ..render.accumulation import SPLAT_SCALE, TILE
from ..render.driver import part_digests
from ..render.renderer import (RenderSettings, Renderer, camera_screen,
                               settings_from_scene)
from ..scene import model as m
from . import layout as pl
from .grid import build_grid

PHOTONS_PER_DISPATCH = 1 << 16   # photons per photon-pass dispatch (64 per work group)
MAX_RECORDS = (128 << 20) // pl.BYTES_PER_RECORD - 1   # emission records fit one SSBO
DEFAULT_RADIUS_PIXELS = 2.0      # default initial radius, in pixel footprints at the scene's centre
# default initial radius of visible points in media over the surfaces' initial radius: a ball
# holds far fewer photons than a disk of the same radius (on scenes/cornell-fog, 256x256,
# 3x makes the fog as smooth at 64 iterations as the walls; 1x leaves it grainy) ...
VOLUME_RADIUS_FACTOR = 3.0
# ... and at most this fraction of the scene's bounding sphere's radius: on a small image the
# pixel footprint is large, and a ball's radius shrinks slowly (iterations^((alpha - 1) / 3));
# cornell-fog at 24x24 pixels: 0.70 beside its fog ball's 0.35, the fog 36% dark after 256
# iterations; capped (0.052), 7%
VOLUME_RADIUS_SCENE = 0.03


def footprint_radius(scene: m.Scene, sphere_bounds: Any, width: int, height: int,
                     pixels: float = DEFAULT_RADIUS_PIXELS) -> float:
    """A search radius of ``pixels`` pixel footprints at the scene's centre (its bounding
    sphere's, ``sphere_bounds``): the default initial radius of SPPM and vcm."""
    center, radius = sphere_bounds
    cam = scene.camera.world_from_camera
    dist = max(float(np.linalg.norm(np.asarray(center) - cam[:3, 3])), 1e-3 * radius)
    _, screen_y = camera_screen(scene.camera, width, height)
    reach = 1.0 if scene.camera.orthographic else dist   # an orthographic pixel's size is fixed
    return pixels * 2 * screen_y * reach / height


@dataclass(frozen=True)
class SppmSettings:
    """SPPM's own parameters: ``photons_per_iteration`` (None: one per pixel, at
    least 16,384), ``initial_radius`` in scene units (None: DEFAULT_RADIUS_PIXELS pixel
    footprints at the scene's centre), ``alpha`` in (0, 1): the fraction of new photons
    kept each iteration; ``direct``: direct light by next-event estimation in the
    camera pass (``nee``) or by the photons like the rest (``photons``)."""

    photons_per_iteration: int | None = None
    initial_radius: float | None = None
    alpha: float = 0.7
    direct: str = "nee"    # direct light by next-event estimation, or "photons" (density estimation)
    photon_view: bool = False   # also render the photon-map view (the "photons" AOV)
    kernel: str = "uniform"     # density estimation kernel: uniform, cone or epanechnikov
    volume_radius: float | None = None   # initial radius of visible points in media (None: VOLUME_RADIUS_*)

    def __post_init__(self) -> None:
        if self.kernel not in pl.KERNELS:
            raise UsageError(f"kernel: expected one of {', '.join(pl.KERNELS)}, got {self.kernel!r}")
        if self.direct not in ("nee", "photons"):
            raise UsageError(f"direct: expected nee or photons, got {self.direct!r}")
        p = self.photons_per_iteration
        if p is not None and (not isinstance(p, (int, np.integer)) or p < 1):
            raise UsageError(f"photons per iteration: expected a positive integer, got {p!r}")
        for name in ("initial_radius", "volume_radius"):
            r = getattr(self, name)
            if r is not None and not (isinstance(r, (int, float)) and math.isfinite(r) and r > 0):
                raise UsageError(f"{name.replace('_', ' ')}: expected a positive number of scene "
                                 f"units, got {r!r}")
        a = self.alpha
        if not (isinstance(a, (int, float)) and 0 < a < 1):
            raise UsageError(f"alpha: expected a number in (0, 1), got {a!r}")


@dataclass
class _Iteration:
    """An SPPM iteration in progress: per slice of pixel rows a camera pass, then the
    photons traced into each grid of the slice's visible points."""

    index: int
    slices: list[tuple[int, int]]
    radiance: np.ndarray            # (N, 3): the camera passes' radiance
    phi: np.ndarray                 # (N, 3): flux deposited
    m: np.ndarray                   # (N,): photons counted
    volume: np.ndarray              # (N,): the visible point lies in a medium
    vp_radius: np.ndarray           # (N,): its search radius (r, or r_v in a medium)
    slice: int = 0                  # the slice in progress
    grids: list[Any] = field(default_factory=list)   # its grids still to trace
    prm: Any = None                 # the photon block of the grid in progress (None: none)
    next_photon: int = 0
    first_group: bool = True        # the photon-map view not drawn yet


class SppmRenderer:
    """A scene on the device rendered by SPPM, iteration by iteration.

    Offers what :class:`Renderer` offers to the command line: ``step(iterations,
    callback, should_stop)``, ``film()``, ``state()``/``restore()``, ``fingerprint()``,
    ``spp_done`` (iterations done), ``release()``."""

    def __init__(self, scene: m.Scene, settings: RenderSettings | None = None,
                 sppm: SppmSettings | None = None, *, ctx: Context | None = None,
                 device: str | int | None = None, record_emission: bool = False,
                 photon_view: bool = False, share: Any = None, **overrides: Any) -> None:
        self.sppm = sppm or SppmSettings()
        settings = settings or settings_from_scene(scene, **overrides)
        # the inner renderer packs, uploads and compiles the scene (its own kernel, unused
        # here, is ambient occlusion's: the quickest to compile)
        inner = replace(settings, integrator=replace(settings.integrator, kind="ao"))
        t0 = time.perf_counter()
        self.base = Renderer(scene, inner, ctx=ctx, device=device, share=share, media_for="sppm")
        self.media = bool(self.base.packed.has_media)
        self.scene, self.settings = scene, settings
        self.ctx, self.gl = self.base.ctx, self.base.gl
        self.width, self.height = self.base.width, self.base.height
        self.rows = self.base.rows
        self.samples_per_pass = 1
        n = self.width * self.height
        self.photons_per_iteration = int(self.sppm.photons_per_iteration or max(n, 16384))
        self.record_emission = record_emission
        self.photon_view = photon_view or self.sppm.photon_view
        if record_emission and self.photons_per_iteration > MAX_RECORDS:
            raise UsageError(f"photons per iteration: at most {MAX_RECORDS} when recording emission")
        self.initial_radius = float(self.sppm.initial_radius or self._default_radius())
        # (a scene without shapes has no size to bound it by: its fog fills all space)
        cap = VOLUME_RADIUS_SCENE * float(self.base.packed.sphere_bounds[1]) if scene.shapes else math.inf
        self.initial_volume_radius = float(self.sppm.volume_radius
                                           or min(VOLUME_RADIUS_FACTOR * self.initial_radius, cap))
        self._compile()
        self._allocate()
        self.reset()
        self._warm_up()
        self.timings = {"pack": self.base.timings["pack"], "build": self.base.timings["build"],
                        "compile": time.perf_counter() - t0
                        - self.base.timings["build"]}

    # -- setup -------------------------------------------------------------------------------
    def _default_radius(self) -> float:
        return footprint_radius(self.scene, self.base.packed.sphere_bounds, self.width, self.height)

    def _compile(self) -> None:
        # the inner renderer's scene code and library (Renderer._compile made them)
        library = self.base.library
        slots = {"scene": self.base.slots["scene"]}
        self.camera_kernel: Any = shaders.compile_compute(
            self.ctx, "photon/sppm_camera.comp.glsl", defines=self.base.defines, slots=slots,
            library=library)
        self.photon_kernel: Any = shaders.compile_compute(
            self.ctx, "photon/photon_trace.comp.glsl", defines=self.base.defines, slots=slots,
            library=library)
        h = hashlib.sha256()
        for entry in ("photon/sppm_camera.comp.glsl", "photon/photon_trace.comp.glsl"):
            h.update(shaders.preprocess(entry, defines=self.base.defines, slots=slots,
                                        library=library).source.encode())
        self._kernel_hash = h.hexdigest()

    def _warm_up(self) -> None:
        """llvmpipe compiles a kernel at its first dispatch: run one empty work group of
        each now, so that setup time is not charged to the first iteration."""
        prm = self.base.param_block(0, 0)
        prm["image"][:2] = 0                      # every camera invocation returns at once
        self._bind()
        self.base.write_params(prm)
        self._photon_params.write(self._photon_block(0).tobytes())   # no photons
        self.camera_kernel.run(group_x=1, group_y=1)
        self.photon_kernel.run(group_x=1)
        self.gl.finish()

    def binding_limit(self) -> int:
        """Bytes one storage-block binding may hold on this device (the inner renderer's
        figure; tests lower it here)."""
        return self.base.binding_limit()

    def slices(self) -> list[tuple[int, int]]:
        """The image's pixel rows in slices (first row, rows) whose visible points fit one
        storage-block binding of every per-pixel buffer (llvmpipe's 128 MiB: 4.2M pixels a
        slice). An iteration runs a camera pass and a photon pass per slice: the same
        photons (the same numbers) deposit into each slice's visible points, so the image
        is the one-slice image up to the order of the float sums."""
        per_row = pl.WIDEST_PER_PIXEL * self.width
        rows = self.binding_limit() // per_row
        if rows < 1:
            raise UsageError(f"sppm: a {self.width}-pixel-wide image does not fit this device's "
                             f"storage buffers ({self.binding_limit()} bytes a binding): render "
                             f"fewer columns")
        top = TILE * self.rows[0]
        end = top + self.band_height
        return [(y, min(rows, end - y)) for y in range(top, end, rows)]

    def _allocate(self) -> None:
        gl = self.gl
        n = max(rows for _, rows in self.slices()) * self.width    # pixels of the largest slice
        if self.photon_view and 24 * self.width * self.height > self.binding_limit():
            raise UsageError(f"sppm: the photons AOV of a {self.width}x{self.height} image needs "
                             f"{24 * self.width * self.height >> 20} MiB, above the device's "
                             f"{self.binding_limit() >> 20} MiB storage buffers: leave it out or "
                             f"render fewer pixels")
        self._vp_position = gl.buffer(reserve=16 * n)
        self._vp_shading = gl.buffer(reserve=32 * n)
        self._vp_extra = gl.buffer(reserve=32 * n)
        self._vp_radiance = gl.buffer(reserve=16 * n)
        self._radius2 = gl.buffer(reserve=4 * n)
        self._deposits = gl.buffer(reserve=16 * n)
        self._grid = gl.buffer(reserve=16)
        records = pl.RECORD_HEADER_WORDS * 4 + (pl.BYTES_PER_RECORD * self.photons_per_iteration
                                                 if self.record_emission else 0)
        self._records = gl.buffer(reserve=records)
        self._photon_params = gl.buffer(reserve=pl.PHOTON_PARAMS.itemsize)
        # the photon-map view: 64-bit fixed-point sums per pixel and channel (integrators/splat.glsl)
        self._view = gl.buffer(reserve=24 * self.width * self.height if self.photon_view else 16)
        self._view.clear()
        self._own = [self._view, self._vp_position, self._vp_shading, self._vp_extra, self._vp_radiance,
                     self._radius2, self._deposits, self._grid, self._records, self._photon_params]

    @current
    def reset(self, start: int = 0, rows: tuple[int, int] | None = None) -> None:
        """Forget every iteration: radii back to the initial radius. ``rows``: ``(first,
        count)`` tile rows (of 8 pixel rows) to render, as :meth:`Renderer.reset` takes
        them (``--crop``); the rest of the image is not rendered (None: the whole
        image). The photons are the same either way, so a band's pixels are the whole
        image's. SPPM has no sample ranges: ``start`` is 0."""
        if start != 0:
            raise UsageError(f"sppm: start {start}: SPPM runs whole iterations from the first (0)")
        if (tuple(rows) if rows is not None else (0, self.base.tiles_y)) != self.base.rows:
            self.base.reset(rows=rows)      # checks the rows; its accumulation follows the band
        self.rows = self.base.rows
        n = self.width * self.band_height
        self.iterations = 0
        self.radius = np.full(n, self.initial_radius, np.float64)
        self.n_photons = np.zeros(n, np.float64)
        self.tau = np.zeros((n, 3), np.float64)
        self.ld_sum = np.zeros((n, 3), np.float64)
        # visible points in media (scenes with media): their radius, count and flux
        self.volume_radius = np.full(n, self.initial_volume_radius, np.float64)
        self.n_volume = np.zeros(n, np.float64)
        self.tau_volume = np.zeros((n, 3), np.float64)
        self.counters = {"skipped": 0, "visited": 0, "max_visited": 0, "max_cell": 0}
        self._work: _Iteration | None = None
        if getattr(self, "_view", None) is not None:
            self._view.clear()

    @property
    def spp_done(self) -> int:
        """Iterations done (one camera sample per pixel each)."""
        return self.iterations

    @property
    def band_height(self) -> int:
        """Pixel rows rendered (the image's height unless ``rows`` is a band)."""
        first, count = self.rows
        return min(self.height, TILE * (first + count)) - TILE * first

    def fingerprint(self) -> str:
        """The inner renderer's fingerprint (scene, camera, sampler, seed) with SPPM's
        kernels and parameters."""
        h = hashlib.sha256()
        h.update(self.base.fingerprint().encode())
        for _, data in self._sppm_inputs():
            h.update(data)
        return h.hexdigest()

    def fingerprint_parts(self) -> dict[str, str]:
        # SPPM's kernels are made of the inner renderer's defines and scene code, which its
        # parts cover: SPPM's settings are the part of its own
        return {**self.base.fingerprint_parts(), **part_digests(self._sppm_inputs()[1:])}

    def _sppm_inputs(self) -> list[tuple[str, bytes]]:
        return [("SPPM kernels", self._kernel_hash.encode()),
                ("SPPM settings", repr(
                    ("sppm", self.photons_per_iteration, self.initial_radius,
                     float(self.sppm.alpha), self.sppm.direct, self.sppm.kernel)
                    + ((self.initial_volume_radius,) if self.media else ())).encode())]

    # -- rendering ---------------------------------------------------------------------------
    def _bind(self) -> None:
        self.base.bind()
        for binding, buf in ((bindings.SSBO_VP_POSITION, self._vp_position), (bindings.SSBO_VP_SHADING, self._vp_shading),
                             (bindings.SSBO_VP_EXTRA, self._vp_extra), (bindings.SSBO_VP_RADIANCE, self._vp_radiance),
                             (bindings.SSBO_VP_RADIUS2, self._radius2), (bindings.SSBO_GRID_CELLS, self._grid),
                             (bindings.SSBO_DEPOSITS, self._deposits), (bindings.SSBO_PHOTON_RECORDS, self._records)):
            buf.bind_to_storage_buffer(binding)
        self._photon_params.bind_to_uniform_block(bindings.UBO_PHOTON_PARAMS)

    def _photon_block(self, iteration: int) -> Any:
        prm = np.zeros(1, pl.PHOTON_PARAMS)[0]
        prm["photons"] = (0, 0, self.photons_per_iteration, iteration)
        max_depth = self.settings.integrator.max_depth
        deposit_from = 2 if self.sppm.direct == "nee" else 1
        prm["estimate"][0] = pl.KERNELS[self.sppm.kernel]
        prm["options"] = (deposit_from, 256 if max_depth < 0 else max_depth, int(self.record_emission),
                          int(self.photon_view))
        return prm

    @current
    def camera_pass(self, iteration: int, rows: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Runs the camera pass of ``iteration`` over the pixel rows ``rows`` (first, count;
        one of :meth:`slices`): the slice's visible points' positions (N, 4: xyz and camera
        segments, 0 for none) and the camera paths' radiance (N, 3)."""
        prm = self.base.param_block(iteration, 1)
        self._bind()
        self.base.write_params(prm)
        photon = self._photon_block(iteration)
        photon["estimate"][1:3] = rows
        self._photon_params.write(photon.tobytes())
        self.camera_kernel.run(group_x=-(-self.width // 8), group_y=-(-rows[1] // 8))
        self.gl.memory_barrier()
        n = rows[1] * self.width
        position = np.frombuffer(self._vp_position.read(16 * n), np.float32).reshape(-1, 4)
        radiance = np.frombuffer(self._vp_radiance.read(16 * n), np.float32).reshape(-1, 4)[:, :3]
        return position, radiance

    def _grids(self, position: np.ndarray, radius: np.ndarray) -> list[Any]:
        """Hash grids over a slice's visible points (``radius``: their search radii),
        each within one storage-block binding: the points split in halves (in pixel
        order) until each half's grid fits. Always at least one grid (it may be empty:
        the photons still draw the photon-map view)."""
        limit = self.binding_limit()

        def split(points: np.ndarray) -> list[Any]:
            grid = build_grid(position[points, :3], radius[points], points.astype(np.uint32))
            if grid.cells.nbytes <= limit:
                return [grid]
            if len(points) < 2:
                raise UsageError(f"sppm: one visible point's grid takes {grid.cells.nbytes} bytes, "
                                 f"above the device's {limit} per storage buffer")
            half = len(points) // 2
            return split(points[:half]) + split(points[half:])

        grids = split(np.nonzero(position[:, 3] != 0)[0])
        for grid in grids:
            self.counters["max_cell"] = max(self.counters["max_cell"], grid.max_cell_entries)
        return grids

    def _begin_group(self, work: "_Iteration") -> None:
        """Uploads the next grid of the slice in progress; its photons start at 0."""
        grid = work.grids.pop(0)
        self._grid.orphan(grid.cells.nbytes)
        self._grid.write(grid.cells.tobytes())
        self._records.write(np.zeros(pl.RECORD_HEADER_WORDS, np.uint32).tobytes())
        prm = self._photon_block(work.index)
        prm["grid_size"] = (*grid.size, grid.table_size)
        prm["grid_lo"] = (*grid.lo, grid.cell)
        # the photon-map view is drawn once an iteration: by the first group's photons
        prm["options"][3] = int(self.photon_view and work.first_group)
        work.first_group = False
        work.prm, work.next_photon = prm, 0

    def _begin_slice(self, work: "_Iteration") -> None:
        """A slice's camera pass, its radii and cleared deposits, and its first grid."""
        first_row, rows = work.slices[work.slice]
        position, radiance = self.camera_pass(work.index, (first_row, rows))
        lo, n = (first_row - TILE * self.rows[0]) * self.width, rows * self.width
        work.radiance[lo:lo + n] = radiance
        volume = position[:, 3] < 0        # visible points in media
        radius = np.where(volume, self.volume_radius[lo:lo + n], self.radius[lo:lo + n])
        work.volume[lo:lo + n], work.vp_radius[lo:lo + n] = volume, radius
        self._radius2.write((radius ** 2).astype(np.float32).tobytes())
        self._deposits.clear()
        work.grids = self._grids(position, radius)
        self._begin_group(work)

    def _dispatch_photons(self, work: "_Iteration") -> None:
        """Traces the next dispatch of photons into the grid in progress; at its end,
        reads the counters, and at the slice's end its deposits."""
        self._bind()
        self._view.bind_to_storage_buffer(bindings.SSBO_ACCUM_SPLAT)
        prm, first = work.prm, work.next_photon
        count = min(PHOTONS_PER_DISPATCH, self.photons_per_iteration - first)
        prm["photons"][:2] = (first, count)
        self._photon_params.write(prm.tobytes())
        self.photon_kernel.run(group_x=-(-count // 64))
        work.next_photon = first + count
        if work.next_photon < self.photons_per_iteration:
            return
        self.gl.memory_barrier()
        head = np.frombuffer(self._records.read(pl.RECORD_HEADER_WORDS * 4), np.uint32)
        self.counters["skipped"] += int(head[0])
        self.counters["visited"] += int(head[1])
        self.counters["max_visited"] = max(self.counters["max_visited"], int(head[2]))
        if work.grids:
            self._begin_group(work)
            return
        first_row, rows = work.slices[work.slice]
        lo, n = (first_row - TILE * self.rows[0]) * self.width, rows * self.width
        dep = np.frombuffer(self._deposits.read(16 * n), np.float32).reshape(-1, 4)
        work.phi[lo:lo + n], work.m[lo:lo + n] = dep[:, :3], dep[:, 3]
        work.prm = None
        work.slice += 1

    @property
    def iteration_in_progress(self) -> bool:
        """Whether an iteration was begun by :meth:`iteration_piece` and not finished."""
        return self._work is not None

    @current
    def iteration_piece(self) -> bool:
        """Does the next piece of the iteration in progress (beginning one if none is): a
        slice's camera pass with the grid over its visible points, or one dispatch of
        photons. Returns True when the piece finished the iteration, which is then added
        to the state. The preview calls it within its frame budget; :meth:`iterate`
        until it returns True."""
        work = self._work
        if work is None:
            n = self.width * self.band_height
            work = self._work = _Iteration(self.iterations, self.slices(), np.zeros((n, 3)),
                                           np.zeros((n, 3)), np.zeros(n), np.zeros(n, bool), np.zeros(n))
        if work.prm is None:
            self._begin_slice(work)
            return False
        self._dispatch_photons(work)
        if work.slice < len(work.slices):
            return False
        self._work = None
        self.ld_sum += work.radiance
        self._update(work.phi, work.m, work.volume)
        self.iterations += 1
        return True

    @current
    def abandon_iteration(self) -> None:
        """Drops the iteration in progress (the state stays as it was before it)."""
        self._work = None

    def _update(self, phi: np.ndarray, m_new: np.ndarray, volume: np.ndarray) -> None:
        """Hachisuka & Jensen's progressive radius and flux update (pbrt-v3's form); for
        the pixels whose visible point lies in a medium (``volume``) its form in three
        dimensions on their volume state."""
        if volume.any():
            self._progress((m_new > 0) & volume, phi, m_new, self.volume_radius, self.n_volume,
                           self.tau_volume, 3)
        self._progress((m_new > 0) & ~volume, phi, m_new, self.radius, self.n_photons, self.tau, 2)

    def _progress(self, hit: np.ndarray, phi: np.ndarray, m_new: np.ndarray, radius: np.ndarray,
                  count: np.ndarray, tau: np.ndarray, dims: int) -> None:
        """The update of the pixels ``hit`` in place: N' = N + alpha M, the disk's area
        (``dims`` 2) or the ball's volume (3) scaled by N' / (N + M), tau by the same."""
        alpha = float(self.sppm.alpha)
        n_old = count[hit]
        n_new = n_old + alpha * m_new[hit]
        r_old = radius[hit]
        shrink = n_new / (n_old + m_new[hit])
        r_new = r_old * (np.sqrt(shrink) if dims == 2 else np.cbrt(shrink))
        tau[hit] = (tau[hit] + phi[hit]) * ((r_new / r_old) ** dims)[:, None]
        count[hit] = n_new
        radius[hit] = r_new

    @current
    def iterate(self, should_stop: Callable[[], bool] | None = None) -> bool:
        """One SPPM iteration; False (and nothing changed) when stopped part way.
        ``should_stop()`` is asked before every piece after the first."""
        self.abandon_iteration()
        self.iteration_piece()
        while True:
            if should_stop is not None and should_stop():
                self.abandon_iteration()
                return False
            if self.iteration_piece():
                return True

    @current
    def emission_records(self) -> tuple[np.ndarray, np.ndarray]:
        """The last photon pass's emitted photons (record_emission=True): power (P, 3)
        float64 and light index (P,), 0xFFFFFFFF for a photon that could not start."""
        if not self.record_emission:
            raise UsageError("emission_records: construct the renderer with record_emission=True")
        words = np.frombuffer(self._records.read(), np.uint32)[pl.RECORD_HEADER_WORDS:].reshape(-1, 4)
        return words[:, :3].copy().view(np.float32).astype(np.float64), words[:, 3].copy()

    @current
    def step(self, iterations: int, callback: Callable[[int, int], None] | None = None,
             should_stop: Callable[[], bool] | None = None) -> int:
        """Run ``iterations`` more iterations; ``callback(done, total)`` after each.
        ``should_stop()`` is asked before every iteration and between photon dispatches;
        an iteration stopped part way is dropped. Returns the iterations added."""
        if iterations < 0:
            raise UsageError(f"iterations: expected a non-negative integer, got {iterations}")
        first, target = self.iterations, self.iterations + iterations
        while self.iterations < target:
            if should_stop is not None and should_stop():
                break
            if not self.iterate(should_stop):
                break
            if callback is not None:
                callback(self.iterations, target)
        return self.iterations - first

    @current
    def radiance(self) -> np.ndarray:
        """The SPPM estimate (H, W, 3) float64."""
        n = max(self.iterations, 1)
        photons = float(n) * self.photons_per_iteration
        L = self.ld_sum / n + self.tau / (photons * math.pi * self.radius ** 2)[:, None]
        if self.media:
            L = L + self.tau_volume / (photons * (4.0 / 3.0) * math.pi * self.volume_radius ** 3)[:, None]
        return L.reshape(self.band_height, self.width, 3)

    def image(self) -> Film:
        return self.film()

    @current
    def film(self) -> Film:
        """The image (the band of ``rows`` only) as a :class:`Film`: ``count`` holds the
        iterations; SPPM has no per-sample variance (``m2`` is zero), error bars come from
        independent runs."""
        h, w = self.band_height, self.width
        return Film(mean=self.radiance().astype(np.float32), m2=np.zeros((h, w, 3), np.float32),
                    count=np.full((h, w), float(self.iterations), np.float32),
                    nonfinite=np.zeros((h, w), np.float32), spp=self.iterations,
                    aovs=self.aovs(),
                    sampler=self.settings.sampler.kind)

    # the per-pixel state in float64, in this order (8 numbers per pixel; 13 with media)
    _STATE = (("radius", 1), ("n_photons", 1), ("tau", 3), ("ld_sum", 3))
    _VOLUME_STATE = (("volume_radius", 1), ("n_volume", 1), ("tau_volume", 3))

    @property
    def state_fields(self) -> tuple[tuple[str, int], ...]:
        """The per-pixel state's arrays and their numbers per pixel: the volume state too in
        a scene with media."""
        return self._STATE + (self._VOLUME_STATE if self.media else ())

    @current
    def aovs(self) -> dict[str, np.ndarray]:
        """SPPM's pictures: ``radius`` (H, W), each pixel's search radius in scene units,
        and with ``photon_view=True`` ``photons`` (H, W, 3), the power of the photon hits
        the camera sees in each pixel per emitted photon (not part of the checkpoint); the
        band of ``rows`` only."""
        h, w = self.band_height, self.width
        out = {"radius": self.radius.reshape(h, w).astype(np.float32)}
        if self.photon_view:
            sums = accum.fixed_sums(np.frombuffer(self._view.read(), np.uint32)).astype(np.float64)
            photons = max(self.iterations, 1) * self.photons_per_iteration
            view = (sums / (SPLAT_SCALE * photons)).reshape(self.height, w, 3)
            top = TILE * self.rows[0]
            out["photons"] = view[top:top + h].astype(np.float32)
        return out

    @current
    def state(self) -> dict[str, Any]:
        """The per-pixel SPPM state: what a checkpoint saves. The checkpoint format holds
        uint32 arrays (``sums``, ``squares``, ``aov``, ``splat``): ``sums`` carries the
        float64 state's bits (radius, N, tau rgb, Ld sum rgb per pixel) viewed as uint32,
        so a resumed render continues exactly where it stopped."""
        n = self.width * self.band_height
        packed = np.concatenate([np.asarray(getattr(self, name), np.float64).reshape(n, k)
                                 for name, k in self.state_fields], axis=1)
        return {"fingerprint": self.fingerprint(), "spp_done": self.iterations,
                "sums": np.ascontiguousarray(packed).view(np.uint32).reshape(-1),
                "squares": np.zeros(4, np.uint32), "aov": np.zeros(4, np.uint32),
                "splat": np.zeros(4, np.uint32),
                "width": self.width, "height": self.height, "rows": self.rows}

    @current
    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state()`` of an equal renderer (same fingerprint)."""
        if state.get("fingerprint") != self.fingerprint():
            raise UsageError("the saved SPPM state belongs to a different scene or different "
                             "render settings (fingerprints differ)")
        rows = tuple(state.get("rows", (0, self.base.tiles_y)))
        if rows != self.rows:
            raise UsageError(f"the saved SPPM state holds tile rows {rows}, this renderer "
                             f"{self.rows} (reset(rows=...) first)")
        n = self.width * self.band_height
        width = sum(k for _, k in self.state_fields)
        bits = np.ascontiguousarray(state["sums"], np.uint32)
        if bits.size != 2 * width * n:
            raise UsageError(f"the saved SPPM state has {bits.size // 2} numbers, expected {width * n}")
        packed = bits.view(np.float64).reshape(n, width)
        column = 0
        for name, k in self.state_fields:
            part = packed[:, column:column + k].copy()
            setattr(self, name, part[:, 0] if k == 1 else part)
            column += k
        self.iterations = int(state["spp_done"])

    def max_loop_count(self) -> int:
        """The most loop iterations one invocation of the camera or photon kernels ran
        (settings with count_loops=True; 0 otherwise): it must stay far below llvmpipe's
        silent ~65,535 cap."""
        if not self.settings.count_loops:
            return 0
        return int(self.base.debug_counters().max())

    def device_bytes_per_pixel(self) -> int:
        """Device bytes per pixel: SPPM's visible points, radii and deposits (the grid adds
        4 bytes per listed cell, up to 27 per visible point) and the inner renderer's
        accumulation (unused by SPPM but allocated)."""
        return pl.BYTES_PER_PIXEL + self.base.device_bytes_per_pixel()

    def stats(self) -> dict[str, Any]:
        """``--stats`` entries: the photon maps, radii, lookups and memory (``photon``); a
        photon estimate is biased (consistent only)."""
        return {"photon": self.photon_stats(), "biased": True}

    def photon_stats(self) -> dict[str, Any]:
        """What --stats reports of SPPM: photons per iteration, alpha, kernel, the radii
        now (min, mean, max), the gathers' candidate counts and memory."""
        return {"photons_per_iteration": self.photons_per_iteration, "alpha": float(self.sppm.alpha),
                "kernel": self.sppm.kernel, "initial_radius": self.initial_radius,
                "radius": [float(self.radius.min()), float(self.radius.mean()), float(self.radius.max())],
                "gathers": dict(self.counters), "memory": self.memory()}

    def memory(self) -> dict[str, int]:
        """Device bytes per pixel and per photon (photons are not stored: deposited at once)."""
        return {"bytes_per_pixel": pl.BYTES_PER_PIXEL,
                "bytes_per_photon": pl.BYTES_PER_RECORD if self.record_emission else 0}

    @current
    def release(self) -> None:
        for buf in self._own:
            buf.release()
        self._own = []
        self.base.release()

    @property
    def device_scene(self) -> Any:
        """The scene's device data (the inner renderer's; None once released)."""
        return self.base.device_scene

    def bind_film(self) -> None:
        """Bind the inner renderer's accumulation, where the preview loads SPPM's estimate
        (Renderer.load_accumulation), for the display to read."""
        self.base.bind_film()

    @property
    def texture_bytes(self) -> int:
        """Bytes of the scene's texture atlas pages on the device."""
        return self.base.texture_bytes

    @property
    def bvh_cache(self) -> str:
        """Where the scene's BVH came from (Renderer.bvh_cache)."""
        return self.base.bvh_cache

    @property
    def mesh_capacity(self) -> dict | None:
        """The BVH triangles' bytes per triangle and the most that fit (Renderer.mesh_capacity)."""
        return self.base.mesh_capacity

    def __enter__(self) -> "SppmRenderer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
