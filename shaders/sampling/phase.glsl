// Phase functions of participating media: isotropic and Henyey-Greenstein, with sampling by inversion.
//
// Convention (pbrt-v4, Mitsuba 3): directions are expressed in a local frame whose +z axis
// is the direction d the path travelled before the scattering event, i.e. the ray
// direction of the incoming path segment; cos_theta = dot(d, wi) for the scattered
// direction wi. pbrt and Mitsuba pass wo = -d instead (pointing back along the path), so
// their cos_theta is -dot(wo, wi). The phase function depends only on this angle and is
// reciprocal, so camera and light paths use it alike.
//
// Henyey-Greenstein (Henyey and Greenstein 1941; pbrt-v4's HenyeyGreenstein with its
// cos_theta negated), per unit solid angle:
//     p(cos_theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos_theta)^(3/2)),
// with mean cosine g in (-1, 1): g > 0 scatters forward (wi near d), g < 0 backward, and
// g = 0 is isotropic, 1 / (4 pi). Both phase functions integrate to 1 over the sphere, so
// a phase function's value is also its sampling density and the weight p / pdf of a
// sampled direction is exactly 1.
//
// Sampling inverts the CDF of cos_theta (its density is 2 pi p(cos_theta); phi = 2 pi u.y):
//     q = sqrt(1 + g^2 - 2 g cos_theta) = (1 - g^2) / (1 - g + 2 g u.x).
// Written as 1 - cos_theta and 1 + cos_theta directly (below), the inversion has no
// cancellation for any |g| < 1 and no division by g: at g = 0 it reduces to
// cos_theta = 2 u.x - 1, so no separate isotropic branch is needed near g = 0.
#include "common/constants.glsl"
#include "common/frame.glsl"
#include "sampling/sphere.glsl"

// The isotropic phase function, 1 / (4 pi) per unit solid angle (sample it with
// sample_uniform_sphere of sampling/sphere.glsl, or sample_hg with g = 0).
float isotropic_phase() {
    return uniform_sphere_pdf();
}

// 1 + g^2 - 2 g cos_theta, the squared distance from the direction to the point g on the
// +z axis, written as a sum of non-negative terms so that it keeps its relative accuracy
// where it is small (cos_theta near sign(g), |g| near 1).
float hg_distance_squared(float cos_theta, float g) {
    float c = clamp(cos_theta, -1.0, 1.0);
    return g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - c)
                    : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + c);
}

// The Henyey-Greenstein phase function, |g| < 1, at cos_theta = dot(d, wi) (local, +z = d,
// the direction of travel before scattering); also the density of sample_hg per unit
// solid angle.
float hg_phase(float cos_theta, float g) {
    float q2 = hg_distance_squared(cos_theta, g);
    return kInvFourPi * (1.0 - g) * (1.0 + g) / (q2 * sqrt(q2));
}

// Direction scattered by the Henyey-Greenstein phase function (|g| < 1): u in [0,1)^2;
// returns a unit vector wi (local, +z = d, the direction of travel before scattering;
// wi.z = cos_theta, u.x -> 1 is forward); density hg_phase(wi.z, g) per unit solid angle.
vec3 sample_hg(vec2 u, float g) {
    // t = 1 - g + 2 g u.x (= (1 - g^2) / q) as a sum of non-negative terms
    float t = g >= 0.0 ? (1.0 - g) + 2.0 * g * u.x : (1.0 + g) - 2.0 * g * (1.0 - u.x);
    float q = (1.0 - g) * (1.0 + g) / t;
    // 1 - cos_theta = (q^2 - (1 - g)^2) / 2g and 1 + cos_theta = ((1 + g)^2 - q^2) / 2g,
    // with the factor g of each difference of squares cancelled exactly
    float one_minus_cos = (1.0 - g) * (1.0 - u.x) * (q + 1.0 - g) / t;
    float one_plus_cos = (1.0 + g) * u.x * (q + 1.0 + g) / t;
    float cos_theta = one_minus_cos < 1.0 ? 1.0 - one_minus_cos : one_plus_cos - 1.0;
    float sin_theta = sqrt(max(0.0, one_minus_cos * one_plus_cos));
    return spherical_direction(sin_theta, cos_theta, u.y);
}

// The u that sample_hg maps to the unit vector w (local, +z = d):
// u.x = CDF(cos_theta) = (1 - g)(1 + cos_theta) / (q (1 + g + q)), the cancellation-free
// form of (1 - g^2) / 2g (1 / q - 1 / (1 + g)).
vec2 invert_hg_sample(vec3 w, float g) {
    float q = sqrt(hg_distance_squared(w.z, g));
    float cdf = (1.0 - g) * (1.0 + clamp(w.z, -1.0, 1.0)) / (q * (1.0 + g + q));
    return vec2(clamp(cdf, 0.0, kOneMinusEpsilon), azimuth_fraction(w));
}

// Direction scattered by the Henyey-Greenstein phase function around the unit vector d,
// the direction of travel before scattering (world or render space, as d): sample_hg
// carried out of the frame frame_from_z(d). Density hg_phase(dot(d, wi), g) per unit
// solid angle.
vec3 sample_hg_world(vec2 u, float g, vec3 d) {
    return frame_from_local(frame_from_z(d), sample_hg(u, g));
}
