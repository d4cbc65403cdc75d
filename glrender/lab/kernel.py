"""The lab's estimator kernel: many independent runs of a GLSL estimator, timed on the device.

A *technique* is a GLSL snippet that computes one sample ``f`` of an estimator (the
value f(x)/p(x), a hit-or-miss indicator, ...). The kernel runs ``runs`` independent
estimates of ``samples`` samples each: run r has its own seed, and sample i of run r
draws its random numbers from a counter-based hash of (run seed, i, draw number), so
every run is a full, independent randomization and the result does not depend on how
the work is split.

Inside the snippet:

- ``lab_uniform()`` / ``lab_uniform2()``: the next uniform number(s) in [0, 1) of this
  sample (independent across samples and runs);
- ``lab_index`` (uint): the sample's index i in its run, ``lab_count`` (uint): the
  samples per run N, ``lab_seed`` (uint): the run's seed, for patterns (stratified,
  Latin hypercube, Sobol') that place sample i of N;
- ``lab_work`` (uint): add deterministic cost units (rays, light evaluations) to it;
  every uniform drawn counts one unit of ``draws`` by itself.

Each invocation accumulates a few samples (``PER_INVOCATION``, far below llvmpipe's
loop cap) with Welford's update and writes its mean and M2; the host merges them in
float64 per run. Cost is the device time of the dispatch (``glFinish`` around it),
the smallest of a few repeats interleaved across techniques.
"""
from __future__ import annotations

import time
import zlib
from dataclasses import dataclass, field

import numpy as np

from ..gl import shaders
from ..gl.context import default_context

PER_INVOCATION = 64   # samples per invocation: with inner loops of <= 64 steps, << 65,535
LOCAL_SIZE = 64
MAX_INVOCATIONS = 1 << 18   # per dispatch: keeps each output buffer at a few MiB


@dataclass
class Technique:
    """One way of estimating the experiment's quantity: a GLSL body assigning ``float f``."""

    name: str
    body: str
    includes: tuple[str, ...] = ()
    preamble: str = ""
    label: str = ""          # for tables and legends (defaults to name)

    @property
    def title(self) -> str:
        return self.label or self.name


@dataclass
class RunSet:
    """The raw outcome of ``runs`` independent estimates of ``samples`` samples each."""

    estimates: np.ndarray     # (runs,) float64: each run's mean
    m2: np.ndarray            # (runs,) each run's sum of squared deviations (float64)
    samples: int              # per run
    draws: float              # uniforms drawn per sample (mean)
    work: float               # lab_work units per sample (mean)
    seconds: float            # device time of all runs (best of the repeats)
    times: list = field(default_factory=list)

    @property
    def runs(self) -> int:
        return len(self.estimates)

    @property
    def run_variances(self) -> np.ndarray:
        """Each run's per-sample variance (unbiased for independent samples)."""
        return self.m2 / max(self.samples - 1, 1)


def _source(tech: Technique) -> str:
    lines = ["#version 450", f"layout(local_size_x = {LOCAL_SIZE}) in;",
             '#include "common/hash.glsl"']
    lines += [f'#include "{inc}"' for inc in tech.includes]
    lines += [
        "uniform uint u_base_seed;", "uniform uint u_samples;", "uniform uint u_groups_per_run;",
        "uniform uint u_first_invocation;", "uniform uint u_per_invocation;",
        "layout(std430, binding = 0) writeonly buffer LabOut { vec4 lab_out[]; };",
        "uint lab_index;", "uint lab_count;", "uint lab_seed;", "uint lab_key;",
        "uint lab_draw;", "uint lab_work;",
        "// The next uniform of this sample in [0, 1): counter-based (run seed, index, draw).",
        "float lab_uniform() {",
        "    lab_draw += 1u;",
        "    return uint_to_unit_float(hash_combine(lab_key, lab_draw));",
        "}",
        "vec2 lab_uniform2() { float a = lab_uniform(); return vec2(a, lab_uniform()); }",
        tech.preamble,
        "float lab_sample() {",
        "    float f = 0.0;",
        "    {",
        *("        " + line for line in tech.body.splitlines()),
        "    }",
        "    return f;",
        "}",
        "void main() {",
        "    uint invocation = gl_GlobalInvocationID.x + u_first_invocation;",
        "    uint run = invocation / u_groups_per_run;",
        "    uint first = (invocation % u_groups_per_run) * u_per_invocation;",
        "    lab_count = u_samples;",
        "    lab_seed = hash_combine(u_base_seed, run);",
        "    float mean = 0.0, m2 = 0.0;",
        "    uint draws = 0u, work = 0u;",
        "    for (uint s = 0u; s < u_per_invocation; ++s) {",
        "        lab_index = first + s;",
        "        lab_key = hash_combine(lab_seed, lab_index);",
        "        lab_draw = 0u;",
        "        lab_work = 0u;",
        "        float x = lab_sample();",
        "        float delta = x - mean;",
        "        mean += delta / float(s + 1u);",
        "        m2 += delta * (x - mean);",
        "        draws += lab_draw;",
        "        work += lab_work;",
        "    }",
        "    lab_out[gl_GlobalInvocationID.x] = vec4(mean, m2, uintBitsToFloat(draws), "
        "uintBitsToFloat(work));",
        "}",
    ]
    return "\n".join(lines) + "\n"


