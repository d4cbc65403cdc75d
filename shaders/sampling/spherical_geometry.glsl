// Robust angles and areas of spherical polygons, shared by the spherical triangle and rectangle samplers.
#include "common/constants.glsl"

// Angle in [0, pi] between unit vectors v1 and v2: 2 atan(|v1 - v2|, |v1 + v2|) (Kahan),
// accurate also near 0 and pi, where acos(dot) loses half its digits. Not asin or acos:
// llvmpipe's measured absolute error is ~4e-4 for those, ~2e-5 relative for atan.
float angle_between(vec3 v1, vec3 v2) {
    return 2.0 * atan(length(v1 - v2), length(v1 + v2));
}

// The part of v orthogonal to the unit vector w (one Gram-Schmidt step).
vec3 gram_schmidt(vec3 v, vec3 w) {
    return v - dot(v, w) * w;
}

// Solid angle of the spherical triangle with unit vertices a, b, c (Van Oosterom &
// Strackee, "The Solid Angle of a Plane Triangle", IEEE TBME 30(2), 1983): accurate for
// small triangles, where the angle excess alpha + beta + gamma - pi cancels.
float spherical_triangle_area(vec3 a, vec3 b, vec3 c) {
    return abs(2.0 * atan(dot(a, cross(b, c)), 1.0 + dot(a, b) + dot(a, c) + dot(b, c)));
}
