"""Pictures of the warps and a table of their chi-square p-values (``glrender sampling``).

For every 2D warp of :mod:`glrender.sampling.catalog`, one PNG with two panels, as in
the lecture's disk figures: the warp applied to independent uniform points (left) and
to a jittered grid, one point per stratum, with the images of the strata boundaries
drawn (right). Planar warps are drawn in their plane (triangles as barycentrics on an
equilateral triangle, the 2D distribution over its image), directions as their (x, y)
projection seen from +z (points below the horizon in a second colour). ``disks.png``
puts the four disk warps side by side. ``chi2.md`` lists each warp's chi-square test
(10^6 GLSL samples by default, Šidák-corrected over the table).

Points are coloured by their u: hue from u.x, lightness from u.y, so that where a
stratum goes can be followed by eye.
"""
from __future__ import annotations

import colorsys
from pathlib import Path

import numpy as np

from ..testing.chi2 import ChiSquareTest, SphericalDomain
from ..testing.stats import sidak_alpha
from .catalog import CATALOG, RECTANGLE_REF, Warp, run_warp

PANEL = 360        # panel size in pixels
STRATA = 16        # strata per axis of the jittered grid (256 points per panel)
LINE_POINTS = 257  # points per traced stratum boundary
ALPHA = 0.01


def jittered_grid(n: int, rng: np.random.Generator) -> np.ndarray:
    """n x n stratified points of [0,1)^2: one uniform point in each cell, row by row."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    cells = np.stack([i.ravel(), j.ravel()], axis=1)
    return ((cells + rng.random((n * n, 2))) / n).astype(np.float32)


def _font(size: int):
    from PIL import ImageFont
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: bitmap font only
        return ImageFont.load_default()


# -- where a warp's points go on the page (x right, y up, in [-1, 1]^2) ---------------------
_SQRT3_2 = np.sqrt(3.0) / 2.0


def plane_coords(warp: Warp, p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, np.float64)
    if warp.point_type == "vec3" and warp.plot == "planar":  # barycentrics
        corners = np.array([[-1.0, -_SQRT3_2], [1.0, -_SQRT3_2], [0.0, _SQRT3_2]]) * 0.95
        return p @ corners
    if warp.plot == "sphere":
        if warp.name == "spherical_rectangle":
            p = p - np.asarray(RECTANGLE_REF)
            p /= np.linalg.norm(p, axis=1, keepdims=True)
        return p
    if warp.name == "distribution_2d":
        return 2.0 * p - 1.0
    return p


class _Panel:
    def __init__(self, title: str):
        from PIL import Image, ImageDraw
        self.image = Image.new("RGB", (PANEL, PANEL + 24), "white")
        self.draw = ImageDraw.Draw(self.image)
        self.draw.text((6, 4), title, fill="black", font=_font(14))

    def xy(self, q: np.ndarray) -> np.ndarray:
        scale = 0.46 * PANEL
        return np.column_stack([PANEL / 2 + scale * q[:, 0], 24 + PANEL / 2 - scale * q[:, 1]])

    def outline(self, warp: Warp) -> None:
        grey = (170, 170, 170)
        scale = 0.46 * PANEL
        c = (PANEL / 2, 24 + PANEL / 2)
        if warp.plot == "sphere" or warp.group == "disk":
            self.draw.ellipse([c[0] - scale, c[1] - scale, c[0] + scale, c[1] + scale], outline=grey)
        if warp.group == "triangle":
            corners = self.xy(np.array([[-1.0, -_SQRT3_2], [1.0, -_SQRT3_2], [0.0, _SQRT3_2]]) * 0.95)
            self.draw.polygon([tuple(v) for v in corners], outline=grey)
        if warp.group in ("disk", "distribution"):
            self.draw.rectangle([c[0] - scale, c[1] - scale, c[0] + scale, c[1] + scale], outline=grey)

    def background(self, warp: Warp) -> None:
        """The 2D distribution's image, in grey levels, under its samples."""
        if warp.name != "distribution_2d":
            return
        from .catalog import DIST_2D
        nv, nu = DIST_2D.shape
        top = DIST_2D.max()
        for j in range(nv):
            for i in range(nu):
                level = int(255 - 90 * DIST_2D[j, i] / top)
                lo = self.xy(np.array([[2 * i / nu - 1, 2 * (j + 1) / nv - 1]]))[0]
                hi = self.xy(np.array([[2 * (i + 1) / nu - 1, 2 * j / nv - 1]]))[0]
                self.draw.rectangle([lo[0], lo[1], hi[0], hi[1]], fill=(level, level, level))

    def points(self, q: np.ndarray, u: np.ndarray, below: np.ndarray | None = None) -> None:
        for k, (x, y) in enumerate(self.xy(q)):
            h, s, l = 0.8 * float(u[k, 0]), 0.85, 0.25 + 0.45 * float(u[k, 1])
            color = tuple(int(255 * c) for c in colorsys.hls_to_rgb(h, l, s))
            if below is not None and below[k]:
                self.draw.rectangle([x - 1.5, y - 1.5, x + 1.5, y + 1.5], outline=color)
            else:
                self.draw.ellipse([x - 2, y - 2, x + 2, y + 2], fill=color)

    def polyline(self, q: np.ndarray) -> None:
        """A traced boundary, broken where the warp jumps (a step 8x the median step:
        the 2D distribution skips empty rows, for one)."""
        xy = self.xy(q)
        steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
        cuts = np.flatnonzero(steps > 8 * max(np.median(steps), 0.5)) + 1
        for piece in np.split(xy, cuts):
            if len(piece) > 1:
                self.draw.line([tuple(v) for v in piece], fill=(120, 120, 120), width=1)


