"""Photon mapping, the classic two-pass method (Jensen 2001), on the device.

A photon pass (``shaders/photon/photon_store.comp.glsl``) traces photons from the lights
(chosen by power) and stores them at non-delta surfaces in two maps: the global map
(every photon hit, tagged direct, caustic or indirect) and the caustic map (a pass of its
own that keeps only photons reaching a non-delta surface through delta surfaces alone,
L S+ D). Each map is sorted into a hash grid in numpy (:func:`build_point_grid`). The
camera pass is a render kernel (``shaders/integrators/photon.glsl``) accumulated by
:class:`Renderer` like any other: direct light by next-event estimation, caustics from
the caustic map, the rest from the global map at the first non-delta surface or through
a one-bounce final gather. Its progress, checkpoints, ``--time`` and the preview are the
Renderer's; the maps depend on the scene and seed only, so they are traced again (the
same photons) when a render resumes.

The estimate is biased (consistent only as photons grow and the radius shrinks): the
sources are listed in README.md ("Photon mapping").
"""
from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import UsageError
from ..film import Film
from ..gl import shaders
from ..gl.buffers import BufferTexture
from ..gl.context import current
from ..gpu import bindings
from ..render import accum
from ..render.accumulation import SPLAT_SCALE
from ..render.driver import part_digests
from ..render.renderer import Renderer
from . import layout as pl
from .grid import PointGrid, build_point_grid, typical_radius

MAP_NAMES = ("global map", "caustic map")

PHOTONS_PER_DISPATCH = 1 << 16   # photons per tracing dispatch (64 per work group)
MAX_KNN = 64                     # kMaxKnn in shaders/photon/photon_gather.glsl
DEFAULT_PHOTONS = 1 << 18
DEFAULT_PHOTONS_PER_DISK = 64    # the default radius holds this many photons around a typical one
KNN_REACH = 1.5                  # the kNN search's largest radius over a typical k-th distance
# volume photons' default radius holds DEFAULT_PHOTONS_PER_DISK of them around the photons of
# this quantile of the k-th nearest distance (their denser part), not the median: their
# density spans orders of magnitude in open fog (photons wander far from the scene) and near a
# light inside fog, where the median's radius overran the lookups' candidate bound (fog around
# the camera in the parity scene medium-camera: -23% at the median, -1.6% at 0.1; the fog
# ball alike at both)
VOLUME_QUANTILE = 0.1


@dataclass(frozen=True)
class PhotonSettings:
    """The photon integrator's parameters: ``photons`` for the global map,
    ``caustic_photons`` for the caustic map (None: as many), a fixed lookup ``radius``
    in scene units or ``knn`` nearest neighbours (not both; neither: a radius that
    holds DEFAULT_PHOTONS_PER_DISK photons where they spread evenly), the density
    ``kernel`` and ``final_gather``; ``direct``: direct light by next-event estimation
    (``nee``) or from the global map's direct photons (``photons``: tests of the
    density estimate)."""

    photons: int = DEFAULT_PHOTONS
    caustic_photons: int | None = None
    radius: float | None = None
    knn: int | None = None
    kernel: str = "uniform"
    final_gather: bool = False
    photon_view: bool = False        # also splat the global map's photons (the "photons" AOV)
    volume_radius: float | None = None   # the volume photons' lookup radius (None: as ``radius``)
    direct: str = "nee"              # direct light by next-event estimation, or "photons" (tests)

    def __post_init__(self) -> None:
        for name in ("photons", "caustic_photons"):
            v = getattr(self, name)
            if v is None and name == "caustic_photons":
                continue
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 1 <= v < 1 << 31:
                raise UsageError(f"{name.replace('_', ' ')}: expected a positive integer, got {v!r}")
        r = self.radius
        for name in ("radius", "volume_radius"):
            r = getattr(self, name)
            if r is not None and not (isinstance(r, (int, float)) and math.isfinite(r) and r > 0):
                raise UsageError(f"{name.replace('_', ' ')}: expected a positive number of scene "
                                 f"units, got {r!r}")
        r = self.radius
        k = self.knn
        if k is not None and (not isinstance(k, (int, np.integer)) or not 1 <= k <= MAX_KNN):
            raise UsageError(f"knn: expected an integer in [1, {MAX_KNN}], got {k!r}")
        if r is not None and k is not None:
            raise UsageError("radius and knn: give one of them (a fixed radius or k nearest photons)")
        if self.kernel not in pl.KERNELS:
            raise UsageError(f"kernel: expected one of {', '.join(pl.KERNELS)}, got {self.kernel!r}")
        if self.direct not in ("nee", "photons"):
            raise UsageError(f"direct: expected nee or photons, got {self.direct!r}")


