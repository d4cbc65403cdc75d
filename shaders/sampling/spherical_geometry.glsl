// The solid angle of a spherical triangle by Van Oosterom & Strackee's formula, robust for small triangles.
//
// Used by the spherical triangle sampler and by tests. llvmpipe's atan has ~2e-5
// relative error (asin and acos ~4e-4 absolute: avoided), so solid angles carry that.

// Solid angle of the spherical triangle with unit vertices a, b, c (Van Oosterom &
// Strackee, "The Solid Angle of a Plane Triangle", IEEE TBME 30(2), 1983): accurate for
// small triangles, where the angle excess alpha + beta + gamma - pi cancels. The triple
// product is taken as a . ((b - a) x (c - a)), equal to a . (b x c), whose cross
// product of nearly parallel vectors would lose digits.
float spherical_triangle_area(vec3 a, vec3 b, vec3 c) {
    float det = dot(a, cross(b - a, c - a));
    return abs(2.0 * atan(det, 1.0 + dot(a, b) + dot(a, c) + dot(b, c)));
}
