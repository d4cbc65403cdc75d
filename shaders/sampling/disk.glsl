// The unit disk by polar maps (r = u and the equi-areal r = sqrt(u)) and Shirley-Chiu's concentric map.
//
// Lecture 13, "Sampling a circle": with theta = 2 pi u_2, r = u_1 crowds the centre
// (density 1 / (2 pi r)), r = sqrt(u_1) is uniform (equi-areal) but stretches strata
// near the rim; Shirley & Chiu, "A Low Distortion Map Between Disk and Square", JGT
// 2(3), 1997, map concentric squares to concentric circles, uniform and with low
// distortion. Rejection from the square: sampling/disk_rejection.glsl.
#include "common/constants.glsl"

// Polar map with r = u.x, theta = 2 pi u.y: NOT uniform. u in [0,1)^2; returns a
// point of the unit disk (local, centred at the origin).
vec2 sample_disk_linear_radius(vec2 u) {
    float phi = kTwoPi * u.y;
    return u.x * vec2(cos(phi), sin(phi));
}

// Density of sample_disk_linear_radius per unit area at p: 1 / (2 pi r) (the polar
// density 1 / (2 pi) divided by the Jacobian r); 0 outside the disk.
float disk_linear_radius_pdf(vec2 p) {
    float r = length(p);
    return r <= 1.0 ? kInvTwoPi / r : 0.0;
}

// Polar angle of p mapped to [0, 1) (theta / 2 pi).
float disk_angle_fraction(vec2 p) {
    float t = atan(p.y, p.x) * kInvTwoPi;
    return t < 0.0 ? min(t + 1.0, kOneMinusEpsilon) : t;
}

// The u that sample_disk_linear_radius maps to p.
vec2 invert_disk_linear_radius_sample(vec2 p) {
    return vec2(length(p), disk_angle_fraction(p));
}

// Uniform density on the unit disk per unit area: 1 / pi (inside the disk).
float uniform_disk_pdf() {
    return kInvPi;
}

// Equi-areal polar map r = sqrt(u.x), theta = 2 pi u.y (lecture 13): uniform on the unit
// disk. u in [0,1)^2; density uniform_disk_pdf() per unit area.
vec2 sample_uniform_disk_polar(vec2 u) {
    float r = sqrt(u.x);
    float phi = kTwoPi * u.y;
    return r * vec2(cos(phi), sin(phi));
}

// The u that sample_uniform_disk_polar maps to p.
vec2 invert_uniform_disk_polar_sample(vec2 p) {
    return vec2(dot(p, p), disk_angle_fraction(p));
}

// Shirley-Chiu concentric map (pbrt-v4 SampleUniformDiskConcentric): the square
// [-1,1]^2 ring of half-width r goes to the circle of radius r. u in [0,1)^2; uniform
// on the unit disk, density uniform_disk_pdf() per unit area.
vec2 sample_uniform_disk_concentric(vec2 u) {
    vec2 o = 2.0 * u - 1.0;
    if (o.x == 0.0 && o.y == 0.0) return vec2(0.0);
    float r, theta;
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = kPiOver4 * (o.y / o.x);
    } else {
        r = o.y;
        theta = kPiOver2 - kPiOver4 * (o.x / o.y);
    }
    return r * vec2(cos(theta), sin(theta));
}

// The u that sample_uniform_disk_concentric maps to p. On the wedge |x| > |y| the map
// is p = r (cos t, sin t) with signed r = o.x and t = (pi/4) o.y / o.x, so y / x = tan t
// and o.y = o.x atan(y / x) / (pi/4); the other wedge swaps the roles of x and y.
vec2 invert_uniform_disk_concentric_sample(vec2 p) {
    float r = length(p);
    vec2 o;
    if (abs(p.x) > abs(p.y)) {
        o.x = p.x < 0.0 ? -r : r;
        o.y = o.x * atan(p.y / p.x) / kPiOver4;
    } else if (p.y != 0.0) {
        o.y = p.y < 0.0 ? -r : r;
        o.x = o.y * atan(p.x / p.y) / kPiOver4;
    } else {
        o = vec2(0.0);
    }
    return clamp(0.5 * (o + 1.0), 0.0, kOneMinusEpsilon);
}
