// GGX (Trowbridge-Reitz) and Beckmann microfacet distributions: D, Smith Lambda/G1/G2, and visible-normal sampling.
//
// Local frame, +z = the macro-surface normal; wo, wi, wm unit vectors; anisotropic
// roughness alpha = vec2(alpha_x, alpha_y). Smith masking with the height-correlated G2
// (Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
// JCGT 3(2), 2014). Visible normals (Heitz & d'Eon, EGSR 2014): for wo with cos theta_o
// > 0 the density of wm per unit solid angle is
//     D_wo(wm) = G1(wo) max(0, dot(wo, wm)) D(wm) / cos theta_o,
// sampled exactly for GGX by Heitz, "Sampling the GGX Distribution of Visible Normals",
// JCGT 7(4), 2018, and for Beckmann by Heitz & d'Eon's stretch-invariant slope sampling
// with the marginal slope CDF inverted numerically (safeguarded Newton on the erf
// scale, as in pbrt-v3 and Mitsuba; not the paper's approximate fit), so both pdfs are
// exact up to float32 rounding. wo below the surface: the caller flips it.
#include "common/constants.glsl"
#include "sampling/disk.glsl"
#include "sampling/erf.glsl"

// tan^2 theta of w scaled by the anisotropic roughness: (ax^2 x^2 + ay^2 y^2) / z^2.
float microfacet_alpha2_tan2(vec3 w, vec2 alpha) {
    vec2 a = alpha * w.xy;
    return dot(a, a) / (w.z * w.z);
}

// ---- GGX -------------------------------------------------------------------------------

// GGX normal distribution D(wm) per unit solid angle of wm (normalised so that
// integral of D(wm) cos theta_m over the hemisphere = 1):
// 1 / (pi ax ay (x^2 / ax^2 + y^2 / ay^2 + z^2)^2); 0 for wm.z <= 0.
float ggx_d(vec3 wm, vec2 alpha) {
    if (wm.z <= 0.0) return 0.0;
    vec2 s = wm.xy / alpha;
    float e = dot(s, s) + wm.z * wm.z;
    return 1.0 / (kPi * alpha.x * alpha.y * e * e);
}

// Smith Lambda for GGX: (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2, written without
// cancellation for small alpha tan theta; infinite at grazing w.z = 0.
float ggx_lambda(vec3 w, vec2 alpha) {
    if (w.z == 0.0) return kInfinity;
    float a2t2 = microfacet_alpha2_tan2(w, alpha);
    return 0.5 * a2t2 / (1.0 + sqrt(1.0 + a2t2));
}

// Smith masking G1(w) = 1 / (1 + Lambda(w)) for GGX, in [0, 1]; 0 at grazing.
float ggx_g1(vec3 w, vec2 alpha) {
    if (w.z == 0.0) return 0.0;
    return 2.0 / (1.0 + sqrt(1.0 + microfacet_alpha2_tan2(w, alpha)));
}