def _boundaries(n: int) -> list[np.ndarray]:
    """The stratum boundaries u.x = k / n and u.y = k / n as dense polylines in [0,1)^2."""
    t = np.linspace(0.0, 1.0 - 2.0 ** -24, LINE_POINTS)
    edges = np.minimum(np.arange(n + 1) / n, 1.0 - 2.0 ** -24)
    lines = [np.column_stack([np.full_like(t, e), t]) for e in edges]
    lines += [np.column_stack([t, np.full_like(t, e)]) for e in edges]
    return [line.astype(np.float32) for line in lines]


def _draw_warp(warp: Warp, u: np.ndarray, title: str, lines: bool):
    panel = _Panel(title)
    panel.background(warp)
    panel.outline(warp)
    if lines and warp.name != "uniform_disk_rejection":  # rejection: later trials are not u
        bounds = _boundaries(STRATA)
        traced = run_warp(warp, np.concatenate(bounds))["p"]
        for k in range(len(bounds)):
            panel.polyline(plane_coords(warp, traced[k * LINE_POINTS:(k + 1) * LINE_POINTS]))
    p = run_warp(warp, u)["p"]
    below = None
    if warp.plot == "sphere":
        d = plane_coords(warp, p)
        below = d[:, 2] < 0
    panel.points(plane_coords(warp, p), u, below)
    return panel.image


def warp_figure(warp: Warp, seed: int = 0):
    """Independent points | jittered grid with strata boundaries, for one 2D warp."""
    from PIL import Image
    rng = np.random.default_rng(seed)
    independent = rng.random((STRATA * STRATA, 2), dtype=np.float32)
    stratified = jittered_grid(STRATA, rng)
    left = _draw_warp(warp, independent, warp.title, lines=False)
    right = _draw_warp(warp, stratified, "jittered grid and its strata", lines=True)
    figure = Image.new("RGB", (2 * PANEL + 8, PANEL + 24), "white")
    figure.paste(left, (0, 0))
    figure.paste(right, (PANEL + 8, 0))
    return figure


def disks_figure(seed: int = 0):
    """The four disk warps (polar r = u, equi-areal, concentric, rejection): independent
    points on the top row, the jittered grid on the bottom row."""
    from PIL import Image
    disks = [w for w in CATALOG if w.group == "disk"]
    rng = np.random.default_rng(seed)
    independent = rng.random((STRATA * STRATA, 2), dtype=np.float32)
    stratified = jittered_grid(STRATA, rng)
    figure = Image.new("RGB", (len(disks) * (PANEL + 8), 2 * (PANEL + 32)), "white")
    for k, warp in enumerate(disks):
        figure.paste(_draw_warp(warp, independent, warp.title, lines=False), (k * (PANEL + 8), 0))
        figure.paste(_draw_warp(warp, stratified, "jittered grid and its strata", lines=True),
                     (k * (PANEL + 8), PANEL + 32))
    return figure


def chi2_table(seed: int = 0, sample_count: int = 1_000_000) -> str:
    """Markdown table of every catalogued warp's chi-square test (GLSL samples)."""
    threshold = sidak_alpha(ALPHA, len(CATALOG))
    rows = ["| warp | domain | samples | chi2 | dof | p-value | result |",
            "|---|---|---|---|---|---|---|"]
    for k, warp in enumerate(CATALOG):
        def sample(u, warp=warp):
            return warp.to_domain(run_warp(warp, u)["p"].astype(np.float64))
        test = ChiSquareTest(warp.domain, sample, warp.pdf, sample_dim=warp.sample_dim,
                             sample_count=sample_count, res=warp.res, seed=seed + k, name=warp.name)
        ok = test.run()
        stat = f"{test.statistic:.1f}" if hasattr(test, "statistic") else "-"
        dof = f"{test.dof}" if hasattr(test, "dof") else "-"
        domain = "sphere" if isinstance(warp.domain, SphericalDomain) else warp.domain.name
        rows.append(f"| {warp.name} | {domain} | {sample_count} | {stat} | {dof} | "
                    f"{test.p_value:.3g} | {'accepted' if ok else 'REJECTED'} |")
    head = (f"# Chi-square goodness of fit of the GLSL warps\n\nEach warp's GLSL samples "
            f"against its own pdf (glrender.testing.chi2), seed {seed} + row. A warp is "
            f"accepted when p >= {threshold:.3g}: alpha = {ALPHA} Šidák-corrected over the "
            f"{len(CATALOG)} tests of the table.\n\n")
    return head + "\n".join(rows) + "\n"


def write_sampling_plots(out_dir, seed: int = 0, sample_count: int = 1_000_000) -> list[Path]:
    """Write ``<warp>.png`` for every 2D warp, ``disks.png`` and ``chi2.md`` into out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for warp in CATALOG:
        if warp.plot == "none":
            continue
        path = out / f"{warp.name}.png"
        warp_figure(warp, seed).save(path)
        written.append(path)
    path = out / "disks.png"
    disks_figure(seed).save(path)
    written.append(path)
    path = out / "chi2.md"
    path.write_text(chi2_table(seed, sample_count), encoding="utf-8")
    written.append(path)
    return written
