"""The renderer's defaults held against what the lab measured (the report's last section)."""
from __future__ import annotations

from .core import Section


def _find(sections, name):
    return next((s for s in sections if s.name == name), None)


def defaults_section(sections: list[Section]) -> Section | None:
    """One line per default the lab can judge: the default, the measured best, the evidence."""
    from ..scene.model import Integrator, Sampler

    integ, samp = Integrator(), Sampler()
    lines = []
    patterns = _find(sections, "patterns")
    if patterns is not None:
        slopes = patterns.extra["rmse"]["light"]["slopes"]
        last = patterns.tables[1]
        best = max(("independent", "stratified", "sobol"),
                   key=lambda p: last.row(f"{p}/light").efficiency)
        lines.append(f"**Sampler** (default `{samp.kind}`): on the smooth irradiance integral the "
                     f"most efficient of the renderer's samplers is **{best}** (RMSE slopes: "
                     f"independent {slopes['independent']:+.2f}, stratified "
                     f"{slopes['stratified']:+.2f}, Sobol' {slopes['sobol']:+.2f}); see Sampling "
                     f"patterns.")
    direct = _find(sections, "direct")
    if direct is not None:
        plates = direct.tables[0]
        bal, pw = plates.row("mis-balance"), plates.row("mis-power")
        best = "mis-power" if pw.efficiency >= bal.efficiency else "mis-balance"
        lines.append(f"**MIS heuristic** (default `{integ.strategy}`): on Veach's plates the power "
                     f"heuristic's efficiency is ×{pw.efficiency / bal.efficiency:.3g} the "
                     f"balance heuristic's (measured best: **{best}**; the two differ by less than "
                     f"their noise when the ratio is near 1).")
    selection = _find(sections, "light_selection")
    if selection is not None:
        whole = selection.tables[0]
        ratio = whole.row("power").efficiency / whole.row("uniform").efficiency
        lines.append(f"**Light selection** (default `{integ.light_selection}`): choosing ∝ power "
                     f"has ×{ratio:.3g} the efficiency of uniform choice over the whole Veach "
                     f"image, but the tables by region disagree (see Light selection): "
                     f"neither wins everywhere.")
    roulette = _find(sections, "roulette")
    if roulette is not None:
        t = roulette.tables[0]
        by_rays = roulette.extra["efficiency_by_rays"]
        rr = {d: by_rays[f"rr-depth-{d}"] / by_rays["none"] for d in (1, 3, 5)}
        lines.append(f"**Russian roulette** (default: Mitsuba's throughput rule from depth "
                     f"{integ.rr_depth}): by rays, throughput RR from depth 1/3/5 is ×"
                     f"{rr[1]:.3g}/×{rr[3]:.3g}/×{rr[5]:.3g} as efficient as none; fixed survival "
                     f"probabilities do worse (see Russian roulette). The walk is a model of a "
                     f"path, not the renderer's path tracer.")
    if not lines:
        return None
    return Section("defaults", "The renderer's defaults against the measurements",
                   "Each default of the renderer next to what this run measured best. The lab "
                   "does not change defaults: a difference here is a finding to act on.",
                   findings=lines)
