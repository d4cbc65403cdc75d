// Ray / parallelogram and ray / triangle intersection through a precomputed dual basis.
//
// The parallelogram is corner + a e1 + b e2 with (a, b) in [0, 1]^2 and normal
// n = e1 x e2. For a point q - corner in the plane, a = q . (e2 x n) / |n|^2 and
// b = q . (n x e1) / |n|^2: the host passes these dual vectors, so the test is two
// dot products; with constants for axis-aligned quads the compiler folds the zeros.

// Ray parameter of the hit of o + t d with the parallelogram, or t_max if there is
// none in (0, t_max). n: e1 x e2 (unnormalized); n_dot_corner: dot(n, corner);
// dual_a, dual_b: the dual basis above; ab receives the parallelogram coordinates.
float intersect_parallelogram(vec3 o, vec3 d, float t_max, vec3 n, float n_dot_corner,
                              vec3 corner, vec3 dual_a, vec3 dual_b, out vec2 ab) {
    float t = (n_dot_corner - dot(n, o)) / dot(n, d);
    vec3 q = o + t * d - corner;
    ab = vec2(dot(q, dual_a), dot(q, dual_b));
    bool inside = all(greaterThanEqual(ab, vec2(0.0))) && all(lessThanEqual(ab, vec2(1.0)));
    return (inside && t > 0.0 && t < t_max) ? t : t_max;
}

// The same test for the triangle corner + a e1 + b e2 (a, b >= 0, a + b <= 1);
// ab receives (a, b), the barycentrics of the second and third vertices.
float intersect_triangle_planar(vec3 o, vec3 d, float t_max, vec3 n, float n_dot_corner,
                                vec3 corner, vec3 dual_a, vec3 dual_b, out vec2 ab) {
    float t = (n_dot_corner - dot(n, o)) / dot(n, d);
    vec3 q = o + t * d - corner;
    ab = vec2(dot(q, dual_a), dot(q, dual_b));
    bool inside = ab.x >= 0.0 && ab.y >= 0.0 && ab.x + ab.y <= 1.0;
    return (inside && t > 0.0 && t < t_max) ? t : t_max;
}

// The parallelogram test when its plane is perpendicular to a coordinate axis: the
// plane is {x_axis = plane} and the caller passes the ray's origin and reciprocal
// direction along that axis (one reciprocal per ray instead of a division per quad).
float intersect_parallelogram_aligned(float o_axis, float inv_d_axis, float plane, vec3 o, vec3 d,
                                      float t_max, vec3 corner, vec3 dual_a, vec3 dual_b, out vec2 ab) {
    float t = (plane - o_axis) * inv_d_axis;
    vec3 q = o + t * d - corner;
    ab = vec2(dot(q, dual_a), dot(q, dual_b));
    bool inside = all(greaterThanEqual(ab, vec2(0.0))) && all(lessThanEqual(ab, vec2(1.0)));
    return (inside && t > 0.0 && t < t_max) ? t : t_max;
}
