// Surface detail from textures: tangent-space normal maps and opacity cutouts.
//
// Normal maps follow glTF 2.0 (and OpenGL): a texel c holds n = 2 c - 1 in the frame
// x = dp/du (made orthogonal to the shading normal), y = n x x, z = the shading normal
// (geometry/surface.glsl shading_frame, Mitsuba's frame), so +Y points up the image
// for uv maps that are not mirrored. The material's scale multiplies n.x and n.y
// (glTF normalTexture.scale). The texture must be stored raw (no sRGB decode).
//
// Opacity is the mean of a texture's RGB; the BVH traversal treats a triangle hit
// whose opacity falls below the material's cutoff as a hole (glTF alphaMode MASK).
#include "bsdf/bsdf_common.glsl"
#include "bsdf/texture.glsl"
#include "geometry/surface.glsl"
#include "scene/layout.glsl"

// Replaces hit.ns by the normal map's normal (MaterialHeader.normal_map: texture + 1,
// normal_scale: its strength) for a ray arriving along d; hits of materials without one are left
// alone, and so is hit.ns0, the normal before the map. A map normal that is not finite
// leaves the hit alone too. With kMaterialFlagNormalFlip (Mitsuba's flip_invalid_normals)
// a map normal that puts -d below its horizon while -d is above the unperturbed one's
// is turned half way round the unperturbed normal (n.x, n.y negated in its frame), as
// Mitsuba 3 does for the direction toward the previous vertex (Schuessler et al. 2017).
// That direction is the camera's side on camera paths only: Mitsuba's light tracer flips
// for the light's side, which is not the adjoint of its path tracer's BSDF (+6% on the
// parity panel). Light paths (g_light_path_rays) keep the map normal as it is instead:
// the path tracer's BSDF wherever the direction toward the camera's side needs no flip;
// where it would, a light path misses the light the flip sends on.
void apply_normal_map(inout SurfaceHit hit, MaterialHeader m, vec3 d) {
    uint tex = uint(m.normal_map);
    if (tex == 0u) return;
    vec3 c = texture_eval(tex - 1u, hit.uv) * 2.0 - 1.0;
    c.xy *= m.normal_scale;
    Frame f = shading_frame(hit);
    vec3 n = c.x * f.x + c.y * f.y + c.z * f.z;
    if ((m.info.y & kMaterialFlagNormalFlip) != 0u && !g_light_path_rays && dot(d, f.z) * dot(d, n) <= 0.0)
        n = c.z * f.z - c.x * f.x - c.y * f.y;
    float len = length(n);
    if (len > 0.0 && !isinf(len)) hit.ns = n / len;
}

// The opacity of texture `index` at uv: the mean of its RGB.
float opacity_at(uint index, vec2 uv) {
    vec3 c = texture_eval(index, uv);
    return (c.r + c.g + c.b) * (1.0 / 3.0);
}
