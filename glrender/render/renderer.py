"""Progressive rendering on the device: compile the kernel, dispatch it in chunks.

The scene's device data is a shared :class:`~glrender.gpu.device_scene.DeviceScene`; the
per-pixel sums live in an :class:`~glrender.render.accumulation.Accumulation`. What stays
here is the kernel (its defines and slots), the parameter block and the dispatch policy.

A *pass* renders ``samples_per_pass`` samples in every pixel; a pass is split into
dispatches of whole 8x8 tiles, as many per dispatch as fit the time target
(measured as the render goes), so progress, previews and Ctrl-C stay responsive.
Each pixel accumulates its samples as exact 128-bit fixed-point sums of the values and
their squares on the device (shaders/film/accum.glsl, glrender/render/accum.py): integer
sums do not depend on how the samples are grouped, so the result is bitwise the same
however the passes and dispatches are split, and sample ranges rendered apart add up to
the same bits, for a given scene, seed, spp and device. Every invocation runs
a few samples only, far below llvmpipe's silent ~65,535-iteration loop cap.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterator, cast

import numpy as np

from .. import integrators
from ..errors import UsageError
from ..gl import shaders
from ..gl.context import Context, current, default_context
from ..gpu import bindings, codegen, layout
from ..gpu.device_scene import DeviceScene
from ..gpu.pack import PackedScene
from ..sampling.sequences import strata_columns
from ..scene import model as m
from ..film import Film
from . import strategies, wavefront
from .accumulation import SPLAT_SCALE, Accumulation
from .driver import part_digests
from .params import choose_light_selection, shader_defines

#: RenderSettings.executor: the render kernel, or the wavefront stages (path tracer)
EXECUTORS = ("megakernel", "wavefront")
BDPT_DEPTH_CAP = cast(int, integrators.get("bdpt").depth_cap)   # kBdptDepthCap (integrators/bdpt_vertex.glsl)


@dataclass
class RenderSettings:
    """Everything that decides an image besides the scene's geometry and materials."""

    integrator: m.Integrator
    sampler: m.Sampler
    aovs: bool = False
    count_loops: bool = False
    count_rays: bool = False              # count the rays traced per pixel (Renderer.rays)
    debug_nonfinite: int = 0              # tests: make sample index % 7 == value - 1 NaN
    samples_per_pass: int | None = None   # None: chosen from the scene
    time_target: float = 0.1              # seconds per dispatch
    clamp: float | None = None            # a sample's largest RGB component is scaled down to
                                          # this (biased: off by default)
    emission_only: bool = False           # path tracer: the emission the camera sees, alone
                                          # (directly and through delta surfaces: the
                                          # emission AOV; glrender.denoise renders it apart)
    strategy_depth: int = 0               # bdpt: keep each strategy's image up to this path
                                          # length (glrender/render/strategies.py; 0: none)
    executor: str = "megakernel"          # how the path tracer runs: one render kernel, or
                                          # stages over binned queues (glrender/render/wavefront.py)

    def __post_init__(self) -> None:
        if self.executor not in EXECUTORS:
            raise UsageError(f"executor: expected one of {', '.join(EXECUTORS)}, "
                             f"got {self.executor!r}")
        if self.executor == "wavefront":
            why = wavefront.supports(self.integrator.kind, self.integrator.split,
                                     self.integrator.light_samples, self.integrator.light_selection)
            if why is not None:
                raise UsageError(f"executor: {why}")


