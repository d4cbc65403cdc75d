// Directions toward a triangle, uniform in solid angle, by Arvo's spherical-triangle inversion (1995).
//
// Arvo, "Stratified Sampling of Spherical Triangles", SIGGRAPH 1995. Seen from p, the
// triangle v0 v1 v2 projects to the spherical triangle with unit vertices a, b, c. u.x
// picks the sub-triangle (a, b, c') of area A' = u.x A whose vertex c' lies on the arc
// a-c; u.y picks a point on the arc b-c', with cos theta from b uniform, so that the
// result is uniform in solid angle. Density 1 / A per unit solid angle over the
// triangle's directions (the lights use it for triangle emitters).
//
// c' is found in closed form rather than by Arvo's cos formula, whose float32 version
// loses ~3e-4 near the ends of the arc: with c' = cos phi a + sin phi e (e the unit
// tangent at a toward c), Van Oosterom & Strackee's tan(A' / 2) = det(a, b, c') /
// (1 + a.b + a.c' + b.c') solves to tan(phi / 2) = sin(A'/2) (1 + a.b) /
// (|det(a, b, e)| cos(A'/2) - sin(A'/2) b.e), and cos phi, sin phi follow without any
// inverse trigonometric function. Areas come from atan (llvmpipe: ~2e-5 relative).
#include "common/constants.glsl"
#include "sampling/spherical_geometry.glsl"

// Density per unit solid angle, at p, of directions toward the triangle v0 v1 v2 that
// hit it: 1 / (its solid angle); 0 for a degenerate triangle or p in its plane.
float spherical_triangle_pdf(vec3 v0, vec3 v1, vec3 v2, vec3 p) {
    vec3 a = normalize(v0 - p), b = normalize(v1 - p), c = normalize(v2 - p);
    float area = spherical_triangle_area(a, b, c);
    return area > 0.0 ? 1.0 / area : 0.0;
}

// Unit direction from p toward a uniformly chosen point of the solid angle of the
// triangle v0 v1 v2. u in [0,1)^2 (u.x: sub-triangle area, u.y: along the arc from
// v1's direction). pdf: per unit solid angle (as spherical_triangle_pdf); 0 and the
// zero vector for a degenerate triangle. Small triangles: every quantity is formed from
// the differences b - a, c - a (dot(a, e) = 0 turns b.e into (b - a).e, and so on) and
// 1 - cos of an arc from half its squared chord, so samples stay within ~4e-4 of the
// triangle's size of exact down to solid angles of ~1e-7 sr (test_warps.py, test08).
vec3 sample_spherical_triangle(vec3 v0, vec3 v1, vec3 v2, vec3 p, vec2 u, out float pdf) {
    pdf = 0.0;
    vec3 a = normalize(v0 - p), b = normalize(v1 - p), c = normalize(v2 - p);
    vec3 ab = b - a, ac = c - a;
    float area = spherical_triangle_area(a, b, c);
    vec3 e = ac - dot(ac, a) * a;  // the tangent at a toward c
    if (!(area > 0.0) || dot(e, e) == 0.0) return vec3(0.0);
    e = normalize(e);
    pdf = 1.0 / area;
    // c' on arc a-c with area(a, b, c') = u.x A: tan(phi / 2) = y / x (see above), so
    // c' - a = 2 y (x e - y a) / (x^2 + y^2).
    float half_area = 0.5 * u.x * area;
    float y = sin(half_area) * (1.0 + dot(a, b));
    float x = abs(dot(a, cross(ab, e))) * cos(half_area) - sin(half_area) * dot(ab, e);
    vec3 d = ac - ab;  // c' - b; c' = c unless c' stops short of c:
    if (y * (1.0 + dot(a, c)) < x * dot(e, ac)) {  // tan(phi/2) < tan(arc(a, c) / 2)
        d = 2.0 * y * (x * e - y * a) / (x * x + y * y) - ab;
    }
    // Along the arc b-c': 1 - cos theta uniform in [0, 1 - dot(c', b)), with
    // 1 - dot(c', b) = |c' - b|^2 / 2 and c' - dot(c', b) b = d + (|d|^2 / 2) b.
    float arc = 0.5 * dot(d, d);
    float one_minus_cos = u.y * arc;
    float sin_theta = sqrt(max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
    return (1.0 - one_minus_cos) * b + sin_theta * normalize(d + arc * b);
}

// The u that sample_spherical_triangle maps to the unit direction w (from p, inside the
// triangle's solid angle), after Arvo's SphTri.C as in pbrt-v4: c' is where the great
// circle through b and w meets arc a-c; u.x = area(a, b, c') / area, u.y from the
// position of w along arc b-c'.
vec2 invert_spherical_triangle_sample(vec3 v0, vec3 v1, vec3 v2, vec3 p, vec3 w) {
    vec3 a = normalize(v0 - p), b = normalize(v1 - p), c = normalize(v2 - p);
    float area = spherical_triangle_area(a, b, c);
    vec3 c_sub = cross(cross(b, w - b), cross(c - a, a));
    if (!(area > 0.0) || dot(c_sub, c_sub) == 0.0) return vec2(0.5);
    c_sub = normalize(c_sub);
    if (dot(c_sub, a + c) < 0.0) c_sub = -c_sub;
    float u0 = spherical_triangle_area(a, b, c_sub) / area;
    vec3 wb = w - b, cb = c_sub - b;
    float u1 = dot(wb, wb) / dot(cb, cb);  // (1 - w.b) / (1 - c'.b)
    return clamp(vec2(u0, u1), 0.0, kOneMinusEpsilon);
}
