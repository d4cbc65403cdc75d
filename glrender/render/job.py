"""A render run to a sample target or a time budget, in whole passes, stoppable at any time.

:class:`RenderJob` drives a :class:`~glrender.render.renderer.Renderer` pass by pass:

- it stops at ``spp_target``, or before a pass that would end past ``seconds`` (judged by
  the last pass's duration), so a time budget ends within one pass of its mark; a pass
  that runs past the budget anyway is undone between dispatches (the first pass of a run
  always completes, so a run adds samples even when one pass outlasts the budget);
- ``stop()`` is asked between dispatches (at most ~``time_target``, 0.1 s, apart): when it
  answers True the pass in progress is undone and the run ends, the accumulation at a
  whole pass, ready for a checkpoint;
- ``checkpoint()`` is called after the pass that ends ``checkpoint_every`` seconds after
  the last one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field


@dataclass
class JobResult:
    stopped: str                 # "complete", "time" or "interrupted"
    spp_start: int
    spp_done: int
    passes: int
    seconds: float               # wall time of the run, checkpoints included
    checkpoint_seconds: float
    pass_seconds_max: float
    checkpoints: int = 0
    pass_seconds: list = field(default_factory=list)

    @property
    def render_seconds(self) -> float:
        return self.seconds - self.checkpoint_seconds


class RenderJob:
    """Run ``renderer`` from its current sample count up to ``spp_target`` samples per
    pixel, within ``seconds`` if given. ``progress(spp_done, elapsed)`` after each pass."""

    def __init__(self, renderer, spp_target: int, *, seconds: float | None = None,
                 stop=None, checkpoint=None, checkpoint_every: float | None = None,
                 progress=None, clock=time.perf_counter):
        self.renderer = renderer
        self.spp_target = int(spp_target)
        self.seconds = seconds
        self.stop = stop or (lambda: False)
        self.checkpoint = checkpoint
        self.checkpoint_every = checkpoint_every
        self.progress = progress
        self.clock = clock

    def run(self) -> JobResult:
        r, clock = self.renderer, self.clock
        start = clock()
        spp_start = r.spp_done
        result = JobResult("complete", spp_start, spp_start, 0, 0.0, 0.0, 0.0)
        last_checkpoint = start

        def past_budget() -> bool:
            # only once this run has a pass: a run always adds samples
            return (self.seconds is not None and r.spp_done > spp_start
                    and clock() - start >= self.seconds)

        def should_stop() -> bool:
            return self.stop() or past_budget()

        while r.spp_done < self.spp_target:
            if self.stop():
                result.stopped = "interrupted"
                break
            if self.seconds is not None and result.pass_seconds and \
                    clock() - start + result.pass_seconds[-1] > self.seconds:
                result.stopped = "time"
                break
            k = min(r.samples_per_pass, self.spp_target - r.spp_done)
            t0 = clock()
            if r.step(k, should_stop=should_stop) == 0:
                result.stopped = "interrupted" if self.stop() else "time"
                break
            now = clock()
            result.pass_seconds.append(now - t0)
            result.passes += 1
            if self.progress is not None:
                self.progress(r.spp_done, now - start)
            if self.checkpoint is not None and self.checkpoint_every is not None and \
                    now - last_checkpoint >= self.checkpoint_every and r.spp_done < self.spp_target:
                self.checkpoint()
                last_checkpoint = clock()
                result.checkpoint_seconds += last_checkpoint - now
                result.checkpoints += 1
        result.spp_done = r.spp_done
        result.seconds = clock() - start
        result.pass_seconds_max = max(result.pass_seconds, default=0.0)
        return result
