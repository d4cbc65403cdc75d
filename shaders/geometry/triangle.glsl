// Watertight ray-triangle intersection (Woop, Benthin & Wald 2013, JCGT 2(1)).
//
// Vertices are translated to the ray origin, permuted so the ray's dominant axis
// is z, and sheared so the ray becomes the +z axis; the hit test is then the sign
// of three 2D edge functions. Each vertex is transformed by the same operations
// whichever triangle it belongs to, and an edge function of a shared edge is the
// exact negation of its neighbour's (`precise`: no fused multiply-add), so a ray
// through an edge or a vertex of a closed mesh always hits at least one triangle.

// Per-ray constants of the watertight test.
struct WatertightRay {
    vec3 o;
    ivec3 k;      // axis permutation (kx, ky, kz): kz = dominant axis of d
    vec3 shear;   // (Sx, Sy, Sz) = (dx / dz, dy / dz, 1 / dz) in permuted axes
};

// Prepares the test for a ray o + t d; d must be nonzero (need not be normalized).
WatertightRay make_watertight_ray(vec3 o, vec3 d) {
    vec3 ad = abs(d);
    int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0) {  // keep the winding (and so the sign of det) of the triangle
        int k = kx;
        kx = ky;
        ky = k;
    }
    float dz = d[kz];
    return WatertightRay(o, ivec3(kx, ky, kz), vec3(d[kx] / dz, d[ky] / dz, 1.0 / dz));
}

// The vertex p in the ray's sheared frame: (x, y) on the ray's image plane, z
// scaled so that the hit distance is an affine combination of the z's.
vec3 watertight_vertex(WatertightRay r, vec3 p) {
    precise vec3 a = p - r.o;
    precise float az = a[r.k.z];
    precise float x = a[r.k.x] - r.shear.x * az;
    precise float y = a[r.k.y] - r.shear.y * az;
    return vec3(x, y, r.shear.z * az);
}

// Intersects the ray with triangle (v0, v1, v2), both faces, in two steps so that
// the division runs only for candidates: watertight_candidate tests the edge
// functions and the distance against (0, t_max) scaled by the determinant, and
// returns (u, v, w, t det) of a candidate; watertight_resolve divides. A hit is a
// candidate that resolve accepts: distance t in (0, t_max), bary = barycentrics
// (b1, b2) of v1 and v2 (the hit point is (1 - b1 - b2) v0 + b1 v1 + b2 v2).
bool watertight_candidate(WatertightRay r, vec3 v0, vec3 v1, vec3 v2, float t_max,
                          out vec4 uvwt) {
    vec3 a = watertight_vertex(r, v0);
    vec3 b = watertight_vertex(r, v1);
    vec3 c = watertight_vertex(r, v2);
    precise float u = c.x * b.y - c.y * b.x;
    precise float v = a.x * c.y - a.y * c.x;
    precise float w = b.x * a.y - b.y * a.x;
    float det = u + v + w;
    float t_det = u * a.z + v * b.z + w * c.z;
    uvwt = vec4(u, v, w, t_det);
    bool inside = !((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0));
    // t = t_det / det in (0, t_max), by the sign of det (det == 0 fails both)
    float limit = t_max * det;
    return inside && (det > 0.0 ? (t_det > 0.0 && t_det < limit)
                                : (det < 0.0 && t_det < 0.0 && t_det > limit));
}

bool watertight_resolve(vec4 uvwt, float t_max, out float t, out vec2 bary) {
    float inv_det = 1.0 / (uvwt.x + uvwt.y + uvwt.z);
    t = uvwt.w * inv_det;
    bary = uvwt.yz * inv_det;
    return t > 0.0 && t < t_max;
}