def settings_from_scene(scene: m.Scene, *, integrator: str | None = None, spp: int | None = None,
                        sampler: str | None = None, seed: int | None = None,
                        max_depth: int | None = None, rr_depth: int | None = None,
                        rr: str | None = None, light_samples: int | None = None,
                        split: int | None = None,
                        strategy: str | None = None, light_selection: str | None = None,
                        area_sampling: str | None = None, hide_emitters: bool | None = None,
                        aovs: bool = False, count_loops: bool = False, count_rays: bool = False,
                        samples_per_pass: int | None = None, time_target: float = 0.1,
                        clamp: float | None = None, emission_only: bool = False,
                        strategy_depth: int = 0, executor: str = "megakernel") -> RenderSettings:
    """The scene's settings with the given overrides (None keeps the scene's value).
    ``clamp``: scale each camera sample whose largest RGB component exceeds it down to
    it (removes fireflies at the price of bias; None: off). ``emission_only`` (path
    tracer): the image is the emission the camera sees, directly or through mirrors,
    glass and null surfaces (the ``emission`` AOV's quantity): paths end at the first
    surface that is not a delta one, without next-event estimation. ``strategy_depth``:
    bdpt keeps the image of every strategy (s, t) of path lengths up to it (0: off)."""
    integ = scene.integrator
    overrides: dict[str, Any] = {k: v for k, v in dict(kind=integrator, max_depth=max_depth, rr_depth=rr_depth,
                                       rr=rr, light_samples=light_samples, split=split,
                                       strategy=strategy, light_selection=light_selection,
                                       area_sampling=area_sampling,
                                       hide_emitters=hide_emitters).items() if v is not None}
    integ = replace(integ, **overrides)  # re-validates in __post_init__
    samp_overrides: dict[str, Any] = {k: v for k, v in dict(kind=sampler, spp=spp, seed=seed).items()
                                      if v is not None}
    samp = replace(scene.sampler, **samp_overrides)
    if samp.spp < 1:
        raise UsageError(f"spp: expected a positive integer, got {samp.spp}")
    if clamp is not None and not (isinstance(clamp, (int, float)) and math.isfinite(clamp)
                                  and clamp > 0):
        raise UsageError(f"clamp: expected a positive number (the largest RGB component a "
                         f"sample keeps), got {clamp!r}")
    if emission_only and not integrators.get(integ.kind).seen_emission_pass:
        passes = [n for n in integrators.names() if integrators.get(n).seen_emission_pass]
        raise UsageError(f"emission_only: only with the {', '.join(passes)} integrator, not "
                         f"{integ.kind}")
    if count_loops and count_rays:
        raise UsageError("count_loops and count_rays share one debug counter: ask for one")
    return RenderSettings(integ, samp, aovs=aovs, count_loops=count_loops, count_rays=count_rays,
                          samples_per_pass=samples_per_pass, time_target=time_target,
                          clamp=None if clamp is None else float(clamp),
                          emission_only=bool(emission_only),
                          strategy_depth=int(strategy_depth), executor=executor)


def _half_extents(half: float, fov_axis: str, width: int, height: int) -> tuple[float, float]:
    """Half the film's extent along x and y from ``half`` along ``fov_axis`` (Mitsuba's
    rules: the other axis follows the film's aspect ratio)."""
    axis = fov_axis
    if axis == "smaller":
        axis = "x" if width <= height else "y"
    elif axis == "larger":
        axis = "x" if width >= height else "y"
    if axis == "x":
        return half, half * height / width
    if axis == "y":
        return half * width / height, half
    diag = math.hypot(width, height)
    return half * width / diag, half * height / diag


def camera_tangents(camera: m.Camera, width: int, height: int) -> tuple[float, float]:
    """tan of the half field of view along x and y (Mitsuba's fov_axis rules) of a
    perspective camera."""
    return _half_extents(math.tan(math.radians(camera.fov) / 2), camera.fov_axis, width, height)


def camera_screen(camera: m.Camera, width: int, height: int) -> tuple[float, float]:
    """Half the film's extent along camera x and y: on the plane z = 1 for a perspective
    camera (the tangents of the half angles), in camera-space units for an orthographic one."""
    if camera.orthographic:
        return _half_extents(camera.half_extent, camera.fov_axis, width, height)
    return camera_tangents(camera, width, height)


def check_camera(camera: m.Camera, integrator: str) -> None:
    """Refuses a camera the integrator cannot render through: an integrator whose image is
    made of connections to the lens (lighttrace) needs a lens that a point of the scene can
    see, which an orthographic camera (one direction for every ray) does not have."""
    if camera.orthographic and integrators.get(integrator).needs_lens:
        able = ", ".join(n for n in integrators.names() if not integrators.get(n).needs_lens)
        raise UsageError(f"camera: an orthographic camera cannot be rendered by {integrator}, whose "
                         f"light paths connect to a lens point (every orthographic ray has one "
                         f"direction); use {able}")