class EstimatorKernel:
    """A compiled technique, ready to run sets of independent estimates."""

    def __init__(self, tech: Technique, ctx=None):
        self.tech = tech
        self.ctx = ctx or default_context()
        self.gl = self.ctx.gl
        self.program = shaders.compile_compute(self.ctx, source=_source(tech),
                                               name=f"<lab:{tech.name}>")

    def _set(self, name: str, value) -> None:
        member = self.program.get(name, None)
        if member is not None:
            member.value = value

    def run(self, runs: int, samples: int, seed: int) -> tuple[RunSet, float]:
        """``runs`` estimates of ``samples`` samples; returns them and the device seconds."""
        per = min(PER_INVOCATION, samples)
        if samples % per:
            raise ValueError(f"samples per run ({samples}) must be a multiple of {per}")
        groups_per_run = samples // per
        total = runs * groups_per_run
        self._set("u_base_seed", int(seed) & 0xFFFFFFFF)
        self._set("u_samples", samples)
        self._set("u_groups_per_run", groups_per_run)
        self._set("u_per_invocation", per)
        chunk = min(total, MAX_INVOCATIONS)
        buf = self.gl.buffer(reserve=chunk * 16)
        out = np.empty((total, 4), np.float32)
        seconds = 0.0
        try:
            buf.bind_to_storage_buffer(0)
            for start in range(0, total, chunk):
                size = min(chunk, total - start)
                self._set("u_first_invocation", start)
                self.gl.finish()
                t0 = time.perf_counter()
                self.program.run(group_x=-(-size // LOCAL_SIZE))
                self.gl.finish()
                seconds += time.perf_counter() - t0
                out[start:start + size] = np.frombuffer(buf.read(size=size * 16),
                                                        np.float32).reshape(size, 4)
        finally:
            buf.release()
        means = out[:, 0].astype(np.float64).reshape(runs, groups_per_run)
        m2s = out[:, 1].astype(np.float64).reshape(runs, groups_per_run)
        counters = out[:, 2:].copy().view(np.uint32).astype(np.float64)
        estimates = means.mean(axis=1)
        # Chan et al.'s merge of equal-sized groups: M2 = sum m2_g + per * sum (mean_g - mean)^2
        m2 = m2s.sum(axis=1) + per * ((means - estimates[:, None]) ** 2).sum(axis=1)
        n = runs * samples
        result = RunSet(estimates=estimates, m2=m2, samples=samples,
                        draws=float(counters[:, 0].sum() / n), work=float(counters[:, 1].sum() / n),
                        seconds=seconds)
        return result, seconds


def technique_seed(seed: int, name: str) -> int:
    """A technique's own seed: techniques draw independent numbers from one lab seed."""
    return (int(seed) * 0x9E3779B1 + zlib.crc32(name.encode())) & 0xFFFFFFFF


def run_techniques(techniques: list[Technique], runs: int, samples: int, seed: int,
                   repeats: int = 3, ctx=None) -> dict[str, RunSet]:
    """Every technique on the same problem: the same run seeds (independent across runs),
    timed ``repeats`` times in interleaved order; the best time is kept (the machine is
    shared, so the smallest time is the least disturbed one)."""
    kernels = [EstimatorKernel(t, ctx) for t in techniques]
    results: dict[str, RunSet] = {}
    for k in kernels:                      # warm up: the JIT runs at the first dispatch
        k.run(1, min(samples, PER_INVOCATION), seed)
    for rep in range(max(repeats, 1)):
        for k in kernels:
            result, seconds = k.run(runs, samples, technique_seed(seed, k.tech.name))
            prev = results.get(k.tech.name)
            if prev is None:
                result.times = [seconds]
                results[k.tech.name] = result
            else:
                prev.times.append(seconds)
                prev.seconds = min(prev.times)
    return results


def measure(lab, techniques: list[Technique], runs: int, samples: int, exact: float | None,
            exact_stderr: float = 0.0, work_unit: str | None = None, repeats: int | None = None,
            independent: bool = True):
    """Run every technique and turn the run sets into :class:`Measurement` rows; the
    deterministic cost units are the uniforms drawn and, if named, ``lab_work``. With
    ``independent`` samples the variance per sample is pooled within the runs (precise);
    patterns whose samples are correlated set it False and get samples x Var(run)."""
    from .core import Measurement

    # quick dispatches last a millisecond or so, where one preemption on a shared machine
    # multiplies the time: more repeats, and the smallest time is kept
    repeats = repeats if repeats is not None else 5
    sets = run_techniques(techniques, runs, samples, lab.seed, repeats=repeats, ctx=lab.ctx)
    rows = []
    for tech in techniques:
        rs = sets[tech.name]
        units = {"uniforms": rs.draws}
        if work_unit:
            units[work_unit] = rs.work
        rows.append(Measurement(tech.name, rs.estimates, rs.samples, rs.seconds, exact=exact,
                                exact_stderr=exact_stderr, units=units, label=tech.title,
                                run_variances=rs.run_variances if independent else None))
    return rows
