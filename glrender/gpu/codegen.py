"""Generate the GLSL that intersects one scene's compiled primitives.

The output fills the slot ``@scene`` of the render kernels with

    LightData scene_light(uint index);
    MaterialHeader scene_material(uint index);
    bool scene_intersect(vec3 o, vec3 d, float t_max, float time, out SurfaceHit hit);
    bool scene_occluded(vec3 o, vec3 d, float t_max, float time, uint ignore);

Compiled primitives (parallelograms, planar triangles, spheres) are written out as
constants, so each costs a handful of selects per ray and no memory traffic;
the hit record is assembled as the loop goes (no switch over primitive ids, which
llvmpipe would run in full for every ray). Meshes go through the BVH.
``time`` is the normalized shutter time in [0, 1] (moving spheres lerp their centre).
"""
from __future__ import annotations

import numpy as np

from ..scene.model import point_bounds
from .pack import PackedScene

GENERATED_PATH = "generated/scene.glsl"
# Scenes with at most this many lights get them as constants (a select chain the
# compiler folds; a single light becomes pure constants): an SSBO gather of a whole
# LightData per light sample measured slower on llvmpipe.
MAX_CONSTANT_LIGHTS = 8
# Likewise for material headers (scene/layout.glsl MaterialHeader).
MAX_CONSTANT_MATERIALS = 8


def _f(x: float) -> str:
    v = float(np.float32(x))
    if v == 0.0:
        return "0.0"
    text = repr(v)
    return text if ("." in text or "e" in text) else text + ".0"


def _v3(v) -> str:
    return f"vec3({_f(v[0])}, {_f(v[1])}, {_f(v[2])})"


def _v2(v) -> str:
    return f"vec2({_f(v[0])}, {_f(v[1])})"


def _dpdu(q) -> np.ndarray:
    """dp/du of a planar primitive p = corner + a e1 + b e2 whose uv = uv0 + a uv_a + b uv_b
    (uv = (a, b) without a uv map); zero when the uv map is singular."""
    if q.uv is None:
        return np.asarray(q.e1, np.float64)
    J = np.array([q.uv[1], q.uv[2]], np.float64).T          # d(u, v) / d(a, b)
    if np.linalg.det(J) == 0:
        return np.zeros(3)
    return np.column_stack([q.e1, q.e2]) @ np.linalg.inv(J)[:, 0]


def has_normal_maps(packed: PackedScene) -> bool:
    """Whether a material has a normal map (MaterialData.normal_map: its texture + 1)."""
    return bool(len(packed.materials) and (packed.materials["normal_map"] > 0).any())


def has_normal_shadowing(packed: PackedScene) -> bool:
    """Whether a normal-mapped material asks for the shadowing term (MATERIAL_FLAG_NORMAL_SHADOWING
    in MaterialData.info.y); the renderer then compiles with GLRENDER_NORMAL_SHADOWING."""
    from . import bindings

    return bool(len(packed.materials) and
                (packed.materials["info"][:, 1] & bindings.MATERIAL_FLAG_NORMAL_SHADOWING).any())


def has_alpha_cutouts(packed: PackedScene) -> bool:
    """Whether a material has an opacity texture (MaterialData.opacity_texture: its texture + 1);
    the renderer then compiles with GLRENDER_ALPHA_CUTOUTS, and BVH traversal asks
    bvh_alpha_pass below about each triangle hit."""
    return bool(len(packed.materials) and (packed.materials["opacity_texture"] > 0).any())


def has_metallic_roughness(packed: PackedScene) -> bool:
    """Whether a material is of the metallicroughness kind (its BSDF chosen per texel); the
    renderer then compiles with GLRENDER_METALLIC_ROUGHNESS."""
    return "metallicroughness" in packed.material_kinds


def has_emission_textures(packed: PackedScene) -> bool:
    """Whether an area light has an emission texture (LightData.emission_texture: its
    texture + 1); the renderer then compiles with GLRENDER_EMISSION_TEXTURES."""
    return bool(len(packed.lights) and (packed.lights["emission_texture"] > 0).any())