def canonical_order(records: np.ndarray) -> np.ndarray:
    """An order of photon records (N, 12) that depends on the records alone: atomics store
    photons in any order, and this one makes the radius estimate and the grid, hence the
    image, repeatable (and the same however the map was traced: in one buffer or
    several). By the bits of x and y; records that share them (the floor's y = 0 with equal
    x, say) by all their words."""
    words = records.view(np.uint32)
    key = (words[:, 0].astype(np.uint64) << np.uint64(32)) | words[:, 1]
    order = np.argsort(key, kind="stable")
    ks = key[order]
    equal = ks[1:] == ks[:-1]
    tied = np.zeros(len(order), bool)
    tied[1:] |= equal
    tied[:-1] |= equal
    if tied.any():
        at = np.nonzero(tied)[0]
        sub = order[at]
        order[at] = sub[np.lexsort((*words[sub].T[::-1], ks[at]))]
    return order


class PhotonRenderer(Renderer):
    """A scene on the device rendered by photon mapping: :class:`Renderer` with the
    photon integrator's camera kernel and the two photon maps, traced at construction."""

    driver = "photon"

    def __init__(self, scene: Any, settings: Any = None, photon: PhotonSettings | None = None, *,
                 ctx: Any = None, device: Any = None, **overrides: Any) -> None:
        self.photon = photon or PhotonSettings()
        if settings is None:
            overrides.setdefault("integrator", "photon")
        super().__init__(scene, settings, ctx=ctx, device=device, **overrides)
        t0 = time.perf_counter()
        # per map: photons stored, dispatches traced again (their photons overflowed a
        # buffer)
        self.counters: dict[str, list[Any]] = {"stored": [0, 0], "retraced": [0, 0]}
        self.grids: list[PointGrid] = []
        self._trace_maps()
        self.timings["photons"] = time.perf_counter() - t0

    # -- setup -------------------------------------------------------------------------------
    def _compile(self) -> None:
        super()._compile()
        # a sample makes two lookups (caustic map, and the global map or a gather ray's) of
        # at most 4096 candidates, or 2048 with the kNN heap's up to 6 steps each
        # (photon/photon_gather.glsl): 2 samples ~16k, 1 kNN sample ~29k loop iterations
        # at worst, below llvmpipe's silent 65,535 (tests/photon/test_photon.py test04)
        if self.settings.samples_per_pass is None:
            self.samples_per_pass = 2 if self.photon.knn is None else 1
        # the render kernel's scene code and library (Renderer._compile made them)
        slots = {"scene": self.slots["scene"]}
        self.store_kernel: Any = shaders.compile_compute(
            self.ctx, "photon/photon_store.comp.glsl", defines=self.defines, slots=slots,
            library=self.library)
        source = shaders.preprocess("photon/photon_store.comp.glsl", defines=self.defines,
                                    slots=slots, library=self.library).source
        self._store_hash = hashlib.sha256(source.encode()).hexdigest()
        gl = self.gl
        empty = np.zeros((0, 4), np.float32)
        self._maps: list[Any] = [BufferTexture(gl, empty, "rgba32f", name) for name in MAP_NAMES]
        self._cells: list[Any] = [BufferTexture(gl, np.zeros(0, np.uint32), "r32ui", f"{name} table")
                                  for name in MAP_NAMES]
        self._counters = gl.buffer(reserve=4 * pl.MAP_COUNTER_WORDS)
        self._counters.clear()
        self._map_params = gl.buffer(reserve=pl.PHOTON_MAP_PARAMS.itemsize)
        self._view = gl.buffer(reserve=24 * self.width * self.height if self.photon.photon_view else 16)
        self._view.clear()
        self._block = np.zeros(1, pl.PHOTON_MAP_PARAMS)[0]
        self._map_params.write(self._block.tobytes())

    @property
    def photons(self) -> tuple[int, int]:
        """Photons emitted for the global and the caustic map."""
        p = self.photon
        return p.photons, p.caustic_photons if p.caustic_photons is not None else p.photons

    def lookup_radius(self, which: int) -> float:
        """The global (0) or caustic (1) map's lookup radius: the fixed radius; or for
        kNN the search's largest, KNN_REACH times the radius holding k photons around a
        typical photon of the map; or by default the radius holding
        DEFAULT_PHOTONS_PER_DISK photons around a typical photon (of each map)."""
        if self.photon.radius is not None:
            return float(self.photon.radius)
        return self._radii[which]

    def _estimate_radius(self, positions: np.ndarray, dims: int = 2) -> float:
        """The lookup radius of photons at ``positions``: on surfaces (``dims`` 2), or in
        media (3: volume photons, whose count grows with r^3); a fixed ``volume_radius``
        for those, else the fixed ``radius``, else from their spread (volume photons: in
        their denser part, VOLUME_QUANTILE)."""
        if dims == 3 and self.photon.volume_radius is not None:
            return float(self.photon.volume_radius)
        if self.photon.radius is not None:
            return float(self.photon.radius)
        k = self.photon.knn or DEFAULT_PHOTONS_PER_DISK
        r = typical_radius(positions, k, dims=dims, quantile=0.5 if dims == 2 else VOLUME_QUANTILE)
        if not r > 0:      # an empty map: any radius finds nothing
            r = 1e-3 * float(self.packed.sphere_bounds[1])
        return r * (KNN_REACH if self.photon.knn else 1.0)

    def _map_binding_limit(self) -> int:
        """Bytes the tracing kernel's storage block may hold: the device's
        GL_MAX_SHADER_STORAGE_BLOCK_SIZE (tests lower it so that small maps are traced
        in pieces)."""
        return self.binding_limit()

    def _texel_limit(self) -> int:
        """Texels one buffer texture may hold: GL_MAX_TEXTURE_BUFFER_SIZE."""
        return int(self.gl.info["GL_MAX_TEXTURE_BUFFER_SIZE"])

    def trace_photons(self) -> int:
        """Photons the tracing buffer holds at most: one storage-block binding's worth."""
        return max(1, self._map_binding_limit() // pl.BYTES_PER_PHOTON)

    def map_photons(self) -> int:
        """Photons one map may hold: one buffer texture's worth (llvmpipe: 44.7M)."""
        return self._texel_limit() // pl.TEXELS_PER_PHOTON

    def _trace(self, which: int) -> np.ndarray:
        """Traces map ``which``: its stored photons (S, 12) float32, in no set order.

        The tracing kernel stores into a buffer of at most one binding (first sized for 4
        photons an emitted photon in the global map, 1 in the caustic map), reading the
        count back after every dispatch. A dispatch that overflows the buffer is traced
        again into an emptied one (photon j's numbers depend on j alone: the same
        photons), after the photons of the dispatches before are read back; the
        buffer doubles at every overflow, up to a binding, and the dispatch halves when it
        alone does not fit one. The photon-map view splats each
        photon once (store.w: photons below it were splatted already)."""
        most = self.trace_photons()
        total = self.photons[which]
        capacity = min(most, 4 * total if which == 0 else total)
        prm = self.param_block(0, 0)
        self.bind()
        self.write_params(prm)
        self._view.bind_to_storage_buffer(bindings.SSBO_ACCUM_SPLAT)
        block = self._block.copy()
        max_depth = self.settings.integrator.max_depth
        view = int(self.photon.photon_view and which == 0)
        chunks: list[np.ndarray] = []
        buf: Any = None
        first, stored, splatted, per_dispatch = 0, 0, 0, PHOTONS_PER_DISPATCH
        try:
            while first < total:
                if buf is None:
                    buf = self.gl.buffer(reserve=max(16, pl.BYTES_PER_PHOTON * capacity))
                    buf.bind_to_storage_buffer(bindings.SSBO_TRACED_PHOTONS)
                    self._counters.clear()
                    stored = 0
                count = min(per_dispatch, total - first)
                block["trace"] = (first, count, total, which)
                block["store"] = (capacity, 256 if max_depth < 0 else max_depth, view, splatted)
                self._map_params.write(block.tobytes())
                self.store_kernel.run(group_x=-(-count // 64))
                n = int(np.frombuffer(self._counters.read(4), np.uint32)[0])
                if n <= capacity:
                    stored, first = n, first + count
                    continue
                # overflow: keep the earlier dispatches' photons, trace this one again
                self.counters["retraced"][which] += 1
                splatted = max(splatted, first + count)
                if stored:
                    chunks.append(self._read_photons(buf, stored))
                elif capacity == most:
                    if count == 1:
                        raise UsageError(f"photon maps: one photon stores {n} hits, more than a "
                                         f"storage buffer's {most}")
                    per_dispatch = count // 2
                capacity = min(most, 2 * capacity)
                buf.release()
                buf = None
            if buf is not None and stored:
                chunks.append(self._read_photons(buf, stored))
        finally:
            if buf is not None:
                buf.release()
        self.bind()
        return np.concatenate(chunks) if chunks else np.zeros((0, 12), np.float32)

    @staticmethod
    def _read_photons(buf: Any, n: int) -> np.ndarray:
        return np.frombuffer(buf.read(pl.BYTES_PER_PHOTON * n), np.float32).reshape(n, 12)

    def _upload_map(self, which: int, records: np.ndarray, cells: np.ndarray) -> None:
        """Map ``which``'s photons (in grid order) and its grid's hash table to their
        buffer textures."""
        name = ("--photons", "--caustic-photons")[which]
        if len(records) > self.map_photons():     # (its hash table holds one entry more)
            raise UsageError(f"{name} {self.photons[which]}: the {MAP_NAMES[which]} stores "
                             f"{len(records)} photons, above the {self.map_photons()} a buffer "
                             f"texture holds on this device: trace fewer")
        self._maps[which].release()
        self._cells[which].release()
        self._maps[which] = BufferTexture(self.gl, records, "rgba32f", MAP_NAMES[which])
        self._cells[which] = BufferTexture(self.gl, cells, "r32ui", f"{MAP_NAMES[which]} table")

    def _trace_maps(self) -> None:
        self._radii = [0.0, 0.0]
        self._volume_radii = [0.0, 0.0]
        self.volume_grids: list[PointGrid] = []
        self.counters["volume"] = [0, 0]
        for which in (0, 1):
            records = self._trace(which)
            stored = len(records)
            self.counters["stored"][which] = stored
            if stored:
                records = records[canonical_order(records)]
            # volume photons (scenes with media) after the surface photons, each in its grid
            volume = records[:, 3].view(np.uint32) >= pl.PHOTON_VOLUME
            if volume.any():
                records, volumes = records[~volume], records[volume]
            else:
                volumes = records[:0]
            self.counters["volume"][which] = len(volumes)
            self._radii[which] = self._estimate_radius(records[:, :3])
            grid = build_point_grid(records[:, :3], self._radii[which])
            self.grids.append(grid)
            cells = grid.offsets if grid.table_size else np.zeros(1, np.uint32)
            ordered = records[grid.order]
            if len(volumes):
                self._volume_radii[which] = self._estimate_radius(volumes[:, :3], dims=3)
                vgrid = build_point_grid(volumes[:, :3], self._volume_radii[which])
                self._block["volume_table"][which] = len(cells)
                cells = np.concatenate([cells, vgrid.offsets + np.uint32(len(records))])
                ordered = np.concatenate([ordered, volumes[vgrid.order]])
                self.volume_grids.append(vgrid)
                name = ("global", "caustic")[which]
                self._block[f"{name}_volume_size"] = (*vgrid.size, vgrid.table_size)
                self._block[f"{name}_volume_lo"] = (*vgrid.lo, vgrid.cell)
            self._upload_map(which, ordered, cells)
            size = "global_size" if which == 0 else "caustic_size"
            lo = "global_lo" if which == 0 else "caustic_lo"
            self._block[size] = (*grid.size, grid.table_size)
            self._block[lo] = (*grid.lo, grid.cell)
        self._block["radius"] = (self.lookup_radius(0), self.lookup_radius(1),
                                 1.0 / self.photons[0], 1.0 / self.photons[1])
        self._block["volume_radius"][:2] = self._volume_radii
        self._block["mode"] = (pl.KERNELS[self.photon.kernel], self.photon.knn or 0,
                               int(self.photon.final_gather), int(self.photon.direct == "photons"))
        self._block["trace"] = 0
        self._block["store"] = 0
        self._map_params.write(self._block.tobytes())
        self._counters.clear()

    def bind(self) -> None:
        super().bind()
        self._counters.bind_to_storage_buffer(bindings.SSBO_MAP_COUNTERS)
        for tex, unit in zip((*self._maps, *self._cells), (bindings.TEX_GLOBAL_MAP, bindings.TEX_CAUSTIC_MAP,
                                                           bindings.TEX_GLOBAL_CELLS, bindings.TEX_CAUSTIC_CELLS)):
            tex.bind(unit)
        self._map_params.bind_to_uniform_block(bindings.UBO_PHOTON_MAP_PARAMS)

    def fingerprint(self) -> str:
        """The Renderer's fingerprint with the photon maps' parameters and kernel."""
        h = hashlib.sha256(super().fingerprint().encode())
        for _, data in self._photon_inputs():
            h.update(data)
        return h.hexdigest()

    def fingerprint_parts(self) -> dict[str, str]:
        # the store kernel's source is made of the render kernel's defines and scene code,
        # which the Renderer's parts cover: its settings are the part of its own
        return {**super().fingerprint_parts(), **part_digests(self._photon_inputs()[:1])}

    def _photon_inputs(self) -> list[tuple[str, bytes]]:
        p = self.photon
        settings: tuple[Any, ...] = ("photon", self.photons, p.radius, p.knn, p.kernel,
                                     p.final_gather, p.direct)
        if p.volume_radius is not None:
            settings += (p.volume_radius,)
        return [("photon map settings", repr(settings).encode()),
                ("photon store kernel", self._store_hash.encode())]

    # -- outputs -----------------------------------------------------------------------------
    @current
    def map_records(self, which: int) -> np.ndarray:
        """The global (0) or caustic (1) map's photons as the device holds them: (stored,
        12) float32 records in grid order (photon/map_layout.glsl)."""
        stored = self.counters["stored"][which]
        words = np.frombuffer(self._maps[which].buffer.read(pl.BYTES_PER_PHOTON * stored), np.float32)
        return words.reshape(stored, 12)

    @current
    def lookup_counters(self) -> dict[str, int]:
        """Lookup candidates since the maps were built: ``skipped`` by the bound,
        ``visited``, and the most one lookup visited (``max_visited``)."""
        c = np.frombuffer(self._counters.read(), np.uint32)
        return {"skipped": int(c[1]), "visited": int(c[2]), "max_visited": int(c[3])}

    @current
    def film(self) -> Film:
        """The Renderer's film; with ``photon_view`` its ``photons`` AOV: the global map's
        photon hits the camera sees, power per emitted photon in each pixel."""
        film = super().film()
        if self.photon.photon_view:
            sums = accum.fixed_sums(np.frombuffer(self._view.read(), np.uint32)).astype(np.float64)
            view = (sums / (SPLAT_SCALE * self.photons[0])).reshape(self.height, self.width, 3)
            first = 8 * self.rows[0]
            film.aovs["photons"] = view[first:first + self.band_height].astype(np.float32)
        return film

    def stats(self) -> dict[str, Any]:
        """``--stats`` entries: the photon maps, radii, lookups and memory (``photon``); a
        photon estimate is biased (consistent only)."""
        return {"photon": self.photon_stats(), "biased": True}

    def photon_stats(self) -> dict[str, Any]:
        """What --stats reports of the photon maps: photons emitted and stored per map,
        lookup radii (the kNN search's largest), the settings, the lookups' candidate
        counts, memory and the seconds spent tracing and sorting the maps."""
        p = self.photon
        return {"photons_emitted": list(self.photons), "photons_stored": list(self.counters["stored"]),
                "radius": [self.lookup_radius(0), self.lookup_radius(1)], "knn": p.knn,
                "volume_photons": list(self.counters["volume"]), "volume_radius": list(self._volume_radii),
                "kernel": p.kernel, "final_gather": p.final_gather,
                "largest_cell": [g.max_cell_entries for g in self.grids],
                "lookups": self.lookup_counters(), "memory": self.memory(),
                "seconds": self.timings.get("photons", 0.0)}

    def memory(self) -> dict[str, Any]:
        """Device bytes per photon stored (and 4 more in its map's hash table) and per
        pixel (the camera pass's accumulation), photons stored per map, the maps' bytes,
        the most photons a map holds (one buffer texture) and the tracing buffer holds."""
        stored = self.counters["stored"]
        return {"bytes_per_photon": pl.BYTES_PER_PHOTON, "bytes_per_pixel": self.device_bytes_per_pixel(),
                "global_photons": stored[0], "caustic_photons": stored[1],
                "map_bytes": sum(pl.BYTES_PER_PHOTON * s + 4 * (g.table_size + 1)
                                 for s, g in zip(stored, self.grids)),
                "map_photons_limit": self.map_photons(), "trace_photons_limit": self.trace_photons()}

    @current
    def release(self) -> None:
        for buf in (*self._maps, *self._cells, self._counters, self._map_params, self._view):
            buf.release()
        super().release()
