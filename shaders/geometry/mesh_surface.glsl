// The surface record of a BVH triangle hit: normals, texture coordinates, material, light.
//
// Shading data lives in per-triangle buffer textures in BVH order (geometry/bvh_layout.glsl).
// As in Mitsuba, the geometric normal is flipped to the side of the interpolated
// shading normal, so that vertex normals decide which side of a mesh is its front.
#include "geometry/bvh.glsl"
#include "scene/layout.glsl"

// p: the hit point from the barycentrics (rounding error relative to the vertices).
// dpdu: from the triangle's uv as Mitsuba's meshes (zero for a triangle of zero uv area).
void mesh_surface(uint tri, vec2 bary, out vec3 p, out vec3 ng, out vec3 ns, out vec2 uv,
                  out uint material, out uint light, out vec3 dpdu) {
    vec3 p0 = bvh_triangle_vertex(tri, 0u);
    vec3 p1 = bvh_triangle_vertex(tri, 1u);
    vec3 p2 = bvh_triangle_vertex(tri, 2u);
    ng = normalize(cross(p1 - p0, p2 - p0));
    float b0 = 1.0 - bary.x - bary.y;
    p = b0 * p0 + bary.x * p1 + bary.y * p2;
    int base = 3 * int(tri);
    vec3 n = b0 * tri_normal_texel(base, 0).xyz + bary.x * tri_normal_texel(base, 1).xyz +
             bary.y * tri_normal_texel(base, 2).xyz;
    float len = length(n);
    ns = len > 0.0 ? n / len : ng;
    ng = dot(ng, ns) < 0.0 ? -ng : ng;
    vec4 uv01 = tri_uv_texel(2 * int(tri), 0);
    vec2 uv2 = tri_uv_texel(2 * int(tri), 1).xy;
    uv = b0 * uv01.xy + bary.x * uv01.zw + bary.y * uv2;
    vec2 duv1 = uv01.zw - uv01.xy, duv2 = uv2 - uv01.xy;
    float det = duv1.x * duv2.y - duv1.y * duv2.x;
    dpdu = det != 0.0 ? ((p1 - p0) * duv2.y - (p2 - p0) * duv1.y) / det : vec3(0.0);
    uvec4 info = tri_info_texel(int(tri), 0);
    material = info.x;
    light = info.y;
}

