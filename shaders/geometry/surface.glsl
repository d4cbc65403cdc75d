// What a ray hit: the surface record every scene intersection routine returns.
#include "common/frame.glsl"

const uint kNoPrimitive = 0xffffffffu;

// The nearest hit of a ray. Normals are unit length and as modelled (not flipped
// toward the ray); the shading normal ns may differ from the geometric one.
struct SurfaceHit {
    float t;        // ray parameter of the hit
    vec3 p;         // the hit point, from the primitive (not o + t d: its rounding error grows
                    // with |o| and t, and would put points behind surfaces near the origin)
    vec3 ng;        // geometric normal
    vec3 ns;        // shading normal
    vec2 uv;        // texture coordinates
    uint material;  // index into materials[]
    uint light;     // index + 1 into lights[] of the area light on this surface, 0 if none
    uint prim;      // primitive id (compiled primitives first, then BVH triangles)
    vec3 dpdu;      // dp/du, the surface's tangent along u (not unit; zero where uv give none)
    vec3 ns0;       // the shading normal before a normal map replaced ns (ns without one)
};

// True while the rays traced are a light path's (importance transport): a normal map's
// flip of invalid normals, which Mitsuba decides by the direction toward the camera's side,
// is then not applied (bsdf/normal_map.glsl apply_normal_map).
bool g_light_path_rays = false;

// The shading frame of a hit: z = the shading normal, x = dp/du made orthogonal to it, as
// Mitsuba's SurfaceInteraction::initialize_sh_frame, so that anisotropic roughness (alpha_u
// along x) follows the surface's u direction. Without a usable dp/du, any frame around z.
Frame shading_frame(SurfaceHit hit) {
    vec3 s = hit.dpdu - hit.ns * dot(hit.ns, hit.dpdu);
    float len2 = dot(s, s);
    if (!(len2 > 1e-10 * dot(hit.dpdu, hit.dpdu))) return frame_from_z(hit.ns);
    vec3 x = s * inversesqrt(len2);
    return Frame(x, cross(hit.ns, x), hit.ns);
}
