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
                     f"balance heuristic's (best on the plates with the direct integrator: **{best}**; "
                     f"the two differ by less than their noise when the ratio is near 1; the "
                     f"default is decided over all the survey's scenes: the last line).")
    selection = _find(sections, "light_selection")
    if selection is not None:
        whole = selection.tables[0]
        ratio = whole.row("power").efficiency / whole.row("uniform").efficiency
        lines.append(f"**Light selection** (default `{integ.light_selection}`): choosing ∝ power "
                     f"has ×{ratio:.3g} the efficiency of uniform choice over the whole Veach "
                     f"image, but the tables by region disagree (see Light selection): "
                     f"neither wins everywhere (the default: the last line).")
    roulette = _find(sections, "roulette")
    if roulette is not None:
        lines.append(roulette_line(roulette, integ))
    survey = _find(sections, "survey")
    if survey is not None:
        lines.append(survey_line(survey, integ))
    if not lines:
        return None
    return Section("defaults", "The renderer's defaults against the measurements",
                   "Each default of the renderer next to what this run measured best. The lab "
                   "does not change defaults: a difference here is a finding to act on.",
                   findings=lines)


def roulette_line(roulette: Section, integ) -> str:
    """The path tracer's roulette rule and splitting against the settings measured per scene:
    the best by rays on each, and the setting whose worse scene is best (by rays)."""
    from .roulette import DEFAULT, variants

    label = variants()[1]
    bests = roulette.extra["best"]
    default = (f"`rr = {integ.rr}` from depth {integ.rr_depth}, {integ.light_samples} light "
               f"sample, split {integ.split}")
    per_scene = []
    for title, b in bests.items():
        ratio = b["ratio_by_rays"]
        top = b["by_rays"]
        per_scene.append(f"{title.split(':')[0]}: **{label[top]}** (×{ratio[top] / ratio[DEFAULT]:.3g} the "
                         f"default's efficiency by rays)")
    names = list(next(iter(bests.values()))["ratio_by_rays"])
    worst = {n: min(b["ratio_by_rays"][n] for b in bests.values()) for n in names}
    robust = max(worst, key=worst.get)
    winners = {b["by_rays"] for b in bests.values()}
    if winners == {DEFAULT}:
        verdict = "the default is the measured best on every scene"
    elif len(winners) == 1:
        verdict = f"**{label[winners.pop()]} is best on every scene: the default should follow it**"
    else:
        verdict = (f"no setting is best on every scene; the one whose worse scene does best is "
                   f"{label[robust]} (×{worst[robust]:.3g} of no roulette there, the default "
                   f"×{worst[DEFAULT]:.3g}); the default stays Mitsuba's rule until more scenes "
                   f"decide (see Russian roulette)")
    return (f"**Russian roulette and splitting** (default: {default}): best by rays on "
            + "; ".join(per_scene) + f". {verdict[0].upper()}{verdict[1:]}.")


def survey_line(survey: Section, integ) -> str:
    """The path tracer's defaults against the settings the survey's criterion chose."""
    from .survey import ALBEDO, FLOOR

    ours = dict(rr=integ.rr, rr_depth=integ.rr_depth, strategy=integ.strategy,
                light_selection=integ.light_selection)
    chosen = survey.extra["chosen"]
    parts = []
    for decision, c in survey.extra["choice_by_time"].items():
        best = c["candidates"][c["chosen"]]
        others = [f"{s['label']} ×{s['geomean']:.3g} (worst ×{s['worst']:.3g}"
                  + ("" if s.get("finite_variance_albedo", 1.0) > ALBEDO else
                     f"; variance finite only below albedo {s['finite_variance_albedo']:.2f}") + ")"
                  for n, s in c["candidates"].items() if n != c["chosen"]]
        parts.append(f"{decision}: **{best['label']}** (against it: " + "; ".join(others) + ")"
                     if c["chosen"] == "baseline" else
                     f"{decision}: **{best['label']}** (×{best['geomean']:.3g}, worst ×{best['worst']:.3g})")
    verdict = ("the renderer's defaults are these settings" if ours == chosen else
               f"**the renderer's defaults ({ours}) differ from the chosen ({chosen})**")
    return (f"**Path tracer defaults over {len(survey.tables)} scenes** (criterion: the best "
            f"geometric mean of the efficiency ratio by time among the settings no worse than "
            f"×{FLOOR:g} on any scene whose variance stays finite up to albedo {ALBEDO:g}; see "
            f"the survey): " + "; ".join(parts) + f". {verdict[0].upper()}"
            f"{verdict[1:]}.")
