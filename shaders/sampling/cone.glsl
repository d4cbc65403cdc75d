// Uniform directions inside a cone about +z, by inversion in (cos theta, phi).
//
// The cone of half-angle theta_max holds the solid angle 2 pi (1 - cos theta_max) and,
// like the sphere, equal bands of cos theta hold equal solid angle (pbrt-v4
// SampleUniformCone). A sphere light of radius R seen from distance d > R subtends the
// cone with sin theta_max = R / d: sampling it covers exactly the visible directions.
#include "common/constants.glsl"
#include "sampling/sphere.glsl"

// Density per unit solid angle of a uniform direction in the cone: 1 / (2 pi (1 -
// cos_theta_max)), for directions inside the cone (the caller knows they are).
float uniform_cone_pdf(float cos_theta_max) {
    return 1.0 / (kTwoPi * (1.0 - cos_theta_max));
}

// Uniform direction in the cone about +z of half-angle acos(cos_theta_max): u in
// [0,1)^2, cos_theta_max in [-1, 1). 1 - cos theta = u.x (1 - cos_theta_max) keeps small
// cones accurate. Returns a unit vector (local, +z = cone axis).
vec3 sample_uniform_cone(vec2 u, float cos_theta_max) {
    float one_minus_cos = u.x * (1.0 - cos_theta_max);
    return spherical_direction(sin_theta_from_one_minus_cos(one_minus_cos), 1.0 - one_minus_cos,
                               u.y);
}

// The u that sample_uniform_cone maps to the unit vector w inside the cone.
vec2 invert_uniform_cone_sample(vec3 w, float cos_theta_max) {
    float ux = (1.0 - w.z) / (1.0 - cos_theta_max);
    return vec2(clamp(ux, 0.0, kOneMinusEpsilon), azimuth_fraction(w));
}