class Renderer:
    """A scene on the device, ready to accumulate samples progressively.

    ``step(spp)`` adds samples to every pixel; ``film()`` reads the image back.
    ``share=other``: render the same scene with other settings on ``other``'s context,
    reusing its packed scene, BVH, triangle data and textures instead of building them
    again (they stay on the device until the last renderer using them is released).
    """

    #: the driver name (glrender.integrators) of the integrators this class runs
    driver = "kernel"

    def __init__(self, scene: m.Scene, settings: RenderSettings | None = None, *,
                 ctx: Context | None = None, device: str | int | None = None,
                 share: Renderer | None = None, media_for: str | None = None,
                 **overrides: Any) -> None:
        # the integrator whose support for participating media the kernels answer for (None:
        # the settings' own; SPPM's inner renderer compiles ao's kernel for its own kernels)
        self._media_for = media_for
        if settings is not None and overrides:
            raise UsageError(f"Renderer: give either settings or overrides "
                             f"({', '.join(sorted(overrides))}), not both")
        self.scene = scene
        self.settings = settings or settings_from_scene(scene, **overrides)
        check_camera(scene.camera, self.settings.integrator.kind)
        if share is not None:
            share = getattr(share, "base", share)     # SPPM's renderer holds the scene in .base
            shared_ctx: Context = share.ctx
            if share.scene is not scene or (ctx is not None and ctx is not shared_ctx):
                raise UsageError("Renderer(share=...): the renderer shared from must render the "
                                 "same scene object on the same context")
            ctx = shared_ctx
        self.ctx: Context = ctx or default_context(device)
        self.ctx.make_current()
        self.gl = self.ctx.gl
        # what depends on the scene alone (the packed arrays, the BVH, the triangle data,
        # textures, the environment image) is made once and shared by the drivers of other
        # settings on the same context (share=: the noise pilot, the seen-emission pass)
        t_pack = time.perf_counter()
        self.device_scene: DeviceScene | None
        if share is None:
            self.device_scene = DeviceScene(self.ctx, scene)
            pack = self.device_scene.timings["pack"]
        elif share.device_scene is None:
            raise UsageError("Renderer(share=...): the renderer shared from was released")
        else:
            self.device_scene = share.device_scene.acquire()
            pack = time.perf_counter() - t_pack      # about 0: the scene data is shared
        self.packed: PackedScene = self.device_scene.packed
        integ = self.settings.integrator
        chosen = choose_light_selection(integ.light_selection, len(self.packed.lights))
        if chosen != integ.light_selection:
            self.settings = replace(self.settings, integrator=replace(integ, light_selection=chosen))
        self.width, self.height = scene.film.width, scene.film.height
        s = self.settings
        self.accumulation = Accumulation(
            self.gl, self.width, self.height, aovs=s.aovs,
            counting=s.count_loops or s.count_rays, splatting=self.splatting,
            strategy_depth=s.strategy_depth, binding_limit=lambda: self.binding_limit(),
            strategy_merges=self._strategy_merges())
        self.tiles_x, self.tiles_y = self.accumulation.tiles_x, self.accumulation.tiles_y
        self.spp_done = 0
        self._tile_rate: float | None = None    # measured seconds per tile-sample
        self._buffers: list[Any] = []
        self._upload()
        t1 = time.perf_counter()
        self._compile()
        self.reset()
        self._warm_up()
        # seconds spent packing the scene into arrays ("pack"), packing and uploading it
        # ("build": pack_scene, the BVH build and the uploads) and compiling the kernel
        # ("compile": llvmpipe's JIT at the first dispatch included)
        self.timings = {"pack": pack, "build": t1 - t_pack, "compile": time.perf_counter() - t1}

    @property
    def splatting(self) -> bool:
        """Whether the integrator splats light paths onto the whole film."""
        return integrators.get(self.settings.integrator.kind).splatting

    @property
    def texture_bytes(self) -> int:
        """Bytes of the scene's texture atlas pages (RGBA16F) on the device."""
        return self.device_scene.texture_bytes if self.device_scene is not None else 0

    @property
    def bvh_cache(self) -> str:
        """Where the scene's BVH came from: "hit" (the mesh cache), "miss" (built and
        stored), "uncached" (built: a small mesh or the cache off) or "none" (no BVH)."""
        return self.device_scene.bvh_cache if self.device_scene is not None else "none"

    @property
    def mesh_capacity(self) -> dict[str, Any] | None:
        """The BVH triangles' device bytes per triangle and the most that fit
        (DeviceScene.mesh_capacity); None without BVH triangles."""
        return self.device_scene.mesh_capacity() if self.device_scene is not None else None

    # -- setup -------------------------------------------------------------------------------
    def _upload(self) -> None:
        """The settings' light table (selection pmf, alias table, spherical-rectangle flags,
        distributions), the materials and the parameter block; the scene's own data is
        the device scene's."""
        assert self.device_scene is not None, "the renderer was released"
        integ = self.settings.integrator
        table = self.device_scene.light_table(integ.light_selection, integ.area_sampling)
        self.lights_final = table.lights
        self.n_lights = len(table.lights)
        self._materials = self._buffer(self.packed.materials.tobytes())
        self._lights = self._buffer(table.lights.tobytes() if self.n_lights
                                    else layout.zeros(layout.LIGHT).tobytes())
        self._dist = self._buffer(table.distributions.tobytes())
        self._params = self.gl.buffer(reserve=layout.RENDER_PARAMS.itemsize)
        media = self.packed.media
        self._media = self._buffer(media.tobytes()) if media is not None else None

    def _buffer(self, data: bytes) -> Any:
        buf = self.gl.buffer(data if len(data) else b"\0" * 16)
        self._buffers.append(buf)
        return buf

    def _compile(self) -> None:
        s = self.settings
        integ = s.integrator
        p = self.packed
        spec = integrators.get(integ.kind)
        if spec.driver != self.driver or spec.glsl is None:
            raise UsageError(f"integrator {integ.kind!r} has its own driver, not "
                             f"{type(self).__name__}: use glrender.drivers.create_driver (or "
                             f"glrender render --integrator {integ.kind}); {type(self).__name__} "
                             f"takes {', '.join(integrators.running_on(self.driver))}")
        geometry = codegen.generate(p, has_bvh=p.has_bvh, lights=self.lights_final)
        library = shaders.ShaderLibrary().with_generated({codegen.GENERATED_PATH: geometry})
        self.defines = shader_defines(
            sampler=s.sampler.kind, material_kinds=p.material_kinds, light_kinds=p.light_kinds,
            max_depth=integ.max_depth, rr_depth=integ.rr_depth, rr=integ.rr,
            light_samples=integ.light_samples if spec.splitting else 1,
            split=integ.split if spec.splitting else 1, strategy=integ.strategy,
            emitter_samples=integ.emitter_samples, bsdf_samples=integ.bsdf_samples,
            hide_emitters=integ.hide_emitters, light_selection=integ.light_selection,
            area_sampling=integ.area_sampling, filter=self.scene.film.filter, aovs=s.aovs,
            count_loops=s.count_loops, count_rays=s.count_rays, debug_nonfinite=s.debug_nonfinite,
            emission_only=s.emission_only)
        assert self.device_scene is not None, "the renderer was released"
        self.defines.update(self.device_scene.defines())   # geometry past one buffer texture
        if p.has_bvh and codegen.has_alpha_cutouts(p):
            self.defines["GLRENDER_ALPHA_CUTOUTS"] = 1     # geometry/bvh.glsl asks the scene
        if codegen.has_normal_shadowing(p):
            self.defines["GLRENDER_NORMAL_SHADOWING"] = 1  # bsdf/bsdf.glsl bsdf_normal_shadowing
        if codegen.has_metallic_roughness(p):
            self.defines["GLRENDER_METALLIC_ROUGHNESS"] = 1  # bsdf/metallic_roughness.glsl
        if codegen.has_emission_textures(p):
            self.defines["GLRENDER_EMISSION_TEXTURES"] = 1   # lights/light.glsl area_light_radiance
        if p.instanced_meshes and s.executor == "wavefront":
            # the extend stage stores a triangle per path, not the instance it belongs to
            raise UsageError(f"{self.scene.source}: the wavefront executor does not trace "
                             f"instanced meshes (two-level BVH); use --executor megakernel")
        if p.has_media:
            takers = [n for n in integrators.names() if integrators.get(n).media]
            kind = self._media_for or integ.kind
            if not integrators.get(kind).media or s.executor != "megakernel" \
                    or integ.light_samples != 1 or integ.split != 1:
                raise UsageError(f"{self.scene.source}: participating media are rendered by "
                                 f"--integrator {', '.join(takers[:-1])} or {takers[-1]} (the "
                                 f"megakernel, one light sample and one branch a vertex) so far, "
                                 f"not {kind}")
            self.defines["GLRENDER_MEDIA"] = 1   # media/medium.glsl, integrators/path.glsl
        if s.strategy_depth:
            self._check_strategy_images()
            self.defines["GLRENDER_STRATEGY_DEPTH"] = s.strategy_depth
        self.defines.update(self._integrator_defines())
        glsl = self._integrator_glsl(spec)
        self._source_fingerprint = (geometry, sorted(self.defines.items()), glsl)
        slots = {"integrator": glsl, "scene": codegen.GENERATED_PATH}
        # what the kernels of a driver beside the render kernel compile against
        self.library, self.slots = library, slots
        self.program: Any = shaders.compile_compute(
            self.ctx, "kernels/render.comp.glsl", defines=self.defines, slots=slots,
            library=library)
        self.wavefront: wavefront.Wavefront | None = None
        if s.executor == "wavefront":   # RenderSettings checked that it runs these settings
            self.wavefront = wavefront.Wavefront(self.ctx, self.defines, slots, library,
                                                 self.binding_limit())
        if s.samples_per_pass is not None:
            self.samples_per_pass = max(1, int(s.samples_per_pass))
        elif spec.strategies and not 0 < integ.max_depth <= 8:
            # a bdpt sample traces two subpaths and up to ~(max_depth + 1)^2 / 2 connections:
            # beyond depth 8 (up to its cap of 16), 2 per invocation keep the loop count far
            # below llvmpipe's cap (tests/render/test_bdpt.py checks the worst scenes)
            self.samples_per_pass = 2
        else:
            # samples per invocation and pass: measured loop counts stay in the hundreds per
            # sample (tests/render/test_determinism.py checks the worst scenes), far below
            # llvmpipe's cap; more samples per dispatch amortise its fixed cost and give path
            # regeneration more to fill idle lanes with (8 measured best with and without a BVH).
            # Splitting multiplies a sample's work: fewer samples per invocation keep the
            # product bounded (tests/render/test_splitting.py checks the largest settings).
            work = integ.split * integ.light_samples if spec.splitting else 1
            self.samples_per_pass = max(1, 8 // work)

    def _integrator_glsl(self, spec: integrators.IntegratorSpec) -> str:
        """The GLSL file that defines the camera kernel's integrator_pixel (the
        integrator's own; vcm's bpt mode takes bdpt's)."""
        assert spec.glsl is not None
        return spec.glsl

    def _strategy_merges(self) -> bool:
        """Whether the strategy images include merges (vcm's)."""
        return False

    def _integrator_defines(self) -> dict[str, int]:
        """Optional defines of the driver's own (glrender.render.params OPTIONAL_DEFINES)."""
        return {}

    def _check_strategy_images(self) -> None:
        s = self.settings
        if not integrators.get(s.integrator.kind).strategies:
            raise UsageError(f"strategy images: only bdpt and vcm have strategies (s, t), "
                             f"not {s.integrator.kind}")
        strategies.check_depth(s.strategy_depth, s.integrator.max_depth, BDPT_DEPTH_CAP)
        need, limit = strategies.buffer_bytes(s.strategy_depth, self.width, self.height,
                                              self._strategy_merges()), \
            self.binding_limit()
        if need > limit:
            raise UsageError(f"strategy images of depth {s.strategy_depth} at {self.width}x"
                             f"{self.height} need {need / 2**20:.0f} MiB, more than this device's "
                             f"{limit / 2**20:.0f} MiB storage buffer: lower --strategy-depth or "
                             f"--width/--height")

    @current
    def strategy_images(self) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
        """{(s, t): (weighted, unweighted)} images, (H, W, 3) float64, of every bdpt
        strategy of path lengths 1 .. ``strategy_depth`` (glrender/render/strategies.py):
        the weighted ones of all lengths add up to ``film().mean`` when the depth is the
        render's max depth."""
        if not self.settings.strategy_depth:
            raise UsageError("strategy_images: render with strategy_depth >= 1 (bdpt)")
        return strategies.read(self.accumulation.strategy_words(), self.settings.strategy_depth,
                               self.width, self.height, self.spp_done, SPLAT_SCALE)

    def stats(self) -> dict[str, Any]:
        """The integrator's own ``--stats`` entries: none for the render kernel's."""
        return {}

    def fingerprint(self) -> str:
        """A hash of everything that decides the value of each sample: the kernel's source
        and defines, the scene data on the device, camera and film, sampler and seed.
        Accumulation states (checkpoints) can only be merged or resumed between equal ones."""
        import hashlib

        h = hashlib.sha256()
        for _, data in self._fingerprint_inputs():
            h.update(data)
        return h.hexdigest()

    def fingerprint_parts(self) -> dict[str, str]:
        """The fingerprint's inputs hashed part by part ({"geometry": digest, ...}): a
        checkpoint records them so that a refusal can say which part differs."""
        # the kernel's source holds a small scene's code, made from its primitives and
        # (already a part each) its materials and lights: the primitives stand for it
        _, defines, glsl = self._source_fingerprint
        p = self.packed
        source = [("kernel", repr((defines, glsl)).encode()),
                  ("geometry", repr((p.quads, p.spheres, p.moving_meshes)).encode())]
        return part_digests([*source, *list(self._fingerprint_inputs())[1:]])

    def _fingerprint_inputs(self) -> Iterator[tuple[str, bytes]]:
        """(part, bytes) of everything the fingerprint hashes, in its order (the first: the
        kernel's source, a small scene's geometry code included)."""
        yield "kernel", repr(self._source_fingerprint).encode()
        yield "materials", np.ascontiguousarray(self.packed.materials).tobytes()
        yield "lights", np.ascontiguousarray(self.lights_final).tobytes()
        if self.packed.media is not None:
            yield "media", self.packed.media.tobytes()
        if self.packed.media_grids is not None:
            yield "media grids", self.packed.media_grids.tobytes()
        if self.device_scene is not None and self.device_scene.bvh is not None:
            # the BVH triangles as the device reads them: the same whether packed now or
            # read from the mesh cache (gpu/mesh_cache.py), which keeps no packed soup
            device = self.device_scene
            packed = device.bvh.bvh.pack()
            for arr in (packed["triangles"], *device.mesh_texels):
                yield "geometry", np.ascontiguousarray(arr).tobytes()
            if len(packed["instances"]) > 1:
                # the instances' transforms (motion and static); a scene without any keeps
                # the fingerprint it had before instances were hashed
                yield "geometry", np.ascontiguousarray(packed["instances"]).tobytes()
        if self.packed.env_image is not None:
            yield "environment map", np.ascontiguousarray(self.packed.env_image).tobytes()
        yield "textures", self.packed.textures.fingerprint()
        prm = self.param_block(0, 0)
        prm["image"][3], prm["counts"][3] = self.tiles_y, 0   # a band renders the same samples
        if self.settings.sampler.kind != "stratified":
            prm["samples"][2:] = 0   # the total spp decides the strata only: other samplers
                                     # may continue past it (render more samples later)
        yield "camera, film and sampler", prm.tobytes()

    @current
    def state(self) -> dict[str, Any]:
        """The accumulation so far (numpy arrays and the sample count): what a checkpoint
        saves. ``restore(state)`` on a renderer with the same fingerprint continues it, and
        the final image is bitwise the same as an uninterrupted render. The arrays are the
        exact sums of glrender.render.accum (uint32 words): those of disjoint sample
        ranges add up (accum.add) to the bits of one render of all of them."""
        return {"fingerprint": self.fingerprint(), "spp_done": self.spp_done,
                "spp_start": self.spp_start, **self.accumulation.state(),
                "width": self.width, "height": self.height, "rows": self.rows}

    @current
    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state()`` of an equal renderer (same fingerprint)."""
        if state.get("fingerprint") != self.fingerprint():
            raise UsageError("the saved accumulation belongs to a different scene or different "
                             "render settings (fingerprints differ)")
        rows = tuple(state.get("rows", (0, self.tiles_y)))
        if rows != self.rows:
            raise UsageError(f"the saved accumulation holds tile rows {rows}, this renderer "
                             f"{self.rows} (reset(rows=...) first)")
        self.accumulation.restore(state)
        self.spp_done = int(state["spp_done"])
        self.spp_start = int(state.get("spp_start", 0))

    def _warm_up(self) -> None:
        """llvmpipe compiles a kernel at its first dispatch (seconds for a cold cache):
        run one empty work group now, so setup time is not charged to the render."""
        prm = self.param_block(0, 0)
        self.bind()
        self.write_params(prm)  # dispatch.y = 0: every invocation returns at once
        self.program.run(group_x=1)
        self.gl.finish()

    @property
    def rows(self) -> tuple[int, int]:
        """The tile rows accumulated: (first, count)."""
        return self.accumulation.rows

    @property
    def band_height(self) -> int:
        """Pixel rows in the accumulation (the image's height unless ``rows`` is a band)."""
        return self.accumulation.band_height

    @current
    def reset(self, start: int = 0, rows: tuple[int, int] | None = None) -> None:
        """Forget every sample (after the camera moves, say).

        ``start``: the sample index the next pass renders, for a range of samples
        rendered here and merged with other ranges elsewhere (glrender.distributed).
        ``rows``: ``(first, count)`` tile rows (of 8 pixel rows) to accumulate; the
        rest of the image is not rendered and not stored (None: the whole image).
        The samples of a pixel do not depend on either."""
        first, count = rows if rows is not None else (0, self.tiles_y)
        if not (0 <= first < self.tiles_y and 1 <= count <= self.tiles_y - first):
            raise UsageError(f"rows {rows}: expected (first, count) tile rows within the image's "
                             f"{self.tiles_y}")
        if not 0 <= start < 1 << 31:
            raise UsageError(f"start: expected a sample index in [0, 2^31), got {start}")
        self.accumulation.allocate((first, count))
        self.spp_done = self.spp_start = int(start)

    @current
    def set_camera(self, camera: m.Camera) -> None:
        """Move the camera (or change its lens) and forget the samples so far.

        The scene's geometry, BVH, materials and kernel stay on the device: only the
        per-pass parameter block changes, so this costs no rebuild. The image size is the
        scene's film and cannot change here."""
        if not isinstance(camera, m.Camera):
            raise UsageError(f"set_camera: expected a glrender Camera, got {type(camera).__name__}")
        check_camera(camera, self.settings.integrator.kind)
        self.scene.camera = camera
        self.reset()

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    # -- rendering ---------------------------------------------------------------------------
    def param_block(self, first_sample: int, samples: int) -> Any:
        """The parameter block (layout.RENDER_PARAMS) of a pass rendering samples
        [first_sample, first_sample + samples); the dispatch's tiles are set per dispatch
        (``dispatch.xy``) before :meth:`write_params`."""
        scene, s = self.scene, self.settings
        cam, film = scene.camera, scene.film
        prm = np.zeros(1, layout.RENDER_PARAMS)[0]
        prm["camera_open"] = cam.world_from_camera.T
        close = cam.world_from_camera_close if cam.world_from_camera_close is not None \
            else cam.world_from_camera
        prm["camera_close"] = close.T
        sx, sy = camera_screen(cam, self.width, self.height)
        prm["camera_screen"] = (sx, sy, cam.aperture_radius, cam.focus_distance)
        prm["camera_clip"][:2] = (cam.near_clip, cam.far_clip)
        prm["camera_projection"] = layout.CAMERA_PROJECTIONS[cam.kind]
        sh = scene.shutter
        prm["shutter"][:3] = (sh.open, sh.close, 1.0 if sh.function == "tent" else 0.0)
        prm["filter_params"] = (film.radius, film.gaussian_stddev, film.mitchell_b, film.mitchell_c)
        prm["image"] = (self.width, self.height, self.tiles_x, self.rows[1])
        spp_total = s.sampler.spp
        prm["samples"] = (first_sample, samples, spp_total, strata_columns(spp_total))
        seed = int(s.sampler.seed) & 0xFFFFFFFF
        prm["dispatch"] = (0, 0, seed, (seed * 2654435761 + 12345) & 0xFFFFFFFF)
        prm["counts"] = (self.n_lights, len(self.packed.materials), self.packed.environment,
                         self.rows[0])
        center, radius = self.packed.sphere_bounds
        prm["scene_sphere"] = (*center, radius)
        prm["ao_distance"] = min(s.integrator.ao_distance, 3.0e38)
        prm["sample_clamp"] = s.clamp if s.clamp is not None else 0.0
        return prm

    def write_params(self, prm: Any) -> None:
        """Upload a parameter block (from :meth:`param_block`) for the next dispatch."""
        self._params.write(prm.tobytes())

    def bind(self) -> None:
        """Bind the scene, the settings' light table, the accumulation and the parameter
        block to their slots: what a kernel of this scene reads (the render kernel, and the
        photon kernels that compile against the same defines)."""
        self.accumulation.bind()
        self._materials.bind_to_storage_buffer(bindings.SSBO_MATERIALS)
        self._lights.bind_to_storage_buffer(bindings.SSBO_LIGHTS)
        self._dist.bind_to_storage_buffer(bindings.SSBO_DISTRIBUTIONS)
        self._params.bind_to_uniform_block(bindings.UBO_RENDER_PARAMS)
        if self._media is not None:
            self._media.bind_to_uniform_block(bindings.UBO_MEDIA)
        assert self.device_scene is not None, "the renderer was released"
        self.device_scene.bind()

    def bind_film(self) -> None:
        """Bind the accumulation alone (sums, squares, AOVs) to its slots, for a pass that
        reads it (the preview's display)."""
        self.accumulation.bind_film()

    @current
    def load_accumulation(self, sums: np.ndarray, squares: np.ndarray) -> None:
        """Replace the accumulation's sums and sums of squares (glrender.render.accum words)
        with an estimate made elsewhere, to show it through the same display path (SPPM's
        preview)."""
        self.accumulation.load(sums, squares)

    def prepare_pass(self, first_sample: int, samples: int) -> None:
        """What the kernel needs before the dispatches of a pass rendering samples
        [first_sample, first_sample + samples) (nothing here; vcm: its light pass and merge
        grid). The preview's frame-budgeted passes call it too."""

    def _run_pass(self, first_sample: int, samples: int,
                  should_stop: Callable[[], bool] | None = None) -> bool:
        """Render samples [first_sample, first_sample + samples) in every pixel.

        ``should_stop()`` is asked between dispatches; when it answers True the tiles done
        so far are undone (from a copy taken before the pass) and the pass returns False,
        so the accumulation always holds whole passes."""
        prm = self.param_block(first_sample, samples)
        if self.wavefront is not None:
            return self._run_pass_wavefront(prm, first_sample, samples, should_stop)
        total = self.tiles_x * self.rows[1]
        done = 0
        self.bind()
        slices = self.accumulation.slices()
        for first_row, n_rows in slices:
            if len(slices) > 1:
                self.accumulation.bind_slice(first_row, n_rows)
            prm["image"][3], prm["counts"][3] = n_rows, first_row
            tiles = self.tiles_x * n_rows
            start = 0
            while start < tiles:
                if self._tile_rate is None:
                    count = min(tiles, 16)
                else:
                    count = int(self.settings.time_target / max(self._tile_rate * samples, 1e-9))
                    count = max(1, min(tiles - start, count, 65535))
                count = min(count, tiles - start)
                if should_stop is not None:
                    if done == 0 and count < total:
                        self.accumulation.take_snapshot()
                    elif done > 0 and should_stop():
                        self.accumulation.restore_snapshot()
                        self.bind()
                        return False
                prm["dispatch"][0], prm["dispatch"][1] = start, count
                self.write_params(prm)
                t0 = time.perf_counter()
                self.program.run(group_x=count)
                self.gl.finish()
                elapsed = time.perf_counter() - t0
                rate = elapsed / (count * samples)
                self._tile_rate = rate if self._tile_rate is None else 0.7 * self._tile_rate + 0.3 * rate
                start += count
                done += count
        if len(slices) > 1:
            self.bind()
        return True

    def _run_pass_wavefront(self, prm: Any, first_sample: int, samples: int,
                            should_stop: Callable[[], bool] | None) -> bool:
        """_run_pass through the wavefront executor: the same samples and sums, in waves
        (a pass stopped between waves is undone as a pass stopped between dispatches)."""
        assert self.wavefront is not None
        self.bind()
        slices = self.accumulation.slices()
        waves = sum(math.ceil(self.tiles_x * n * 64 * samples / self.wavefront.capacity)
                    for _, n in slices)
        if should_stop is not None and waves > 1:
            self.accumulation.take_snapshot()
        for k, (first_row, n_rows) in enumerate(slices):
            if len(slices) > 1:
                self.accumulation.bind_slice(first_row, n_rows)
            prm["image"][3], prm["counts"][3] = n_rows, first_row
            prm["dispatch"][0], prm["dispatch"][1] = 0, self.tiles_x * n_rows
            self.write_params(prm)
            stop = should_stop if waves > 1 else None
            if (k and stop is not None and stop()) or \
                    not self.wavefront.render(first_sample, samples, self.tiles_x * n_rows, stop):
                self.accumulation.restore_snapshot()
                self.bind()
                return False
            self.gl.finish()
        if len(slices) > 1:
            self.bind()
        return True

    def slices(self) -> list[tuple[int, int]]:
        """The tile rows of a pass in slices that fit one storage-buffer binding
        (Accumulation.slices)."""
        return self.accumulation.slices()

    def device_bytes_per_pixel(self) -> int:
        """Bytes of device memory per accumulated pixel (Accumulation.device_bytes_per_pixel)."""
        return self.accumulation.device_bytes_per_pixel()

    def binding_limit(self) -> int:
        """Bytes one storage-buffer binding may hold on this device."""
        return int(self.gl.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"])

    @current
    def step(self, spp: int, callback: Callable[[int, int], None] | None = None,
             should_stop: Callable[[], bool] | None = None) -> int:
        """Add ``spp`` samples per pixel; ``callback(done, total)`` after every pass.

        ``should_stop()``, if given, is asked before every pass and between the dispatches
        of a pass (at most ~``time_target`` seconds apart): when it answers True, the pass
        in progress is undone and ``step`` returns early, the accumulation at a whole pass.
        Returns the samples per pixel added."""
        if spp < 0:
            raise UsageError(f"spp: expected a non-negative integer, got {spp}")
        first = self.spp_done
        target = self.spp_done + spp
        while self.spp_done < target:
            if should_stop is not None and should_stop():
                break
            k = min(self.samples_per_pass, target - self.spp_done)
            if not self._run_pass(self.spp_done, k, should_stop):
                break
            self.spp_done += k
            if callback is not None:
                callback(self.spp_done, target)
        return self.spp_done - first

    def image(self) -> Film:
        """The same as :meth:`film` (the accumulated image with its statistics)."""
        return self.film()

    @current
    def film(self) -> Film:
        """Read the accumulation back as a :class:`Film` (the band of ``rows`` only)."""
        return self.accumulation.film(self.spp_done, self._splat_paths(),
                                      self.settings.sampler.kind, self.settings.count_loops)

    def _splat_paths(self) -> int:
        """Light paths splatted since the band's start: one per camera sample of every
        pixel accumulated."""
        return max(self.spp_done - self.spp_start, 1) * self.width * self.band_height

    @current
    def debug_counters(self) -> np.ndarray:
        """The per-pixel debug counter of the band (settings with count_loops: the most loop
        iterations an invocation ran; count_rays: the rays traced), uint32 (H, W)."""
        return self.accumulation.debug_counters()

    @current
    def rays(self) -> int:
        """Rays traced since the last reset (camera, continuation and shadow rays, summed
        over the pixels; path integrator, settings with count_rays=True)."""
        if not self.settings.count_rays:
            raise UsageError("Renderer.rays: render with count_rays=True to count rays")
        return int(self.debug_counters().astype(np.int64).sum())

    @current
    def splat_image(self) -> np.ndarray:
        """The splatted part of the image (light tracing, BDPT's t = 1 strategies), (H, W, 3)
        float32: the fixed-point sums over the number of light paths, one per camera sample
        of every pixel accumulated (the band's, since ``reset``'s start). ``film()`` adds it
        to the camera-side mean; its variance is not in the film's M2 (error bars of
        splatted images come from independent renders)."""
        return self.accumulation.splat_image(self._splat_paths())

    @current
    def release(self) -> None:
        """Free the device buffers (the renderer cannot render afterwards); the scene's
        own data stays on the device while another renderer shares it."""
        for buf in self._buffers + [self._params]:
            buf.release()
        if self.wavefront is not None:
            self.wavefront.release()
            self.wavefront = None
        self.accumulation.release()
        self._buffers = []
        data, self.device_scene = self.device_scene, None
        if data is not None:
            data.release()
