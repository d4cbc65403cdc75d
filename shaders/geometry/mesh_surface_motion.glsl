// The surface record of a BVH triangle hit in a scene with moving meshes.
//
// Triangles of a motion instance (geometry/motion.glsl) are stored in object space:
// the hit's geometric normal comes from the triangle moved to the hit's time, and its
// shading normal is turned by the inverse transpose of the instance's transform,
// R S^-1 (R a rotation, S the symmetric scale/shear).
#include "geometry/mesh_surface.glsl"
#include "geometry/motion.glsl"

void mesh_surface_t(uint tri, vec2 bary, float time, out vec3 p, out vec3 ng, out vec3 ns,
                    out vec2 uv, out uint material, out uint light, out vec3 dpdu) {
    mesh_surface(tri, bary, p, ng, ns, uv, material, light, dpdu);
    int i = motion_instance_of(tri);
    if (i < 0) return;
    vec3 translation;
    mat3 rotation, scale;
    motion_transform(i, time, translation, rotation, scale);
    p = translation + rotation * (scale * p);
    dpdu = rotation * (scale * dpdu);
    mat3 normal_matrix = rotation * inverse(scale);
    ng = normalize(normal_matrix * ng);
    ns = normalize(normal_matrix * ns);
    ng = dot(ng, ns) < 0.0 ? -ng : ng;
}
