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

// Intersects the ray with triangle (v0, v1, v2), both faces.
// Returns true for a hit at distance t in (0, t_max); bary = barycentrics (b1, b2)
// of v1 and v2 (the hit point is (1 - b1 - b2) v0 + b1 v1 + b2 v2).
bool intersect_triangle_watertight(WatertightRay r, vec3 v0, vec3 v1, vec3 v2, float t_max,
                                   out float t, out vec2 bary) {
    vec3 a = watertight_vertex(r, v0);
    vec3 b = watertight_vertex(r, v1);
    vec3 c = watertight_vertex(r, v2);
    precise float u = c.x * b.y - c.y * b.x;
    precise float v = a.x * c.y - a.y * c.x;
    precise float w = b.x * a.y - b.y * a.x;
    t = 0.0;
    bary = vec2(0.0);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return false;
    }
    float det = u + v + w;
    if (det == 0.0) {
        return false;
    }
    float inv_det = 1.0 / det;
    t = (u * a.z + v * b.z + w * c.z) * inv_det;
    bary = vec2(v, w) * inv_det;
    return t > 0.0 && t < t_max;
}
