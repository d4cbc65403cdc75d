// Directions toward a rectangle, uniform in solid angle, by Urena et al.'s spherical-rectangle inversion (2013).
//
// Urena, Fajardo, King, "An Area-Preserving Parametrization for Spherical Rectangles",
// EGSR 2013 (Computer Graphics Forum 32(4)). In the rectangle's frame, with p at the
// origin and the rectangle in the plane z = z0 < 0, u.x fixes the x of the sample
// by inverting the solid angle of the strip [x0, x] (a closed form in the internal
// angles g0..g3), and u.y its y by inverting the solid angle along that column. Density
// 1 / S per unit solid angle, S = g0 + g1 + g2 + g3 - 2 pi.
//
// The rectangle is its corner s and edges ex, ey (orthogonal). The lights use it for
// quad emitters; a rectangle of tiny solid angle loses float32 digits: sample its area.
#include "common/constants.glsl"
#include "common/frame.glsl"
#include "sampling/spherical_geometry.glsl"

// The quantities of Urena et al.'s SphQuadInit for p and the rectangle (s, ex, ey).
struct SphericalRectangle {
    Frame frame;     // x along ex, y along ey, z away from p's side
    float x0, y0, z0, x1, y1;
    float b0, b1;    // z components of the edge-plane normals n0 and n2
    float k;         // 2 pi - g2 - g3
    float solid_angle;
};

SphericalRectangle spherical_rectangle_setup(vec3 p, vec3 s, vec3 ex, vec3 ey) {
    SphericalRectangle r;
    float ex_len = length(ex), ey_len = length(ey);
    r.frame = frame_from_xy(ex / ex_len, ey / ey_len);
    vec3 d = frame_to_local(r.frame, s - p);
    r.x0 = d.x;
    r.y0 = d.y;
    r.z0 = d.z;
    if (r.z0 > 0.0) {  // make z point away from the rectangle as seen from p
        r.frame.z = -r.frame.z;
        r.z0 = -r.z0;
    }
    r.x1 = r.x0 + ex_len;
    r.y1 = r.y0 + ey_len;
    vec3 v00 = vec3(r.x0, r.y0, r.z0), v01 = vec3(r.x0, r.y1, r.z0);
    vec3 v10 = vec3(r.x1, r.y0, r.z0), v11 = vec3(r.x1, r.y1, r.z0);
    vec3 n0 = normalize(cross(v00, v10)), n1 = normalize(cross(v10, v11));
    vec3 n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
    float g0 = angle_between(-n0, n1), g1 = angle_between(-n1, n2);
    float g2 = angle_between(-n2, n3), g3 = angle_between(-n3, n0);
    r.b0 = n0.z;
    r.b1 = n2.z;
    r.k = kTwoPi - g2 - g3;
    r.solid_angle = g0 + g1 - r.k;
    return r;
}

// Density per unit solid angle, at p, of directions toward the rectangle (corner s,
// edges ex, ey) that hit it: 1 / (its solid angle); 0 if p lies in its plane.
float spherical_rectangle_pdf(vec3 p, vec3 s, vec3 ex, vec3 ey) {
    if (dot(s - p, cross(ex, ey)) == 0.0) return 0.0;
    float solid_angle = spherical_rectangle_setup(p, s, ex, ey).solid_angle;
    return solid_angle > 0.0 ? 1.0 / solid_angle : 0.0;
}

// A point of the rectangle (corner s, edges ex, ey) whose direction from p is uniform
// in the rectangle's solid angle (Urena et al. 2013, SphQuadSample). u in [0,1)^2 (u.x
// along ex, u.y along ey). pdf: per unit solid angle (as spherical_rectangle_pdf); 0 if
// p lies in the rectangle's plane (the point is then s + u.x ex + u.y ey).
vec3 sample_spherical_rectangle(vec3 p, vec3 s, vec3 ex, vec3 ey, vec2 u, out float pdf) {
    pdf = 0.0;
    if (dot(s - p, cross(ex, ey)) == 0.0) return s + u.x * ex + u.y * ey;
    SphericalRectangle r = spherical_rectangle_setup(p, s, ex, ey);
    if (!(r.solid_angle > 0.0)) return s + u.x * ex + u.y * ey;
    pdf = 1.0 / r.solid_angle;
    // x: the angle au = u.x S + k bounds the strip of solid angle u.x S.
    float au = u.x * r.solid_angle + r.k;
    float fu = (cos(au) * r.b0 - r.b1) / sin(au);
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
    return p + frame_from_local(r.frame, vec3(xu, yv, r.z0));
}
