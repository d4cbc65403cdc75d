// Directions toward a rectangle, uniform in solid angle, by Urena et al.'s spherical-rectangle inversion (2013).
//
// Urena, Fajardo, King, "An Area-Preserving Parametrization for Spherical Rectangles",
// EGSR 2013 (Computer Graphics Forum 32(4)). In the rectangle's frame, with p at the
// origin and the rectangle in the plane z = z0 < 0, u.x fixes the x of the sample
// by inverting the solid angle of the strip [x0, x] (a closed form in the internal
// angles g0..g3), and u.y its y by inverting the solid angle along that column. Density
// 1 / S per unit solid angle, S = g0 + g1 + g2 + g3 - 2 pi.
//
// Written for float32 (and llvmpipe's atan, 3.5e-6 absolute error): the edge normals
// use their closed forms in the local frame (no cross products of nearly parallel
// vectors); S is not the angle sum, which cancels for small rectangles, but two Van
// Oosterom & Strackee triangle solid angles with the exact triple product z0 w h; the
// angle u.x S + k enters only through its cosine and sine, by angle addition from cos k
// and sin k computed from the normals. Samples stay within ~2e-4 of the rectangle's size
// of exact down to S ~ 1e-7 sr (tests/sampling/test_warps.py, test08).
//
// The rectangle is its corner s and edges ex, ey (orthogonal). The lights use it for
// quad emitters.
#include "common/constants.glsl"
#include "common/frame.glsl"

// The quantities of Urena et al.'s SphQuadInit for p and the rectangle (s, ex, ey).
struct SphericalRectangle {
    Frame frame;     // x along ex, y along ey, z away from p's side
    float x0, y0, z0, x1, y1;
    float b0, b1;    // z components of the edge-plane normals n0 and n2
    float cos_k, sin_k;  // k = 2 pi - g2 - g3
    float solid_angle;
};

// Solid angle of the triangle with (unnormalised) vertices r1, r2, r3 seen from the
// origin, given |det(r1, r2, r3)| (Van Oosterom & Strackee 1983).
float spherical_rectangle_half(vec3 r1, vec3 r2, vec3 r3, float det) {
    float l1 = length(r1), l2 = length(r2), l3 = length(r3);
    float denominator = l1 * l2 * l3 + dot(r1, r2) * l3 + dot(r1, r3) * l2 + dot(r2, r3) * l1;
    return 2.0 * atan(det, denominator);
}

// The rectangle (corner s, orthogonal edges ex, ey) in its own frame as seen from p:
// corner coordinates, edge-plane normals, cos and sin of k, and the solid angle.
SphericalRectangle spherical_rectangle_setup(vec3 p, vec3 s, vec3 ex, vec3 ey) {
    SphericalRectangle r;
    float w = length(ex), h = length(ey);
    r.frame = frame_from_xy(ex / w, ey / h);
    vec3 d = frame_to_local(r.frame, s - p);
    r.x0 = d.x;
    r.y0 = d.y;
    r.z0 = d.z;
    if (r.z0 > 0.0) {  // make z point away from the rectangle as seen from p
        r.frame.z = -r.frame.z;
        r.z0 = -r.z0;
    }
    r.x1 = r.x0 + w;
    r.y1 = r.y0 + h;
    // Edge-plane normals n0 = v00 x v10, n1 = v10 x v11, n2 = v11 x v01, n3 = v01 x v00.
    vec3 n0 = normalize(vec3(0.0, r.z0, -r.y0));
    vec3 n1 = normalize(vec3(-r.z0, 0.0, r.x1));
    vec3 n2 = normalize(vec3(0.0, -r.z0, r.y1));
    vec3 n3 = normalize(vec3(r.z0, 0.0, -r.x0));
    r.b0 = n0.z;
    r.b1 = n2.z;
    // g2 = angle(-n2, n3), g3 = angle(-n3, n0); k = 2 pi - (g2 + g3).
    float cos_g2 = -dot(n2, n3), sin_g2 = length(cross(n2, n3));
    float cos_g3 = -dot(n3, n0), sin_g3 = length(cross(n3, n0));
    r.cos_k = cos_g2 * cos_g3 - sin_g2 * sin_g3;
    r.sin_k = -(sin_g2 * cos_g3 + cos_g2 * sin_g3);
    vec3 v00 = vec3(r.x0, r.y0, r.z0), v01 = vec3(r.x0, r.y1, r.z0);
    vec3 v10 = vec3(r.x1, r.y0, r.z0), v11 = vec3(r.x1, r.y1, r.z0);
    float det = abs(r.z0) * w * h;  // |det| of both halves: height times twice their area
    r.solid_angle = spherical_rectangle_half(v00, v10, v11, det) +
                    spherical_rectangle_half(v00, v11, v01, det);
    return r;
}

// Density per unit solid angle, at p, of directions toward the rectangle (corner s,
// edges ex, ey) that hit it: 1 / (its solid angle); 0 if p lies in its plane.
float spherical_rectangle_pdf(vec3 p, vec3 s, vec3 ex, vec3 ey) {
    float solid_angle = spherical_rectangle_setup(p, s, ex, ey).solid_angle;
    return solid_angle > 0.0 ? 1.0 / solid_angle : 0.0;
}

// A point of the rectangle (corner s, edges ex, ey) whose direction from p is uniform
// in the rectangle's solid angle (Urena et al. 2013, SphQuadSample). u in [0,1)^2 (u.x
// along ex, u.y along ey). pdf: per unit solid angle (as spherical_rectangle_pdf); 0 if
// p lies in the rectangle's plane (the point is then s + u.x ex + u.y ey).
vec3 sample_spherical_rectangle(vec3 p, vec3 s, vec3 ex, vec3 ey, vec2 u, out float pdf) {
    pdf = 0.0;
    SphericalRectangle r = spherical_rectangle_setup(p, s, ex, ey);
    if (!(r.solid_angle > 0.0)) return s + u.x * ex + u.y * ey;
    pdf = 1.0 / r.solid_angle;
    // x: the angle au = u.x S + k bounds the strip of solid angle u.x S.
    float t = u.x * r.solid_angle;
    float cos_au = r.cos_k * cos(t) - r.sin_k * sin(t);
    float sin_au = r.sin_k * cos(t) + r.cos_k * sin(t);
    float fu = (cos_au * r.b0 - r.b1) / sin_au;
    float cu = clamp((fu >= 0.0 ? 1.0 : -1.0) / sqrt(fu * fu + r.b0 * r.b0),
                     -kOneMinusEpsilon, kOneMinusEpsilon);
    float xu = clamp(-(cu * r.z0) / sqrt(1.0 - cu * cu), r.x0, r.x1);
    // y: h = sin of the elevation along the column x = xu is uniform in solid angle.
    float dd = sqrt(xu * xu + r.z0 * r.z0);
    float h0 = r.y0 / sqrt(dd * dd + r.y0 * r.y0);
    float h1 = r.y1 / sqrt(dd * dd + r.y1 * r.y1);
    float hv = h0 + u.y * (h1 - h0);
    float hv2 = hv * hv;
    float yv = hv2 < 1.0 - 1e-6 ? hv * dd / sqrt(1.0 - hv2) : r.y1;
    return p + frame_from_local(r.frame, vec3(xu, clamp(yv, r.y0, r.y1), r.z0));
}