_ALPHA_PASS = [
    "bool bvh_alpha_pass(uint tri, vec2 bary) {",
    "    MaterialHeader m = scene_material(tri_info_texel(int(tri), 0).x);",
    "    uint tex = uint(m.opacity_texture);",
    "    if (tex == 0u) return true;",
    "    vec4 uv01 = tri_uv_texel(2 * int(tri), 0);",
    "    vec2 uv2 = tri_uv_texel(2 * int(tri), 1).xy;",
    "    vec2 uv = (1.0 - bary.x - bary.y) * uv01.xy + bary.x * uv01.zw + bary.y * uv2;",
    "    return opacity_at(tex - 1u, uv) >= m.alpha_cutoff;",
    "}",
    "",
]


def _aligned_axis(q) -> int | None:
    """The coordinate axis a parallelogram's plane is perpendicular to, if any (exactly)."""
    n = np.cross(q.e1, q.e2)
    nz = np.flatnonzero(np.abs(n) > 0)
    if q.triangle or len(nz) != 1 or np.any(q.e1[nz] != 0) or np.any(q.e2[nz] != 0):
        return None
    return int(nz[0])


def _planar_call(q, t_max: str) -> str:
    """The GLSL call intersecting one compiled planar primitive."""
    axis = _aligned_axis(q)
    if axis is not None:
        c = "xyz"[axis]
        n = np.cross(q.e1, q.e2)
        nn = float(np.dot(n, n))
        dual_a, dual_b = np.cross(q.e2, n) / nn, np.cross(n, q.e1) / nn
        return (f"intersect_parallelogram_aligned(o.{c}, inv_d.{c}, {_f(q.corner[axis])}, o, d, {t_max}, "
                f"{_v3(q.corner)}, {_v3(dual_a)}, {_v3(dual_b)}, ab)")
    fn = "intersect_triangle_planar" if q.triangle else "intersect_parallelogram"
    return f"{fn}(o, d, {t_max}, {_planar_args(q)}, ab)"


def _planar_args(q) -> str:
    n = np.cross(q.e1, q.e2)
    nn = float(np.dot(n, n))
    dual_a = np.cross(q.e2, n) / nn
    dual_b = np.cross(n, q.e1) / nn
    return (f"{_v3(n)}, {_f(np.dot(n, q.corner))}, {_v3(q.corner)}, "
            f"{_v3(dual_a)}, {_v3(dual_b)}")


def _struct_fields(records) -> tuple[str, ...]:
    """The fields of a MaterialData or LightData record that its GLSL header struct holds,
    in order: every one but the roughplastic table."""
    return tuple(name for name in records.dtype.names if name != "table")


def _struct_literal(struct: str, rec, fields) -> str:
    """A GLSL constructor call for one numpy record: float and vecN fields, the uvec4 info."""
    args = []
    for name in fields:
        value = rec[name]
        if name == "info":
            args.append(f"uvec4({', '.join(f'{int(x)}u' for x in value)})")
        elif np.ndim(value) == 0:
            args.append(_f(value))
        else:
            args.append(f"vec{len(value)}({', '.join(_f(x) for x in value)})")
    return f"{struct}({', '.join(args)})"


def _record_accessor(struct: str, name: str, records, fields, limit: int, fallback: str) -> list[str]:
    """``struct name(uint index)``: a select chain over constants for at most ``limit``
    records (the compiler folds the fields they share), else ``fallback`` (a buffer read)."""
    lines = [f"// {struct} records (see scene/layout.glsl).", f"{struct} {name}(uint index) {{"]
    if 0 < len(records) <= limit:
        lines.append(f"    {struct} r = {_struct_literal(struct, records[0], fields)};")
        for k in range(1, len(records)):
            lines.append(f"    if (index == {k}u) r = {_struct_literal(struct, records[k], fields)};")
        lines.append("    return r;")
    else:
        lines.append(f"    return {fallback};")
    return lines + ["}", ""]