// Height-correlated Smith masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi)).
float ggx_g2(vec3 wo, vec3 wi, vec2 alpha) {
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

// Density of GGX visible normals D_wo(wm) per unit solid angle of wm (wo.z > 0).
float ggx_visible_normal_pdf(vec3 wo, vec3 wm, vec2 alpha) {
    if (wo.z <= 0.0) return 0.0;
    return ggx_g1(wo, alpha) * max(0.0, dot(wo, wm)) * ggx_d(wm, alpha) / wo.z;
}

// Samples a GGX visible normal wm for wo (wo.z > 0), Heitz 2018: stretch wo to the
// alpha = 1 configuration, where visible normals are the projection of a uniform disk
// point onto the hemisphere, with the half of the disk hidden behind wo compressed
// into the visible half; then unstretch. u in [0,1)^2; returns a unit vector (local,
// +z up) with density ggx_visible_normal_pdf(wo, wm, alpha) per unit solid angle.
vec3 sample_ggx_visible_normal(vec3 wo, vec2 alpha, vec2 u) {
    vec3 wh = normalize(vec3(alpha * wo.xy, wo.z));
    float len2 = dot(wh.xy, wh.xy);
    vec3 t1 = len2 > 0.0 ? vec3(-wh.y, wh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(wh, t1);
    vec2 p = sample_uniform_disk_polar(u);
    float h = sqrt(max(0.0, 1.0 - p.x * p.x));
    p.y = mix(h, p.y, 0.5 * (1.0 + wh.z));
    float pz = sqrt(max(0.0, 1.0 - dot(p, p)));
    vec3 nh = p.x * t1 + p.y * t2 + pz * wh;
    return normalize(vec3(alpha * nh.xy, max(1e-6, nh.z)));
}

// The u that sample_ggx_visible_normal maps to wm (a visible normal of wo): undo the
// unstretch, the half-disk compression and the polar disk map.
vec2 invert_ggx_visible_normal_sample(vec3 wo, vec3 wm, vec2 alpha) {
    vec3 wh = normalize(vec3(alpha * wo.xy, wo.z));
    float len2 = dot(wh.xy, wh.xy);
    vec3 t1 = len2 > 0.0 ? vec3(-wh.y, wh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(wh, t1);
    vec3 nh = normalize(vec3(wm.xy / alpha, wm.z));
    vec2 p = vec2(dot(nh, t1), dot(nh, t2));
    float h = sqrt(max(0.0, 1.0 - p.x * p.x));
    float s = 0.5 * (1.0 + wh.z);
    p.y = (p.y - (1.0 - s) * h) / s;
    return invert_uniform_disk_polar_sample(p);
}

// ---- Beckmann --------------------------------------------------------------------------

// Beckmann normal distribution D(wm) per unit solid angle of wm (normalised like ggx_d):
// exp(-(x^2 / ax^2 + y^2 / ay^2) / z^2) / (pi ax ay z^4); 0 for wm.z <= 0.
float beckmann_d(vec3 wm, vec2 alpha) {
    if (wm.z <= 0.0) return 0.0;
    vec2 s = wm.xy / alpha;
    float z2 = wm.z * wm.z;
    return exp(-dot(s, s) / z2) / (kPi * alpha.x * alpha.y * z2 * z2);
}

// Smith Lambda for Beckmann with a = 1 / (alpha tan theta):
// (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)); infinite at grazing.
float beckmann_lambda(vec3 w, vec2 alpha) {
    if (w.z == 0.0) return kInfinity;
    float a2t2 = microfacet_alpha2_tan2(w, alpha);
    if (a2t2 == 0.0) return 0.0;
    float a = inversesqrt(a2t2);
    return 0.5 * (erf_approx(a) - 1.0) + exp(-a * a) / (2.0 * a * sqrt(kPi));
}

// Smith masking G1(w) = 1 / (1 + Lambda(w)) for Beckmann.
float beckmann_g1(vec3 w, vec2 alpha) {
    return 1.0 / (1.0 + beckmann_lambda(w, alpha));
}

// Height-correlated Smith masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi)).
float beckmann_g2(vec3 wo, vec3 wi, vec2 alpha) {
    return 1.0 / (1.0 + beckmann_lambda(wo, alpha) + beckmann_lambda(wi, alpha));
}

// Density of Beckmann visible normals D_wo(wm) per unit solid angle of wm (wo.z > 0).
float beckmann_visible_normal_pdf(vec3 wo, vec3 wm, vec2 alpha) {
    if (wo.z <= 0.0) return 0.0;
    return beckmann_g1(wo, alpha) * max(0.0, dot(wo, wm)) * beckmann_d(wm, alpha) / wo.z;
}

// Visible slopes of the isotropic alpha = 1 Beckmann surface seen from polar angle
// theta (cos_theta > 0), as if from azimuth 0 (Heitz & d'Eon 2014). The slope x along
// the view has the CDF (1 + erf(x) + tan theta exp(-x^2) / sqrt(pi)) / norm on x <
// cot theta; it is inverted on the scale b = erf(x) by Newton steps safeguarded by
// bisection (at most 10 steps: the loop is bounded for llvmpipe). Given x, the slope y
// is Gaussian: erf_inv(2 u.y - 1).
vec2 beckmann_sample_slopes_11(float cos_theta, vec2 u) {
    if (cos_theta > 0.9999) {  // normal incidence: a 2D Gaussian by the polar map
        float r = sqrt(-log(1.0 - u.x));
        float phi = kTwoPi * u.y;
        return r * vec2(cos(phi), sin(phi));
    }
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float tan_theta = sin_theta / cos_theta;
    float cot_theta = 1.0 / tan_theta;
    float lo = -1.0;
    float hi = erf_approx(cot_theta);
    float ux = max(u.x, 1e-6);
    // Initial guess from a fit of the inverse (pbrt-v3, Mitsuba)
    float theta = acos(cos_theta);
    float fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    float b = hi - (1.0 + hi) * pow(1.0 - ux, fit);
    float norm = 1.0 / (1.0 + hi + tan_theta * exp(-cot_theta * cot_theta) / sqrt(kPi));
    for (int it = 0; it < 10; ++it) {
        if (!(b >= lo && b <= hi)) b = 0.5 * (lo + hi);
        float x = erf_inv_approx(b);
        float value = norm * (1.0 + b + tan_theta * exp(-x * x) / sqrt(kPi)) - ux;
        float derivative = norm * (1.0 - x * tan_theta);
        if (abs(value) < 1e-6) break;
        if (value > 0.0) hi = b; else lo = b;
        b -= value / derivative;
    }
    return vec2(erf_inv_approx(b), erf_inv_approx(2.0 * max(u.y, 1e-6) - 1.0));
}

// Samples a Beckmann visible normal wm for wo (wo.z > 0): stretch wo to alpha = 1,
// sample the visible slopes there, rotate them to wo's azimuth and unstretch (Heitz &
// d'Eon 2014). u in [0,1)^2; returns a unit vector (local, +z up) with density
// beckmann_visible_normal_pdf(wo, wm, alpha) per unit solid angle.
vec3 sample_beckmann_visible_normal(vec3 wo, vec2 alpha, vec2 u) {
    vec3 ws = normalize(vec3(alpha * wo.xy, wo.z));
    vec2 slope = beckmann_sample_slopes_11(ws.z, u);
    float len = length(ws.xy);
    vec2 cs = len > 0.0 ? ws.xy / len : vec2(1.0, 0.0);  // (cos phi, sin phi) of ws
    slope = vec2(cs.x * slope.x - cs.y * slope.y, cs.y * slope.x + cs.x * slope.y);
    slope *= alpha;
    return normalize(vec3(-slope, 1.0));
}
