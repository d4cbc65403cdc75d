// What a ray hit: the surface record every scene intersection routine returns.

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
};