def generate_lights(lights) -> list[str]:
    """``LightData scene_light(uint index)``: constants for a few lights, else the SSBO."""
    return _record_accessor("LightData", "scene_light", lights, _struct_fields(lights),
                            MAX_CONSTANT_LIGHTS, "lights[index]")


def generate_materials(materials) -> list[str]:
    """``MaterialHeader scene_material(uint index)``: constants for a few materials."""
    fields = _struct_fields(materials)
    fallback = f"MaterialHeader({', '.join(f'materials[index].{name}' for name in fields)})"
    return _record_accessor("MaterialHeader", "scene_material", materials, fields,
                            MAX_CONSTANT_MATERIALS, fallback)


def _mesh_box(packed: PackedScene):
    """World box of every BVH triangle (over the shutter for moving meshes), grown by a
    relative margin for float32 rounding; None when there is nothing to bound."""
    points = []
    if packed.mesh_bounds is not None:
        points.append(np.stack(packed.mesh_bounds))
    for mm in packed.moving_meshes:
        from ..accel.instances import MotionInstance, motion_bounds

        obj = mm.positions.reshape(-1, 3)
        inst = MotionInstance(obj, np.arange(len(obj)).reshape(-1, 3), mm.world_from_object_open,
                              mm.world_from_object_close)
        lo, hi = motion_bounds(inst, obj.min(axis=0), obj.max(axis=0))
        points.append(np.stack([lo, hi]))
    for im in packed.instanced_meshes:
        points.append(np.concatenate(im.world_bounds()))
    if not points:
        return None
    lo, hi = point_bounds(np.concatenate(points))
    pad = 1e-5 * (np.abs(lo) + np.abs(hi) + (hi - lo)) + 1e-30
    return lo - pad, hi + pad


def _instanced_query(moving: bool) -> list[str]:
    """``scene_bvh_query``: the static (and moving) meshes' trees, then the static instances
    (geometry/instances.glsl); inst is the instance hit, or kNoInstance."""
    base = ("bvh_traverse_t(o, d, t_max, time, any_hit, bh)" if moving
            else "bvh_traverse(0u, o, d, t_max, any_hit, bh)")
    return [
        "bool scene_bvh_query(vec3 o, vec3 d, float t_max, float time, const bool any_hit, "
        "out BvhHit bh, out uint inst) {",
        "    inst = kNoInstance;",
        f"    bool found = {base};",
        "    if (bh.prim == kBvhStackOverflow || (any_hit && found)) return found;",
        "    return instances_traverse(o, d, any_hit, bh, inst) || found;",
        "}",
        "",
    ]


