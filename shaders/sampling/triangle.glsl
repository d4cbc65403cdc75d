// Uniform points of a triangle as barycentrics: the sqrt map (lecture 13) and Heitz's low-distortion map (2019).
//
// Barycentrics b = (b0, b1, b2), b0 + b1 + b2 = 1, give the point b0 p0 + b1 p1 + b2 p2.
// Both maps are uniform: density 2 per unit area of the reference triangle (b1, b2),
// 1 / area on a triangle of that area.

// Density of a uniform point per unit area on a triangle of the given area: 1 / area.
float uniform_triangle_pdf(float area) {
    return area > 0.0 ? 1.0 / area : 0.0;
}

// Area of the triangle p0 p1 p2.
float triangle_area(vec3 p0, vec3 p1, vec3 p2) {
    return 0.5 * length(cross(p1 - p0, p2 - p0));
}

// Lecture 13, "Sampling a triangle": the marginal of b0 is 2 (1 - b0), so b0 = 1 - sqrt(u.x),
// and given b0 the rest is uniform: b1 = sqrt(u.x) u.y. u in [0,1)^2; returns barycentrics.
vec3 sample_uniform_triangle_sqrt(vec2 u) {
    float su = sqrt(u.x);
    float b0 = 1.0 - su;
    float b1 = su * u.y;
    return vec3(b0, b1, 1.0 - b0 - b1);
}

// The u that sample_uniform_triangle_sqrt maps to barycentrics b.
vec2 invert_uniform_triangle_sqrt_sample(vec3 b) {
    float su = 1.0 - b.x;
    return vec2(su * su, su > 0.0 ? b.y / su : 0.0);
}

// Heitz, "A Low-Distortion Map Between Triangle and Square", 2019 (pbrt-v4
// SampleUniformTriangle): the square is split along its diagonal and each half sheared
// onto the triangle, so nearby u stay nearby. u in [0,1)^2; returns barycentrics.
vec3 sample_uniform_triangle(vec2 u) {
    float b0, b1;
    if (u.x < u.y) {
        b0 = 0.5 * u.x;
        b1 = u.y - b0;
    } else {
        b1 = 0.5 * u.y;
        b0 = u.x - b1;
    }
    return vec3(b0, b1, 1.0 - b0 - b1);
}

// The u that sample_uniform_triangle maps to barycentrics b (pbrt-v4).
vec2 invert_uniform_triangle_sample(vec3 b) {
    return b.x > b.y ? vec2(b.x + b.y, 2.0 * b.y) : vec2(2.0 * b.x, b.y + b.x);
}
