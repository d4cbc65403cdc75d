"""Host side of ``shaders/common/params.glsl``: the compile-time configuration.

Every define that params.glsl requires is produced here and nowhere else; the switches it
takes when present (``OPTIONAL_DEFINES``) are added by the renderer for the scenes that need
them, and by tests. No shader file tests any other host macro (tests/gpu/test_params.py).
"""
from __future__ import annotations

from ..gpu import layout
from ..sampling.sequences import SAMPLERS

STRATEGIES = {"light": 0, "bsdf": 1, "mis-balance": 2, "mis-power": 3}
LIGHT_SELECTION = {"uniform": 0, "power": 1, "bvh": 2}
#: light records (an emitting mesh's triangles each) from which ``light_selection = "auto"``
#: chooses lights by power instead of uniformly (benchmarks/light_selection.py: power selection
#: measured 1.1-4.2x uniform's efficiency from 97 records on, 0.3-0.9x with 25 or fewer)
AUTO_POWER_LIGHTS = 64


def choose_light_selection(selection: str, light_count: int) -> str:
    """The light selection a render uses: ``selection`` itself, or for ``auto`` uniform
    below AUTO_POWER_LIGHTS light records and power from there on. The light BVH is chosen
    only on request: it measured far better than power selection on the many-lights city
    (8-16x) but not on open streets of 97 to 1,537 lights (0.48-0.67x by the image's MSE,
    0.79-1.56x by the median pixel), so the light count alone does not tell where it wins
    (benchmarks/RESULTS.md, "Light selection by scene")."""
    if selection != "auto":
        return selection
    return "power" if light_count >= AUTO_POWER_LIGHTS else "uniform"
AREA_SAMPLING = {"area": 0, "solid-angle": 1}
FILTERS = {"box": 0, "tent": 1, "gaussian": 2, "mitchell": 3}
RR_RULES = {"throughput": 0, "fixed": 1, "off": 2}
#: the switches params.glsl defaults to 0 (the BVH depth: to 31, the parts: to 1) when the host
#: leaves them out
OPTIONAL_DEFINES = {
    "GLRENDER_NORMAL_SHADOWING": "a material's normal map has the shadowing term",
    "GLRENDER_ALPHA_CUTOUTS": "opacity textures cut holes into mesh triangles",
    "GLRENDER_STRATEGY_DEPTH": "bdpt keeps each strategy's image up to this path length",
    "GLRENDER_BVH_MAX_DEPTH": "the deepest BVH the traversal stack holds (tests lower it)",
    "GLRENDER_BDPT_GENERIC_WEIGHTS": "test only: bdpt evaluates every MIS density afresh",
    "GLRENDER_METALLIC_ROUGHNESS": "a metallic-roughness material picks its BSDF per texel",
    "GLRENDER_EMISSION_TEXTURES": "an area light's radiance varies with a texture",
    "GLRENDER_WAVEFRONT": "the path tracer runs as the wavefront executor's stages",
    "GLRENDER_WAVE_STAGE": "which stage of the wavefront executor the program is",
    "GLRENDER_WAVE_BVH_HITS": "the scene's closest hit takes the extend stage's BVH hit",
    "GLRENDER_COOP_LANES": "8-wide traversal: cooperative when at most this many lanes have rays",
    "GLRENDER_VCM_MODE": "vertex connection and merging: 1 connections and merges, 2 merges alone",
    "GLRENDER_VCM_CACHE": "vcm: connections per camera vertex to a light vertex cache (0: none)",
    "GLRENDER_SHARED_TIME": "every sample of a pass takes one shutter time (vcm with motion)",
    "GLRENDER_MEDIA": "shapes or the camera name participating media",
    # geometry/bvh_layout.glsl, from glrender/gpu/bvh_upload.py: the geometry textures' parts
    "GLRENDER_GEOMETRY_PART_TEXELS": "texels of each part of a geometry texture cut into parts",
    "GLRENDER_BVH_NODE_PARTS": "buffer textures the BVH nodes span (1 when absent)",
    "GLRENDER_BVH_TRIANGLE_PARTS": "buffer textures the triangle corners span (1 when absent)",
    "GLRENDER_TRI_NORMAL_PARTS": "buffer textures the vertex normals span (1 when absent)",
    "GLRENDER_TRI_UV_PARTS": "buffer textures the texture coordinates span (1 when absent)",
    "GLRENDER_TRI_INFO_PARTS": "buffer textures the triangles' material records span (1 when absent)",
}


