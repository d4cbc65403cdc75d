"""Area light sampling: by area vs by solid angle.

- A sphere light (radius R = 0.5, radiance 1) at distance d = 1 above a point whose
  normal points at its centre: E = π (R/d)² exactly. Uniform points on the whole
  sphere (density 1/4πR² per area, half of them on the back, contributing 0) vs uniform
  points on the visible cap vs directions uniform in the cone it subtends
  (sampling/cone.glsl): E = ∫ L cos θ dω, and the cone pdf cancels all but cos θ.
- The renderer on the Cornell box with its rectangular ceiling light made 3× wider and
  deeper (radiance ÷ 9, so the same power): the ``direct``
  integrator with light sampling only, the light sampled uniformly by area or uniformly
  in solid angle (spherical rectangle, Ureña et al. 2013), at equal samples per pixel.
  The renderer samples in solid angle only where the light looks large (an estimated
  solid angle above 0.5 sr: near the ceiling), and by area elsewhere, where the two
  differ little; with the original small light the two settings give the same image.
"""
from __future__ import annotations

import math

import numpy as np

from .core import Section, Table, ratio_findings
from .kernel import Technique, measure
from .renders import load_scene, pair_variance_figure, region_table, render_variants
from .report import bar_figure

NAME = "area_lights"
TITLE = "Area light sampling: by area vs by solid angle"

RADIUS, DIST = 0.5, 1.0
EXACT = math.pi * (RADIUS / DIST) ** 2

SPHERE = f"""\
const float kRadius = {RADIUS};
const vec3 kCentre = vec3(0.0, 0.0, {DIST});
// Irradiance integrand at the origin (normal +z) from the light point q with outward
// normal nq: L cos(theta) cos(theta_q) / r^2, zero on the far side of the sphere.
float sphere_irradiance(vec3 q, vec3 nq) {{
    float r2 = dot(q, q);
    vec3 w = q * inversesqrt(r2);
    float cos_q = -dot(nq, w);
    return cos_q > 0.0 && w.z > 0.0 ? w.z * cos_q / r2 : 0.0;
}}
"""


def techniques() -> list[Technique]:
    inc = ("common/constants.glsl", "sampling/sphere.glsl", "sampling/cone.glsl")
    sin2 = (RADIUS / DIST) ** 2
    cap = 1.0 - RADIUS / DIST     # the visible cap, seen from the origin: cos(angle) >= R/d
    return [
        Technique("sphere-area",
                  "vec3 n = sample_uniform_sphere(lab_uniform2());\n"
                  "f = sphere_irradiance(kCentre + kRadius * n, n) * (4.0 * kPi * kRadius * kRadius);",
                  inc, SPHERE, label="whole sphere by area"),
        Technique("cap-area",
                  # points of the cap facing the origin: n uniform in the cone about -z of
                  # cos >= R/d (an area of 2 pi R^2 (1 - R/d))
                  f"vec3 n = -sample_uniform_cone(lab_uniform2(), {RADIUS / DIST!r});\n"
                  f"f = sphere_irradiance(kCentre + kRadius * n, n) * (2.0 * kPi * kRadius * kRadius * {cap!r});",
                  inc, SPHERE, label="visible cap by area"),
        Technique("cone",
                  f"float cos_max = sqrt(1.0 - {sin2!r});\n"
                  "vec3 w = sample_uniform_cone(lab_uniform2(), cos_max);\n"
                  "f = w.z / uniform_cone_pdf(cos_max);",
                  inc, SPHERE, label="solid angle (cone)"),
    ]


def big_light(scene, scale: float):
    """The scene with each rectangle light ``scale``× larger per side, radiance / scale²."""
    from dataclasses import replace

    shapes = []
    for shape in scene.shapes:
        if shape.emission is not None and shape.kind == "rectangle":
            m = np.asarray(shape.world_from_object, float) @ np.diag([scale, scale, 1.0, 1.0])
            rad = tuple(c / scale ** 2 for c in shape.emission.radiance)
            shape = replace(shape, world_from_object=m,
                            emission=replace(shape.emission, radiance=rad))
        shapes.append(shape)
    return replace(scene, shapes=shapes)


def run(lab) -> Section:
    runs, samples = lab.size((16, 1 << 12), (64, 1 << 16))
    sphere = Table(f"Irradiance from a sphere light (R = {RADIUS}, d = {DIST}): E = π(R/d)²",
                   measure(lab, techniques(), runs, samples, EXACT))
    width, height = lab.size((64, 64), (256, 256))
    rruns, spp = lab.size((6, 32), (16, 64))
    scene = big_light(load_scene("cornell-box", width, height), 3.0)
    labels = {"area": "rectangle by area", "solid-angle": "rectangle by solid angle"}
    renders = render_variants(lab, scene, {k: dict(integrator="direct", strategy="light",
                                                   area_sampling=k) for k in labels}, rruns, spp)
    cornell = region_table("Cornell box, 3× light, direct lighting, light sampling only", renders,
                           labels=labels)
    section = Section(NAME, TITLE, __doc__.split("\n\n", 1)[1], tables=[sphere, cornell])
    for t in (sphere, cornell):
        section.findings += ratio_findings(t, f"{t.title.split(':')[0]}: ")
    bar_figure(lab.figure_path("area_lights_sphere.png"), sphere, "Sphere light: ratios to area sampling")
    _cornell_figure(lab.figure_path("area_lights_cornell.png"), renders, labels)
    section.figures += [("area_lights_sphere.png", "Sphere light: variance, cost and efficiency "
                                                   "relative to sampling the whole sphere by area"),
                        ("area_lights_cornell.png", "Cornell box, light sampling: per-pixel "
                                                    "variance per sample (log₁₀) by area and "
                                                    "by solid angle, and their ratio")]
    return section


def _cornell_figure(path, renders, labels) -> None:
    va, vs = (renders[k].variance.mean(axis=2) for k in labels)
    pair_variance_figure(path, va, vs, tuple(labels.values()),
                         "log₁₀ ratio (< 0: solid angle better)")
