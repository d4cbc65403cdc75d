"""Vertex connection and merging (Georgiev, Křivánek, Davidovič and Slusallek 2012) on the
device: bdpt's connection strategies and photon mapping's merges under one MIS weight.

Each iteration (one camera sample per pixel, its index i - 1) does three things:

- a light pass (``shaders/kernels/vcm_light.comp.glsl``) traces one light subpath per
  pixel, splats its lens connections (t = 1) onto the film, and stores its vertices and
  its merge points (non-delta surface vertices past the light);
- the host sorts the merge points into a hash grid of cell 2 r_i
  (:func:`glrender.photon.grid.build_point_grid`), r_i = r_1 i^((alpha - 1) / 2);
- the camera pass, the render kernel with ``integrators/vcm.glsl``, connects each camera
  subpath to the light subpath of its pixel's index and merges at its vertices with the
  merge points within r_i.

The iterations accumulate like the render kernel's samples: sample i's radius and light
paths depend on i and the seed alone, so progress, checkpoints, ``--resume`` and sample
ranges rendered elsewhere are the Renderer's. The merges make the estimate biased; the
bias falls with the radius (consistent for alpha in (0, 1)).

``mode``: ``vcm`` (connections and merges), ``vm`` (merges and the camera subpath reaching
the lights: progressive photon mapping under the same weights) or ``bpt`` (connections
alone, both subpaths in one invocation: the bdpt integrator itself, bitwise).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..gl import shaders
from ..gl.context import current
from ..gpu import bindings
from ..photon.grid import stable_argsort_u32
from ..photon.sppm import footprint_radius
from ..render import strategies
from ..render.renderer import Renderer
from . import layout as vl

MODES = {"vcm": 1, "vm": 2, "bpt": 0}
DEFAULT_ALPHA = 0.75        # SmallVCM's: the radius falls as i^-0.125
# the default initial radius, in pixel footprints at the scene's centre (SPPM's rule at half
# its 2: on the Cornell box, door and caustic scenes at 128x128 the RMSE after 16 iterations
# was the same or lower than at 2 footprints, with a third of the bias and fewer candidates)
DEFAULT_RADIUS_PIXELS = 1.0
VERTICES_PER_PATH = 4       # first guess of the vertex buffer (stored vertices per light path)
MERGES_PER_PATH = 3         # and of the merge points'
GRID_SLACK = 1e-3           # the merge grid's cells are 2 r (1 + this)
MAX_LIGHT_PATHS = 1 << 26   # a merge point's key holds the light path index in 27 bits
MAX_CACHE_CONNECTIONS = 16  # per camera vertex, to a light vertex cache


def iteration_time(index: int, seed: int) -> float:
    """The uniform number in [0, 1) whose shutter time every path of iteration ``index`` + 1
    takes in a scene with motion: the base-2 radical inverse of the index (the iterations
    stratify the shutter), rotated by a number of the seed (Cranley-Patterson), so that it
    depends on the index and the seed alone."""
    bits = int(f"{index & 0xFFFFFFFF:032b}"[::-1], 2)
    rotation = ((seed & 0xFFFFFFFF) * 2654435761 + 0x9E3779B9) & 0xFFFFFFFF
    return ((bits + rotation) & 0xFFFFFFFF) / 2.0 ** 32


def groups_2d(invocations: int) -> tuple[int, int]:
    """Work groups of 64 for ``invocations``, in rows of at most 65,535 (GL's guaranteed
    count along one axis): (x, y); the kernels number them row by row."""
    groups = max(1, -(-invocations // 64))
    rows = -(-groups // 65535)
    return -(-groups // rows), rows


@dataclass(frozen=True)
class VcmSettings:
    """vcm's own parameters: ``mode`` (vcm, vm or bpt), ``initial_radius`` r_1 in scene
    units (None: DEFAULT_RADIUS_PIXELS pixel footprints at the scene's centre), ``alpha`` in
    (0, 1), the radius schedule r_i = r_1 i^((alpha - 1) / 2), and ``light_paths`` traced
    per iteration (None: one per pixel; fewer: pixels share the one they connect to), and
    ``cache_connections``: with a light vertex cache (Davidovič et al. 2014), the light
    vertices drawn from all the iteration's light subpaths that each camera vertex connects
    to (0: none, each camera vertex connects to every vertex of its pixel's own subpath)."""

    mode: str = "vcm"
    initial_radius: float | None = None
    alpha: float = DEFAULT_ALPHA
    light_paths: int | None = None     # per iteration (None: one per pixel)
    cache_connections: int = 0          # per camera vertex, to a light vertex cache (0: none)

    def __post_init__(self) -> None:
        n = self.light_paths
        if n is not None and (not isinstance(n, (int, np.integer)) or isinstance(n, bool)
                              or not 1 <= n <= MAX_LIGHT_PATHS):
            raise UsageError(f"light paths: expected an integer in [1, {MAX_LIGHT_PATHS}], got {n!r}")
        if self.mode not in MODES:
            raise UsageError(f"vcm mode: expected one of {', '.join(MODES)}, got {self.mode!r}")
        r = self.initial_radius
        if r is not None and not (isinstance(r, (int, float)) and not isinstance(r, bool)
                                  and math.isfinite(r) and r > 0):
            raise UsageError(f"initial radius: expected a positive number of scene units, got {r!r}")
        a = self.alpha
        if not (isinstance(a, (int, float)) and not isinstance(a, bool) and 0 < a < 1):
            raise UsageError(f"alpha: expected a number in (0, 1), got {a!r}")
        c = self.cache_connections
        if not isinstance(c, (int, np.integer)) or isinstance(c, bool) or not 0 <= c <= MAX_CACHE_CONNECTIONS:
            raise UsageError(f"light vertex cache: expected an integer in [0, {MAX_CACHE_CONNECTIONS}] "
                             f"connections per camera vertex, got {c!r}")
        if c and self.mode != "vcm":
            raise UsageError(f"light vertex cache: only in vcm mode 'vcm' (connections and merges), "
                             f"not {self.mode!r}")

    @property
    def merges(self) -> bool:
        return self.mode != "bpt"


class VcmRenderer(Renderer):
    """A scene on the device rendered by vertex connection and merging: :class:`Renderer`
    with vcm's camera kernel, plus a light pass and a merge grid before every sample."""

    driver = "vcm"

    def __init__(self, scene: Any, settings: Any = None, vcm: VcmSettings | None = None, *,
                 ctx: Any = None, device: Any = None, **overrides: Any) -> None:
        self.vcm = vcm or VcmSettings()
        if settings is None:
            overrides.setdefault("integrator", "vcm")
        # merges join light vertices of other light paths, which must be at the same time:
        # in a scene with motion every path of an iteration takes the iteration's time
        cam = scene.camera
        self.shared_time = self.vcm.merges and scene.shutter.close > scene.shutter.open and (
            any(s.moving for s in scene.shapes) or (
                cam.world_from_camera_close is not None
                and not np.allclose(cam.world_from_camera_close, cam.world_from_camera)))
        self.counters = {"vertices": 0, "merge_points": 0, "retraced": 0}
        self.grid_seconds = 0.0
        self.light_seconds = 0.0
        super().__init__(scene, settings, ctx=ctx, device=device, **overrides)
        self.radius_1 = float(self.vcm.initial_radius or footprint_radius(
            scene, self.packed.sphere_bounds, self.width, self.height, DEFAULT_RADIUS_PIXELS))

    # -- setup -------------------------------------------------------------------------------
    def _integrator_glsl(self, spec: Any) -> str:
        return "integrators/bdpt.glsl" if not self.vcm.merges else super()._integrator_glsl(spec)

    def _strategy_merges(self) -> bool:
        return self.vcm.merges

    def _integrator_defines(self) -> dict[str, int]:
        if not self.vcm.merges:
            return {}
        out = {"GLRENDER_VCM_MODE": MODES[self.vcm.mode]}
        if self.shared_time:
            out["GLRENDER_SHARED_TIME"] = 1
        if self.vcm.cache_connections:
            out["GLRENDER_VCM_CACHE"] = self.vcm.cache_connections
        return out

    def _compile(self) -> None:
        super()._compile()
        self.light_kernel: Any = None
        if not self.vcm.merges:
            return
        # one iteration per pass: each sample has its own light pass, radius and grid
        self.samples_per_pass = 1
        self.light_kernel = shaders.compile_compute(
            self.ctx, "kernels/vcm_light.comp.glsl", defines=self.defines, slots=self.slots,
            library=self.library)
        self.order_kernel: Any = shaders.compile_compute(self.ctx, "kernels/vcm_order.comp.glsl")
        self.light_paths = int(self.vcm.light_paths or self.width * self.height)
        self._vertex_bytes = vl.vertex_bytes(bool(self.defines.get("GLRENDER_NORMAL_SHADOWING")),
                                             bool(self.defines.get("GLRENDER_MEDIA")))
        gl = self.gl
        self._vcm_params = gl.buffer(reserve=vl.VCM_PARAMS.itemsize)
        self._paths = gl.buffer(reserve=vl.PATH_BYTES * self.light_paths)
        self._counters = gl.buffer(reserve=4 * vl.COUNTER_WORDS)
        self._vertices: Any = None
        self._keys: Any = None
        self._data: Any = None
        self._sort: Any = None
        self._grid: Any = gl.buffer(reserve=16)
        self._grid.clear()
        self._ordered: Any = None     # the camera pass's grid-ordered merge points
        self._cache: Any = None       # the camera pass's light vertex cache
        self._cache_bytes = 0
        self._camera_bindings = False   # binding 15: the camera pass's cache, not the merge sort
        self._allocate(VERTICES_PER_PATH * self.light_paths, MERGES_PER_PATH * self.light_paths)
        self._block = np.zeros(1, vl.VCM_PARAMS)[0]
        self._vcm_params.write(self._block.tobytes())

    def _allocate(self, vertices: int, merges: int) -> None:
        for buf in (self._vertices, self._keys, self._data, self._sort):
            if buf is not None:
                buf.release()
        limit = self.binding_limit()
        if vertices * self._vertex_bytes > limit or merges * vl.MERGE_DATA_BYTES > limit:
            raise UsageError(f"vcm: a light pass stores {vertices} vertices and {merges} merge "
                             f"points, above one storage buffer's {limit} bytes on this device: "
                             f"render a smaller image")
        self.vertex_capacity, self.merge_capacity = vertices, merges
        self._vertices = self.gl.buffer(reserve=max(16, self._vertex_bytes * vertices))
        self._keys = self.gl.buffer(reserve=max(16, vl.MERGE_KEY_BYTES * merges))
        self._data = self.gl.buffer(reserve=max(16, vl.MERGE_DATA_BYTES * merges))
        self._sort = self.gl.buffer(reserve=max(16, vl.MERGE_SORT_BYTES * merges))

    def bind(self) -> None:
        super().bind()
        if getattr(self, "light_kernel", None) is None:
            return
        self._vcm_params.bind_to_uniform_block(bindings.UBO_VCM_PARAMS)
        self._vertices.bind_to_storage_buffer(bindings.SSBO_VCM_VERTICES)
        self._paths.bind_to_storage_buffer(bindings.SSBO_VCM_PATHS)
        # the light pass appends to the keys, the camera pass reads their grid-ordered copy
        keys = self._ordered if self._ordered is not None else self._keys
        keys.bind_to_storage_buffer(bindings.SSBO_VCM_MERGE_KEYS)
        self._data.bind_to_storage_buffer(bindings.SSBO_VCM_MERGE_DATA)
        self._grid.bind_to_storage_buffer(bindings.SSBO_VCM_GRID)
        self._counters.bind_to_storage_buffer(bindings.SSBO_VCM_COUNTERS)
        if self._cache is not None and self._camera_bindings:
            self._cache.bind_to_storage_buffer(bindings.SSBO_VCM_CACHE)
        else:
            self._sort.bind_to_storage_buffer(bindings.SSBO_VCM_MERGE_SORT)

    @current
    def reset(self, start: int = 0, rows: tuple[int, int] | None = None) -> None:
        """Renderer.reset, and the light pass and grid timers (stats) from zero."""
        super().reset(start, rows)
        self.light_seconds = self.grid_seconds = 0.0

    def _warm_up(self) -> None:
        super()._warm_up()
        if self.light_kernel is not None:
            self.bind()
            self._vcm_params.write(self._block.tobytes())   # paths.x = 0: every invocation returns
            self.light_kernel.run(group_x=1)
            one = self.gl.buffer(np.zeros(1, np.uint32).tobytes())   # one entry: merge point 0
            one.bind_to_storage_buffer(bindings.SSBO_VCM_GRID)
            self.order_kernel.run(group_x=1)
            one.release()
            self.bind()
            self.gl.finish()

    # -- one iteration -----------------------------------------------------------------------
    def param_block(self, first_sample: int, samples: int) -> Any:
        """Renderer.param_block; in a scene with motion, with the shutter time of iteration
        ``first_sample`` + 1 that all its paths take (:func:`iteration_time`)."""
        prm = super().param_block(first_sample, samples)
        if self.shared_time:
            prm["shutter"][3] = iteration_time(first_sample, int(self.settings.sampler.seed))
        return prm

    def radius(self, iteration: int) -> float:
        """The merge radius of iteration ``iteration`` (1, 2, ...): r_1 i^((alpha - 1) / 2)."""
        return self.radius_1 * iteration ** ((self.vcm.alpha - 1.0) / 2.0)

    def _light_pass(self, sample: int) -> None:
        """Trace sample ``sample``'s light paths, store them and build their merge grid."""
        t0 = time.perf_counter()
        r = self.radius(sample + 1)
        eta = math.pi * r * r * self.light_paths
        prm = self.param_block(sample, 1)
        if self._ordered is not None:     # the light pass appends to the keys themselves
            self._ordered.release()
            self._ordered = None
        self._camera_bindings = False
        self.bind()
        self.write_params(prm)
        block = self._block
        block["merge"] = (r, r * r, eta, 1.0 / eta)
        per_sample = self.light_paths / (self.width * self.height)
        block["lens"] = (per_sample, 1.0 / per_sample, 0.0, 0.0)
        splat = 1
        while True:
            self._grid_geometry(r)
            self._counters.clear()
            block["paths"] = (self.light_paths, self.vertex_capacity, self.merge_capacity, splat)
            self._vcm_params.write(block.tobytes())
            self.light_kernel.run(*groups_2d(self.light_paths))
            counts = np.frombuffer(self._counters.read(), np.uint32)
            vertices, merges = int(counts[0]), int(counts[1])
            if vertices <= self.vertex_capacity and merges <= self.merge_capacity:
                break
            # the lens connections are splatted already: the retrace only stores
            self.counters["retraced"] += 1
            splat = 0
            self._allocate(max(vertices + vertices // 4, self.vertex_capacity),
                           max(merges + merges // 4, self.merge_capacity))
            self.bind()
        self.counters["vertices"] += vertices
        self.counters["merge_points"] += merges
        if self.vcm.cache_connections:
            self._build_cache()
        t1 = time.perf_counter()
        self.light_seconds += t1 - t0
        self._camera_bindings = True
        self._build_grid(merges)
        self.grid_seconds += time.perf_counter() - t1
        self.bind()

    def _build_cache(self) -> None:
        """The light vertex cache of the camera pass: the slot of every stored light vertex
        past the light, light path by light path in index order (so the entry a camera
        vertex draws does not depend on the order the light pass's atomics stored them in),
        and its entry count into the parameter block."""
        paths = np.frombuffer(self._paths.read(vl.PATH_BYTES * self.light_paths), np.uint32)
        first = paths[0::2].astype(np.int64)
        count = np.maximum(paths[1::2].astype(np.int64) - 1, 0)
        entries = int(count.sum())
        ends = np.cumsum(count)
        slots = (np.repeat(first + 1 - (ends - count), count) + np.arange(entries)).astype(np.uint32)
        size = max(16, vl.CACHE_ENTRY_BYTES * entries)
        if self._cache is None or self._cache_bytes < size:
            if self._cache is not None:
                self._cache.release()
            self._cache_bytes = size + size // 4
            self._cache = self.gl.buffer(reserve=self._cache_bytes)
        if entries:
            self._cache.write(slots.tobytes())
        self._block["cache"] = (entries, 0, 0, 0)
        self._vcm_params.write(self._block.tobytes())

    def _grid_geometry(self, r: float) -> None:
        """The merge grid of radius r into the parameter block, before the light pass hashes
        its merge points into it: cells of edge 2r (with the slack of the photon grids, so a
        float32 lookup near a cell boundary finds what it should) counted from a corner
        outside the scene's bounding sphere and unbounded (merge points in a medium around
        the scene lie anywhere), a hash table of one entry per merge point of capacity."""
        center, radius = self.packed.sphere_bounds
        cell = 2.0 * r * (1.0 + GRID_SLACK)
        lo = np.asarray(center, np.float64) - radius - cell
        self._block["grid_size"] = (0, 0, 0, self.merge_capacity)
        self._block["grid_lo"] = (*lo, cell)

    def _build_grid(self, merges: int) -> None:
        """The merge points in the grid's order: by cell hash, and within a hash by key
        (light path, vertex): the device appends them in any order, the grid and the sums
        over it do not depend on it. The light pass hashed them (vcm_merge_sort); here two
        stable integer sorts and the offsets per hash, and kernels/vcm_order.comp.glsl
        copies the positions in that order."""
        block = self._block
        if merges == 0:
            block["grid_size"][3] = 0
            self._vcm_params.write(block.tobytes())
            return
        pairs = np.frombuffer(self._sort.read(8 * merges), np.uint32).reshape(merges, 2)
        by_key = stable_argsort_u32(pairs[:, 0])
        order = by_key[stable_argsort_u32(pairs[by_key, 1])].astype(np.uint32)
        table = int(block["grid_size"][3])
        offsets = np.zeros(table + 1, np.uint32)
        np.cumsum(np.bincount(pairs[:, 1], minlength=table), out=offsets[1:])
        for buf in (self._grid, self._ordered):
            if buf is not None:
                buf.release()
        self._ordered = self.gl.buffer(reserve=vl.MERGE_KEY_BYTES * merges)
        order_buf = self.gl.buffer(order.tobytes())
        self._keys.bind_to_storage_buffer(bindings.SSBO_VCM_MERGE_KEYS)
        order_buf.bind_to_storage_buffer(bindings.SSBO_VCM_GRID)
        self._ordered.bind_to_storage_buffer(bindings.SSBO_VCM_MERGE_SORT)
        self.order_kernel.run(*groups_2d(merges))
        order_buf.release()
        self._grid = self.gl.buffer(offsets.tobytes())
        self.bind()

    def _run_pass(self, first_sample: int, samples: int,
                  should_stop: Callable[[], bool] | None = None) -> bool:
        """bpt: the render kernel's pass. Otherwise one iteration per sample: its light
        pass, then the camera pass, whole (a stop is answered between iterations: the light
        pass's splats are on the film already)."""
        if not self.vcm.merges:
            return super()._run_pass(first_sample, samples, should_stop)
        for k in range(samples):
            self.prepare_pass(first_sample + k, 1)
            super()._run_pass(first_sample + k, 1, None)
        return True

    def prepare_pass(self, first_sample: int, samples: int) -> None:
        """The light pass and merge grid of iteration ``first_sample`` + 1 (a pass is one
        iteration: ``samples_per_pass`` is 1)."""
        if self.vcm.merges:
            if samples != 1:
                raise UsageError(f"vcm: a pass renders one iteration, not {samples} samples")
            self._light_pass(first_sample)

    # -- outputs -----------------------------------------------------------------------------
    @current
    def merge_strategy_images(self) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] | None:
        """{(q, t): (weighted, unweighted)} images of the merges (q light subpath segments,
        t camera subpath vertices) of path lengths 2 .. ``strategy_depth``
        (glrender/render/strategies.py): with :meth:`strategy_images`' connections, the
        weighted ones add up to ``film().mean`` when the depth is the render's max depth.
        None in bpt mode (no merges)."""
        if not self.vcm.merges:
            return None
        if not self.settings.strategy_depth:
            raise UsageError("merge_strategy_images: render with strategy_depth >= 1")
        return strategies.read_merges(self.accumulation.strategy_words(), self.settings.strategy_depth,
                                      self.width, self.height, self.spp_done)

    @current
    def merge_counters(self) -> dict[str, int]:
        """Merge candidates since the start: ``skipped`` by the per-vertex bound and
        ``visited`` (the last iteration's), with the light passes' stored vertices and merge
        points summed over the iterations and the light passes traced again."""
        out = dict(self.counters)
        if self.light_kernel is not None:
            c = np.frombuffer(self._counters.read(), np.uint32)
            out.update(skipped=int(c[2]), visited=int(c[3]))
        return out

    def stats(self) -> dict[str, Any]:
        """``--stats`` entries: vcm's mode, radii, stored vertices and merge points, the
        seconds of light passes and grid builds; merges make the estimate biased."""
        done = max(self.spp_done, 1)
        info: dict[str, Any] = {"mode": self.vcm.mode, "alpha": self.vcm.alpha}
        if self.vcm.merges:
            info.update(initial_radius=self.radius_1, final_radius=self.radius(done),
                        light_paths=self.light_paths, counters=self.merge_counters(),
                        bytes_per_vertex=self._vertex_bytes, bytes_per_merge_point=vl.MERGE_BYTES,
                        light_pass_seconds=self.light_seconds, grid_seconds=self.grid_seconds)
        return {"vcm": info, "biased": self.vcm.merges}

    def fingerprint_parts(self) -> dict[str, str]:
        from ..render.driver import part_digests
        return {**super().fingerprint_parts(), **part_digests(self._vcm_inputs())}

    def fingerprint(self) -> str:
        import hashlib
        h = hashlib.sha256(super().fingerprint().encode())
        for _, data in self._vcm_inputs():
            h.update(data)
        return h.hexdigest()

    def _vcm_inputs(self) -> list[tuple[str, bytes]]:
        v = self.vcm
        key = ("vcm", v.mode, v.initial_radius, v.alpha, v.light_paths)
        if v.cache_connections:   # as before the cache for renders without it
            key += (v.cache_connections,)
        return [("vcm settings", repr(key).encode())]

    @current
    def release(self) -> None:
        if getattr(self, "light_kernel", None) is not None:
            for buf in (self._vcm_params, self._paths, self._counters, self._vertices, self._keys,
                        self._data, self._sort, self._grid, self._ordered, self._cache):
                if buf is not None:
                    buf.release()
            self.light_kernel = None
        super().release()
