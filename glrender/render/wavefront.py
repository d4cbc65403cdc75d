"""The wavefront executor of the path tracer: stages over binned queues of paths.

``shaders/kernels/wavefront.comp.glsl`` holds the stages (generate, step, shadow) and why:
the rays a SIMD vector traverses the BVH with are binned so that every lane has one.
A pass renders its samples in waves of at most :attr:`Wavefront.capacity` paths (one
path per sample); each wave generates its camera rays, then alternates a step over the
ray queue with the shadow stage over the shadow queue until no path is left. The images
are bitwise the render kernel's: every path draws the same numbers and adds its sample to
the same exact sums.

Memory, per path of a wave: twice :data:`PATH_BYTES` of state (the queue a step reads and
the one it writes), :data:`SHADOW_BYTES` of shadow queue and :data:`HIT_BYTES` of extend
hits; each buffer stays within one storage binding.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..errors import UsageError
from ..gl import shaders
from ..gpu import bindings

PATH_BYTES = 160      # WavePath: 10 vec4
SHADOW_BYTES = 48     # WaveShadow: 3 vec4
#: the most paths one wave holds: 512 Ki paths (80 MiB of path state) keep a stage's fixed
#: dispatch cost small and leave memory for large films
MAX_CAPACITY = 1 << 19
STAGES = {"generate": 0, "step": 1, "shadow": 2, "extend": 3}
HIT_BYTES = 16        # the extend stage's hit per path: vec4
#: the stages' work group size (kernels/wavefront.comp.glsl local_size_x): 256 measured 1.2x
#: faster than 64 on the Cornell box (fewer groups for llvmpipe to start), 1024 no better
LOCAL_SIZE = 256


def supports(integrator: str, split: int, light_samples: int, light_selection: str = "uniform") -> str | None:
    """None when the wavefront executor renders these settings, else why not (one line)."""
    if integrator != "path":
        return f"the wavefront executor runs the path integrator, not {integrator}"
    if split != 1 or light_samples != 1:
        return "the wavefront executor takes one light sample and no splitting (--split 1 --light-samples 1)"
    if light_selection == "bvh":
        # a queued path keeps its last vertex, not the normal its light sample chose for
        return "the wavefront executor chooses lights uniformly or by power, not by the light BVH"
    return None


class Wavefront:
    """The stage programs of one renderer's scene and settings, and their queues."""

    def __init__(self, ctx: Any, defines: dict[str, Any], slots: dict[str, str],
                 library: shaders.ShaderLibrary, binding_limit: int,
                 capacity: int | None = None) -> None:
        self.ctx, self.gl = ctx, ctx.gl
        fit = min(binding_limit // PATH_BYTES, binding_limit // SHADOW_BYTES, MAX_CAPACITY)
        self.capacity = int(min(capacity or fit, fit))
        if self.capacity < LOCAL_SIZE:
            raise UsageError(f"wavefront executor: a wave of {self.capacity} paths is too small")
        self.programs = {
            name: shaders.compile_compute(
                ctx, "kernels/wavefront.comp.glsl",
                defines={**defines, "GLRENDER_WAVEFRONT": 1, "GLRENDER_WAVE_STAGE": stage,
                         "GLRENDER_WAVE_BVH_HITS": int(name == "step")},
                slots=slots, library=library)
            for name, stage in STAGES.items()}
        w = self.capacity
        self.paths = [self.gl.buffer(reserve=w * PATH_BYTES), self.gl.buffer(reserve=w * PATH_BYTES)]
        self.shadows = self.gl.buffer(reserve=w * SHADOW_BYTES)
        self.counters = self.gl.buffer(reserve=16)
        self.hits = self.gl.buffer(reserve=w * HIT_BYTES)
        #: per wave: (bounces, paths stepped, shadow rays) of the last pass
        self.last_waves: list[tuple[int, int, int]] = []

    def _run(self, name: str, count: int, wave: tuple[int, int, int, int],
             pass_: tuple[int, int, int, int]) -> None:
        program = self.programs[name]
        for uniform, value in (("u_wave", wave), ("u_pass", pass_)):
            member = program.get(uniform, None)
            if member is not None:   # the compiler drops what a stage never reads
                member.value = value
        program.run(group_x=(count + LOCAL_SIZE - 1) // LOCAL_SIZE)

    def _take_counters(self) -> tuple[int, int, int, int]:
        """The queue counters written by the last stage, then zero them for the next."""
        c = np.frombuffer(self.counters.read(), np.uint32)
        self.counters.write(np.zeros(4, np.uint32).tobytes())
        return int(c[0]), int(c[1]), int(c[2]), int(c[3])

    def render(self, first_sample: int, samples: int, tiles: int,
               should_stop: Callable[[], bool] | None = None) -> bool:
        """Samples [first_sample, first_sample + samples) of every pixel of ``tiles`` 8x8
        tiles (the bound slice's). The scene, the film and the parameter block must be
        bound. ``should_stop`` is asked between waves: True stops (returns False) with the
        waves done so far added."""
        w = self.capacity
        self.shadows.bind_to_storage_buffer(bindings.SSBO_WAVE_SHADOWS)
        self.counters.bind_to_storage_buffer(bindings.SSBO_WAVE_COUNTERS)
        self.hits.bind_to_storage_buffer(bindings.SSBO_WAVE_HITS)
        self.counters.write(np.zeros(4, np.uint32).tobytes())
        pixels = tiles * 64
        pass_ = (samples, first_sample, pixels, 0)
        total = pixels * samples
        self.last_waves = []
        for first in range(0, total, w):
            if first and should_stop is not None and should_stop():
                return False
            n = min(w, total - first)
            out = 0   # the path buffer the next stage writes
            self.paths[out].bind_to_storage_buffer(bindings.SSBO_WAVE_PATHS_OUT)
            self._run("generate", n, (0, n, w, first), pass_)
            front, back, _, _ = self._take_counters()
            bounces = stepped = shadows = 0
            while front + back:
                self.paths[out].bind_to_storage_buffer(bindings.SSBO_WAVE_PATHS_IN)
                out = 1 - out
                self.paths[out].bind_to_storage_buffer(bindings.SSBO_WAVE_PATHS_OUT)
                if front:
                    self._run("extend", front, (front, back, w, 0), pass_)
                self._run("step", front + back, (front, back, w, 0), pass_)
                stepped += front + back
                front, back, s_front, s_back = self._take_counters()
                if s_front + s_back:
                    self._run("shadow", s_front + s_back, (s_front, s_back, w, 0), pass_)
                    shadows += s_front + s_back
                bounces += 1
            self.last_waves.append((bounces, stepped, shadows))
        return True

    def release(self) -> None:
        for buf in [*self.paths, self.shadows, self.counters, self.hits]:
            buf.release()
        self.paths = []
