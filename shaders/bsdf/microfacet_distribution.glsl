// The microfacet distribution of the rough BSDFs: Mitsuba 3's model over the sampling library.
//
// Local frame, +z = the macro-surface normal; m a unit microfacet normal. The rough
// models (roughconductor, roughdielectric, roughplastic) evaluate Mitsuba 3's
// microfacet.h exactly: D with its 1e-20 cut-off, Smith's *separable* masking-shadowing
// G = G1(wo, m) G1(wi, m), and for Beckmann its rational fit of G1 (Walter et al.
// 2007, eq. 27; < 0.35% relative error). Sampling uses visible normals
// (sampling/microfacet.glsl), whose density contains the exact G1 of the view
// direction; microfacet_visible_normal_pdf returns that exact density, so that
// sample weights f / pdf are unbiased. (Mitsuba's pdf reuses the rational G1 there:
// for Beckmann its pdf differs from ours by the constant factor
// G1_rational(wo) / G1_exact(wo), within 0.35%; for GGX the two are identical.)
#include "bsdf/bsdf_common.glsl"
#include "sampling/microfacet.glsl"

// The distribution at one surface point: anisotropic roughness along local x and y.
struct Microfacet {
    vec2 alpha;  // clamped to >= 1e-4 as in Mitsuba
    bool ggx;    // GGX (Trowbridge-Reitz) or Beckmann
};

Microfacet microfacet_from_bsdf(Bsdf b) {
    return Microfacet(max(b.alpha, vec2(1e-4)), (b.flags & kMaterialFlagGgx) != 0u);
}

// D(m) per unit solid angle of m; 0 where D cos theta_m <= 1e-20 (Mitsuba's guard
// against denormals in later steps), in particular for m.z <= 0.
float microfacet_d(Microfacet md, vec3 m) {
    float d = md.ggx ? ggx_d(m, md.alpha) : beckmann_d(m, md.alpha);
    return d * m.z > 1e-20 ? d : 0.0;
}

// Mitsuba's Smith G1(v, m) of the shading models: exact for GGX, the rational fit
// for Beckmann (a = 1 / (alpha tan theta): 1 for a >= 1.6, else
// (3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2)); 1 at normal incidence; 0 when
// v sees the back of the microfacet (dot(v, m) and v.z of different signs).
float microfacet_smith_g1(Microfacet md, vec3 v, vec3 m) {
    vec2 s = md.alpha * v.xy;
    float xy_alpha2 = dot(s, s);
    float tan2 = xy_alpha2 / (v.z * v.z);
    float g;
    if (md.ggx) {
        g = 2.0 / (1.0 + sqrt(1.0 + tan2));
    } else {
        float a = inversesqrt(tan2);
        g = a >= 1.6 ? 1.0 : (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
    }
    if (xy_alpha2 == 0.0) g = 1.0;
    if (dot(v, m) * v.z <= 0.0) g = 0.0;
    return g;
}

// Mitsuba's separable masking-shadowing G(wo, wi, m) = G1(wo, m) G1(wi, m).
float microfacet_g(Microfacet md, vec3 wo, vec3 wi, vec3 m) {
    return microfacet_smith_g1(md, wo, m) * microfacet_smith_g1(md, wi, m);
}

// Exact density of sample_microfacet_visible_normal per unit solid angle of m, for
// wo with wo.z > 0: D(m) G1(wo) max(0, dot(wo, m)) / wo.z (Heitz & d'Eon 2014, eq. 2).
float microfacet_visible_normal_pdf(Microfacet md, vec3 wo, vec3 m) {
    if (!(wo.z > 0.0) || dot(wo, m) <= 0.0) return 0.0;
    float g1 = md.ggx ? ggx_g1(wo, md.alpha) : beckmann_g1(wo, md.alpha);
    return microfacet_d(md, m) * g1 * dot(wo, m) / wo.z;
}

// Density per unit solid angle of wi = reflect_about(wo, m) for m drawn by
// sample_microfacet_visible_normal (wo.z > 0): D_wo(m) |dm/dwi| = D_wo(m) / (4 wo.m) =
// D(m) G1(wo) / (4 cos theta_o) (Walter et al. 2007, eq. 14). Written without the
// ratio wo.m / wi.m (= 1), which float32 loses when wo and wi are nearly opposite.
float microfacet_reflection_pdf(Microfacet md, vec3 wo, vec3 m) {
    if (!(wo.z > 0.0) || dot(wo, m) <= 0.0) return 0.0;
    float g1 = md.ggx ? ggx_g1(wo, md.alpha) : beckmann_g1(wo, md.alpha);
    return microfacet_d(md, m) * g1 / (4.0 * wo.z);
}

// Samples a microfacet normal visible from wo (wo.z > 0); u in [0,1)^2. Returns a unit
// vector (local, +z up) with density microfacet_visible_normal_pdf per solid angle.
vec3 sample_microfacet_visible_normal(Microfacet md, vec3 wo, vec2 u) {
    return md.ggx ? sample_ggx_visible_normal(wo, md.alpha, u)
                  : sample_beckmann_visible_normal(wo, md.alpha, u);
}