def generate(packed: PackedScene, has_bvh: bool, lights=None) -> str:
    lines = [
        f"// Scene geometry: {len(packed.quads)} planar primitives, {len(packed.spheres)} spheres, "
        f"BVH: {'yes' if has_bvh else 'no'}.",
        '#include "geometry/surface.glsl"',
        '#include "geometry/parallelogram.glsl"',
        '#include "geometry/sphere.glsl"',
        '#include "geometry/box.glsl"',
        '#include "common/constants.glsl"',
        '#include "scene/layout.glsl"',
    ]
    moving = bool(packed.moving_meshes)
    instanced = bool(packed.instanced_meshes)
    if has_bvh:
        lines += ['#include "geometry/bvh.glsl"', '#include "geometry/mesh_surface.glsl"']
    if moving:
        lines += ['#include "geometry/mesh_surface_motion.glsl"']
    if instanced:
        lines += ['#include "geometry/instances.glsl"']
    n_compiled = len(packed.quads) + len(packed.spheres)
    lines += generate_lights(packed.lights if lights is None else lights)
    lines += generate_materials(packed.materials)
    lines += [f"const uint kCompiledPrimitives = {n_compiled}u;",
              f"const bool kSceneHasBvh = {'true' if has_bvh else 'false'};", ""]

    # -- closest hit -------------------------------------------------------------
    body = [
        "bool scene_intersect(vec3 o, vec3 d, float t_max, float time, out SurfaceHit hit) {",
        "    float t = t_max;",
        "    uint prim = kNoPrimitive;",
        "    vec3 ng = vec3(0.0, 0.0, 1.0);",
        "    vec3 ns = ng;",
        "    vec2 uv = vec2(0.0);",
        "    vec3 dpdu = vec3(0.0);",
        "    uint material = 0u;",
        "    uint light = 0u;",
        "    vec4 sphere = vec4(0.0);  // centre and signed radius of the nearest sphere hit",
        "    float plane = 0.0;        // dot(ng, corner) of the nearest planar hit",
        "    vec3 p = vec3(0.0);",
        "    vec2 ab;",
        "    float tq;",
        "    vec3 inv_d = 1.0 / d;",
    ]
    for k, q in enumerate(packed.quads):
        if q.uv is not None:
            uv = f"{_v2(q.uv[0])} + ab.x * {_v2(q.uv[1])} + ab.y * {_v2(q.uv[2])}"
        else:
            uv = "ab"
        body += [
            f"    tq = {_planar_call(q, 't')};",
            f"    if (tq < t) {{ t = tq; prim = {k}u; ng = {_v3(q.normal)}; uv = {uv}; dpdu = {_v3(_dpdu(q))}; "
            f"plane = {_f(np.dot(q.normal, q.corner))}; "
            f"material = {q.material}u; light = {q.light}u; sphere.w = 0.0; }}",
        ]
    for j, s in enumerate(packed.spheres):
        k = len(packed.quads) + j
        center = _v3(s.center) if s.center_close is None else \
            f"mix({_v3(s.center)}, {_v3(s.center_close)}, time)"
        signed_r = -s.radius if s.flip else s.radius
        body += [
            f"    {{ vec3 c = {center};",
            f"      tq = intersect_sphere(o, d, t, c, {_f(s.radius)});",
            f"      if (tq < t) {{ t = tq; prim = {k}u; sphere = vec4(c, {_f(signed_r)}); "
            f"material = {s.material}u; light = {s.light}u; }} }}",
        ]
    box = _mesh_box(packed) if has_bvh else None
    box_test = (f"ray_meets_box(o, inv_d, {_v3(box[0])}, {_v3(box[1])}, {{}})" if box is not None
                else "true")
    closest = 'bvh_intersect_closest_t(o, d, t, time, bh)' if moving else 'bvh_intersect_closest(o, d, t, bh)'
    if instanced:
        closest = 'scene_bvh_query(o, d, t, time, false, bh, inst)'
        lines += _instanced_query(moving)
    if has_bvh:
        body += [
            "    BvhHit bh;",
            *(["    uint inst = kNoInstance;"] if instanced else []),
            "#if GLRENDER_WAVE_BVH_HITS",
            "    // the wavefront's extend stage traced the BVH already (kernels/wavefront.comp.glsl)",
            "    if (wave_bvh_hit(t, bh)) {",
            "#else",
            f"    if ({box_test.format('t')} && {closest}) {{",
            "#endif",
            "        t = bh.t;",
            "        prim = kCompiledPrimitives + bh.prim;",
            f"        {'mesh_surface_t(bh.prim, bh.bary, time, p, ng, ns, uv, material, light, dpdu)' if moving else 'mesh_surface(bh.prim, bh.bary, p, ng, ns, uv, material, light, dpdu)'};",
            *(["        if (inst != kNoInstance) instance_surface(inst, p, ng, ns, dpdu);"] if instanced else []),
            "        sphere.w = 0.0;",
            "    }",
        ]
    body += [
        "    if (prim == kNoPrimitive) return false;",
        "    if (prim < kCompiledPrimitives) {",
        "        p = o + t * d;",
        "        if (sphere.w != 0.0) {",
        "            // back onto the sphere; Mitsuba's uv: u = atan2(y, x) / 2 pi in [0, 1), v = theta / pi",
        "            vec3 local = normalize(p - sphere.xyz);",
        "            p = sphere.xyz + abs(sphere.w) * local;",
        "            ng = local * sign(sphere.w);",
        "            float u = atan(local.y, local.x) * kInvTwoPi;",
        "            uv = vec2(u < 0.0 ? u + 1.0 : u, atan(length(local.xy), local.z) * kInvPi);",
        "            dpdu = vec3(-local.y, local.x, 0.0);   // Mitsuba's, up to its length 2 pi r",
        "        } else {",
        "            p -= (dot(ng, p) - plane) * ng;   // back onto the plane",
        "        }",
        "        ns = ng;",
        "    }",
        "    hit = SurfaceHit(t, p, ng, ns, uv, material, light, prim, dpdu, ns);",
    ]
    normal_maps, cutouts = has_normal_maps(packed), has_bvh and has_alpha_cutouts(packed)
    if normal_maps:
        body += ["    apply_normal_map(hit, scene_material(material), d);"]
    body += [
        "    return true;",
        "}",
        "",
    ]
    if normal_maps or cutouts:
        lines += ['#include "bsdf/normal_map.glsl"']
    if cutouts:
        lines += _ALPHA_PASS
    lines += body

    # -- any hit -------------------------------------------------------------------
    occ = ["// Any hit in (0, t_max), ignoring primitive `ignore` (the light a shadow ray aims at:",
           "// a segment to a point of a convex emitter cannot meet it before that point, and",
           "// testing it anyway loses grazing rays to rounding).",
           "bool scene_occluded(vec3 o, vec3 d, float t_max, float time, uint ignore) {",
           "    float t = t_max;  // min over primitives: no short-circuit branches",
           "    vec2 ab;",
           "    vec3 inv_d = 1.0 / d;"]
    for k, q in enumerate(packed.quads):
        test = _planar_call(q, "t_max")
        occ.append(f"    t = min(t, {test if not q.light else f'ignore == {k}u ? t_max : {test}'});")
    for j, s in enumerate(packed.spheres):
        k = len(packed.quads) + j
        center = _v3(s.center) if s.center_close is None else \
            f"mix({_v3(s.center)}, {_v3(s.center_close)}, time)"
        test = f"intersect_sphere(o, d, t_max, {center}, {_f(s.radius)})"
        occ.append(f"    t = min(t, {test if not s.light else f'ignore == {k}u ? t_max : {test}'});")
    occ.append("    if (t < t_max) return true;")
    if has_bvh:
        any_hit = 'bvh_intersect_any_t(o, d, t_max, time)' if moving else 'bvh_intersect_any(o, d, t_max)'
        if instanced:
            occ += ["    BvhHit bh;", "    uint inst;"]
            any_hit = 'scene_bvh_query(o, d, t_max, time, true, bh, inst)'
        occ.append(f"    return {box_test.format('t_max')} && {any_hit};")
    else:
        occ.append("    return false;")
    occ += ["}", ""]
    lines += occ

    # -- the wavefront's bin key ---------------------------------------------------
    lines += ["// Whether the ray o + t d, t in (0, t_max), may meet a BVH mesh (its box): the",
              "// wavefront executor bins rays by it, so that the rays a vector traverses together",
              "// all enter the BVH (kernels/wavefront.comp.glsl).",
              "bool scene_meets_meshes(vec3 o, vec3 d, float t_max) {"]
    if has_bvh:
        lines += ["    vec3 inv_d = 1.0 / d;", f"    return {box_test.format('t_max')};"]
    else:
        lines += ["    return false;"]
    lines += ["}", ""]
    if has_bvh:
        lines += ["// The nearest BVH triangle alone (the wavefront's extend stage).",
                  "bool scene_bvh_closest(vec3 o, vec3 d, float t_max, float time, out BvhHit bh) {",
                  f"    return {'bvh_intersect_closest_t(o, d, t_max, time, bh)' if moving else 'bvh_intersect_closest(o, d, t_max, bh)'};",
                  "}", ""]
    else:
        lines += ["#if GLRENDER_WAVEFRONT", "// No BVH: the wavefront's extend stage has nothing to trace.",
                  "bool scene_bvh_closest(vec3 o, vec3 d, float t_max, float time, out BvhHit bh) {",
                  "    bh = BvhHit(t_max, kBvhNoHit, vec2(0.0));", "    return false;", "}", "#endif", ""]
    return "\n".join(lines)