def kind_mask(kinds, table: dict[str, int]) -> int:
    mask = 0
    for kind in kinds:
        mask |= 1 << table[kind]
    return mask


def shader_defines(*, sampler: str = "independent", material_kinds=("diffuse",),
                   light_kinds=(), max_depth: int = -1, rr_depth: int | None = None,
                   rr: str | None = None, light_samples: int = 1, split: int = 1,
                   strategy: str | None = None, emitter_samples: int = 1, bsdf_samples: int = 1,
                   hide_emitters: bool = False, light_selection: str | None = None,
                   area_sampling: str | None = None, filter: str = "box", aovs: bool = False,
                   count_loops: bool = False, count_rays: bool = False,
                   debug_nonfinite: int = 0, emission_only: bool = False) -> dict[str, object]:
    """The full define set for params.glsl (defaults suit unit tests of shader code).
    ``rr``: the Russian roulette rule, ``throughput``, ``fixed:<q>`` or ``off``. The
    integrator settings left None take the scene model's defaults (:class:`Integrator`):
    one fact for the shaders' unit tests and the renderer."""
    from ..scene.model import Integrator, parse_rr

    default = Integrator()
    rr_depth = default.rr_depth if rr_depth is None else rr_depth
    strategy = default.strategy if strategy is None else strategy
    light_selection = default.light_selection if light_selection is None else light_selection
    # (a renderer chooses for auto from the scene's lights; a shader test has none)
    light_selection = choose_light_selection(light_selection, 0)
    area_sampling = default.area_sampling if area_sampling is None else area_sampling
    rule, survival = parse_rr(default.rr if rr is None else rr)
    return {
        "GLRENDER_SAMPLER": SAMPLERS[sampler],
        "GLRENDER_MATERIAL_KINDS": kind_mask(material_kinds, layout.MATERIAL_KINDS),
        "GLRENDER_LIGHT_KINDS": kind_mask(light_kinds, layout.LIGHT_KINDS),
        "GLRENDER_MAX_DEPTH": int(max_depth),
        "GLRENDER_RR_DEPTH": int(rr_depth),
        "GLRENDER_RR_RULE": RR_RULES[rule],
        "GLRENDER_RR_SURVIVAL": float(survival),
        "GLRENDER_LIGHT_SAMPLES": int(light_samples),
        "GLRENDER_SPLIT": int(split),
        "GLRENDER_STRATEGY": STRATEGIES[strategy],
        "GLRENDER_EMITTER_SAMPLES": int(emitter_samples),
        "GLRENDER_BSDF_SAMPLES": int(bsdf_samples),
        "GLRENDER_HIDE_EMITTERS": bool(hide_emitters),
        "GLRENDER_LIGHT_SELECTION": LIGHT_SELECTION[light_selection],
        "GLRENDER_AREA_SAMPLING": AREA_SAMPLING[area_sampling],
        "GLRENDER_FILTER": FILTERS[filter],
        "GLRENDER_AOVS": bool(aovs),
        "GLRENDER_COUNT_LOOPS": bool(count_loops),
        "GLRENDER_COUNT_RAYS": bool(count_rays),
        "GLRENDER_DEBUG_NONFINITE": int(debug_nonfinite),
        "GLRENDER_EMISSION_ONLY": bool(emission_only),
    }
