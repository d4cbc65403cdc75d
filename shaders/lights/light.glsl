// Light sampling for next-event estimation and the matching pdfs for MIS, for every light kind.
//
// Area lights (parallelograms, triangles, spheres) emit radiance from their front
// side (both sides if two-sided); a parallelogram or triangle is sampled uniformly
// in solid angle (Urena et al. 2013 / Arvo 1995) or by area (kAreaSampling), a
// sphere by the cone of directions it subtends (uniform area inside it). Point,
// spot and directional lights are Dirac deltas that BSDF sampling can never hit.
// Each light kind is compiled in only when the scene has it (kLightKinds).
#include "common/constants.glsl"
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "sampling/cone.glsl"
#include "common/frame.glsl"
#include "sampling/sphere.glsl"
#include "sampling/triangle.glsl"
#include "sampling/spherical_rectangle.glsl"
#include "sampling/spherical_triangle.glsl"
#include "sampling/distribution2d.glsl"
#include "sampling/disk.glsl"
#include "sampling/hemisphere.glsl"
#include "bsdf/texture.glsl"

// Light kinds: the values of glrender.gpu.layout.LIGHT_KINDS.
const uint kLightParallelogram = 0u;
const uint kLightTriangle = 1u;
const uint kLightSphere = 2u;
const uint kLightDisk = 3u;
const uint kLightPoint = 4u;
const uint kLightSpot = 5u;
const uint kLightDirectional = 6u;
const uint kLightConstant = 7u;
const uint kLightEnvmap = 8u;
// Light flags (kLightFlag*): common/bindings.glsl, included by scene/layout.glsl.

// Solid angles outside this range are sampled by area: below it float32 loses the
// digits of the spherical construction, above it the warp is badly conditioned
// (pbrt-v4's MinSphericalSampleArea / MaxSphericalSampleArea).
const float kMinSphericalSampleArea = 3e-4;
const float kMaxSphericalSampleArea = 6.22;

bool light_kind_present(uint kind) {
    return (kLightKinds & (1u << kind)) != 0u;
}

// A sampled light direction as seen from a reference point.
struct LightSample {
    vec3 wi;       // unit direction from the reference point toward the light
    float dist;    // distance to the sampled point (kInfinity: at infinity)
    vec3 Le;       // radiance arriving along -wi (point/spot: intensity / dist^2; directional: irradiance)
    float pdf;     // solid-angle pdf of wi; 1 for delta lights (selection probability not included)
    bool delta;    // a Dirac light (no MIS)
};

// Environment maps (Mitsuba's lat-long convention, +y up in the light's frame):
// u = atan2(x, -z) / 2 pi wrapped to [0, 1), v = theta / pi; the light's frame columns
// are LightData e1, e2, n (world_from_light's rotation). The importance distribution
// is piecewise constant over the texels (weighted by sin theta); radiance is looked
// up bilinearly (envmap_lookup). theta comes from atan (llvmpipe's acos is off by up to 4e-4).
vec2 envmap_uv(LightData l, vec3 w_world, out float sin_theta) {
    vec3 w = vec3(dot(w_world, l.e1.xyz), dot(w_world, l.e2.xyz), dot(w_world, l.n.xyz));
    sin_theta = length(w.xz);
    float u = atan(w.x, -w.z) * kInvTwoPi;
    u = u < 0.0 ? u + 1.0 : u;
    return vec2(min(u, kOneMinusEpsilon), atan(sin_theta, w.y) * kInvPi);
}

vec3 envmap_direction(LightData l, vec2 uv, out float sin_theta) {
    float phi = kTwoPi * uv.x, theta = kPi * uv.y;
    sin_theta = sin(theta);
    vec3 w = vec3(sin(phi) * sin_theta, cos(theta), -cos(phi) * sin_theta);
    return w.x * l.e1.xyz + w.y * l.e2.xyz + w.z * l.n.xyz;
}

// Bilinear radiance at uv as Mitsuba 3 interpolates its lat-long images: columns centred
// at u = (i + 1/2) / width (as GL's texels), but rows at v = j / (height - 1), the first
// and last rows on the poles (src/emitters/envmap.cpp, eval_spectrum).
vec3 envmap_lookup(LightData l, vec2 uv) {
    float h = float(textureSize(u_envmap, 0).y);
    vec2 st = vec2(uv.x, (uv.y * (h - 1.0) + 0.5) / h);
    return textureLod(u_envmap, st, 0.0).rgb * l.params.x;
}

// The radiance an area light emits on its emitting side(s) at surface coordinates uv:
// uniform, or with an emission texture the radiance times the texture at uv
// (kEmissionTextures; uniform area sampling stays unbiased, as the estimators evaluate
// it at the point they sample or hit).
vec3 area_light_emitted(LightData l, vec2 uv) {
    vec3 Le = l.radiance.rgb;
    if (kEmissionTextures && l.emission_texture > 0.0) Le *= texture_eval(uint(l.emission_texture) - 1u, uv);
    return Le;
}

// Radiance leaving an area light's surface at surface coordinates uv, where its normal is
// n, toward direction w (unit, away).
vec3 area_light_radiance(LightData l, vec3 n, vec3 w, vec2 uv) {
    bool front = dot(n, w) > 0.0;
    bool two_sided = (l.info.y & kLightFlagTwoSided) != 0u;
    return (front || two_sided) ? area_light_emitted(l, uv) : vec3(0.0);
}

// The surface uv of the point p + a e1 + b e2 of a planar light, ab = (a, b).
vec2 planar_light_uv(LightData l, vec2 ab) {
    return l.uv0 + ab.x * l.uv_e1 + ab.y * l.uv_e2;
}

// (a, b) of a point q on the plane of a planar light: q = p + a e1 + b e2 (the edges need
// not be orthogonal; a triangle's (a, b) are its barycentrics of vertices 1 and 2).
vec2 planar_light_coordinates(LightData l, vec3 q) {
    vec3 d = q - l.p.xyz;
    float e11 = dot(l.e1.xyz, l.e1.xyz), e12 = dot(l.e1.xyz, l.e2.xyz), e22 = dot(l.e2.xyz, l.e2.xyz);
    float d1 = dot(d, l.e1.xyz), d2 = dot(d, l.e2.xyz);
    float det = e11 * e22 - e12 * e12;
    return det > 0.0 ? vec2(e22 * d1 - e12 * d2, e11 * d2 - e12 * d1) / det : vec2(0.0);
}

// Solid-angle pdf from an area pdf: p_A d^2 / |cos theta_l|.
float area_to_solid_angle(float pdf_area, float dist, vec3 n, vec3 wi) {
    float cos_l = abs(dot(n, wi));
    return cos_l > 0.0 ? pdf_area * dist * dist / cos_l : 0.0;
}

// Whether a planar light is sampled by solid angle as seen from p.
// Planar lights are sampled by solid angle only where they look large: spherical
// sampling costs several trigonometric functions, and for a light that subtends a
// small solid angle uniform area sampling has nearly the same variance. The choice
// uses a cheap estimate, A |cos theta_l| / d^2 from the light's centre, so that
// sampling and the MIS pdf always agree, and so that a SIMD vector of points far
// from every light skips the spherical code altogether.
const float kSphericalSamplingMinEstimate = 0.5;

bool planar_light_looks_large(LightData l, vec3 p, float centre_weight) {
    vec3 c = l.p.xyz + centre_weight * (l.e1.xyz + l.e2.xyz) - p;
    float d2 = dot(c, c);
    return l.n.w * abs(dot(l.n.xyz, c)) > kSphericalSamplingMinEstimate * d2 * sqrt(d2);
}

bool use_spherical_sampling_rectangle(LightData l, vec3 p, out float solid_angle) {
    solid_angle = 0.0;
    if (kAreaSampling != kAreaSamplingSolidAngle || (l.info.y & kLightFlagRectangle) == 0u) return false;
    if (!planar_light_looks_large(l, p, 0.5) || dot(l.p.xyz - p, l.n.xyz) == 0.0) return false;
    solid_angle = spherical_rectangle_setup(p, l.p.xyz, l.e1.xyz, l.e2.xyz).solid_angle;
    return solid_angle > kMinSphericalSampleArea && solid_angle < kMaxSphericalSampleArea;
}

bool use_spherical_sampling_triangle(LightData l, vec3 p, out float solid_angle) {
    solid_angle = 0.0;
    if (kAreaSampling != kAreaSamplingSolidAngle || !planar_light_looks_large(l, p, 1.0 / 3.0)) return false;
    vec3 v0 = l.p.xyz, v1 = v0 + l.e1.xyz, v2 = v0 + l.e2.xyz;
    float pdf = spherical_triangle_pdf(v0, v1, v2, p);
    solid_angle = pdf > 0.0 ? 1.0 / pdf : 0.0;
    return solid_angle > kMinSphericalSampleArea && solid_angle < kMaxSphericalSampleArea;
}

// Mitsuba 3's spot falloff for the cosine between the spot axis and the emission direction:
// 1 inside the beam width, 0 beyond the cutoff, and between them linear in the angle theta:
// (cutoff - theta) / (cutoff - beam_width) (src/emitters/spot.cpp, falloff_curve).
float spot_falloff(LightData l, float cos_theta) {
    float cos_cutoff = l.params.x, cos_beam = l.params.y;
    float cutoff = acos(cos_cutoff);
    float t = (cutoff - acos(clamp(cos_theta, -1.0, 1.0))) / max(cutoff - acos(cos_beam), 1e-8);
    return cos_theta >= cos_beam ? 1.0 : (cos_theta <= cos_cutoff ? 0.0 : clamp(t, 0.0, 1.0));
}

// Samples light l as seen from point p; u in [0,1)^2.
LightSample sample_light(LightData l, vec3 p, vec2 u) {
    LightSample s = LightSample(vec3(0.0, 0.0, 1.0), 0.0, vec3(0.0), 0.0, false);
    uint kind = l.info.x;
    if ((light_kind_present(kLightParallelogram) && kind == kLightParallelogram) ||
        (light_kind_present(kLightTriangle) && kind == kLightTriangle)) {
        bool triangle = kind == kLightTriangle;
        float solid_angle;
        bool spherical = triangle ? use_spherical_sampling_triangle(l, p, solid_angle)
                                  : use_spherical_sampling_rectangle(l, p, solid_angle);
        vec3 q;
        vec2 ab = vec2(0.0);
        float pdf_sa = 0.0;
        if (spherical) {
            if (triangle) {
                vec3 v0 = l.p.xyz;
                vec3 w = sample_spherical_triangle(v0, v0 + l.e1.xyz, v0 + l.e2.xyz, p, u, pdf_sa);
                float denom = dot(l.n.xyz, w);
                q = p + w * (dot(l.n.xyz, v0 - p) / denom);
            } else {
                q = sample_spherical_rectangle(p, l.p.xyz, l.e1.xyz, l.e2.xyz, u, pdf_sa);
            }
            if (kEmissionTextures && l.emission_texture > 0.0) ab = planar_light_coordinates(l, q);
        } else {
            ab = u;
            if (triangle) ab = sample_uniform_triangle(u).yz;
            q = l.p.xyz + ab.x * l.e1.xyz + ab.y * l.e2.xyz;
        }
        vec3 d = q - p;
        float dist = length(d);
        if (!(dist > 0.0)) return s;
        s.wi = d / dist;
        s.dist = dist;
        s.pdf = spherical ? pdf_sa : area_to_solid_angle(1.0 / l.n.w, dist, l.n.xyz, s.wi);
        s.Le = area_light_radiance(l, l.n.xyz, -s.wi, planar_light_uv(l, ab));
    } else if (light_kind_present(kLightSphere) && kind == kLightSphere) {
        vec3 c = l.p.xyz;
        float r = l.e1.w;
        vec3 to_c = c - p;
        float d2 = dot(to_c, to_c);
        if (d2 > r * r * 1.0001) {
            // Outside: uniform in the cone subtended (pbrt-v4 Sphere::Sample).
            float d = sqrt(d2);
            float sin2_max = r * r / d2;
            float cos_max = sqrt(max(0.0, 1.0 - sin2_max));
            Frame f = frame_from_z(to_c / d);
            vec3 w = frame_from_local(f, sample_uniform_cone(u, cos_max));
            // Distance to the sphere along w (nearest root).
            float b = dot(w, to_c);
            float disc = max(0.0, b * b - (d2 - r * r));
            float dist = b - sqrt(disc);
            vec3 n = normalize(p + dist * w - c);
            s.wi = w;
            s.dist = dist;
            s.pdf = uniform_cone_pdf(cos_max);
            s.Le = area_light_radiance(l, n, -w, vec2(0.0));
        } else {
            // Inside (or on) the sphere: uniform by area.
            vec3 n = sample_uniform_sphere(u);
            vec3 q = c + r * n;
            vec3 dvec = q - p;
            float dist = length(dvec);
            if (!(dist > 0.0)) return s;
            s.wi = dvec / dist;
            s.dist = dist;
            s.pdf = area_to_solid_angle(1.0 / l.n.w, dist, n, s.wi);
            s.Le = area_light_radiance(l, n, -s.wi, vec2(0.0));
        }
    } else if ((light_kind_present(kLightPoint) && kind == kLightPoint) ||
               (light_kind_present(kLightSpot) && kind == kLightSpot)) {
        vec3 d = l.p.xyz - p;
        float dist2 = dot(d, d);
        s.dist = sqrt(dist2);
        s.wi = d / s.dist;
        s.pdf = 1.0;
        s.delta = true;
        vec3 intensity = l.radiance.rgb;
        if (kind == kLightSpot) {
            // Mitsuba's spot falloff: 1 inside the beam width, linear in the angle to 0 at the cutoff.
            intensity *= spot_falloff(l, dot(-s.wi, l.n.xyz));
        }
        s.Le = intensity / dist2;
    } else if (light_kind_present(kLightDirectional) && kind == kLightDirectional) {
        s.wi = -l.n.xyz;
        s.dist = kInfinity;
        s.pdf = 1.0;
        s.delta = true;
        s.Le = l.radiance.rgb;
    } else if (light_kind_present(kLightConstant) && kind == kLightConstant) {
        s.wi = sample_uniform_sphere(u);
        s.dist = kInfinity;
        s.pdf = uniform_sphere_pdf();
        s.Le = l.radiance.rgb;
    } else if (light_kind_present(kLightEnvmap) && kind == kLightEnvmap) {
        float pdf_uv, sin_theta;
        vec2 uv = sample_distribution_2d(l.info.w, u, pdf_uv);
        s.wi = envmap_direction(l, uv, sin_theta);
        s.dist = kInfinity;
        s.pdf = sin_theta > 0.0 ? pdf_uv / (2.0 * kPi * kPi * sin_theta) : 0.0;
        s.Le = envmap_lookup(l, uv);
    }
    return s;
}

// Solid-angle pdf with which sample_light(l, p, .) returns the direction wi that
// reaches the light's surface at distance dist where its normal is n (area lights).
float light_pdf_area_hit(LightData l, vec3 p, vec3 wi, float dist, vec3 n) {
    uint kind = l.info.x;
    if ((light_kind_present(kLightParallelogram) && kind == kLightParallelogram) ||
        (light_kind_present(kLightTriangle) && kind == kLightTriangle)) {
        float solid_angle;
        bool spherical = kind == kLightTriangle ? use_spherical_sampling_triangle(l, p, solid_angle)
                                                : use_spherical_sampling_rectangle(l, p, solid_angle);
        return spherical ? 1.0 / solid_angle : area_to_solid_angle(1.0 / l.n.w, dist, n, wi);
    }
    if (light_kind_present(kLightSphere) && kind == kLightSphere) {
        vec3 to_c = l.p.xyz - p;
        float d2 = dot(to_c, to_c);
        float r = l.e1.w;
        if (d2 > r * r * 1.0001) {
            float cos_max = sqrt(max(0.0, 1.0 - r * r / d2));
            return uniform_cone_pdf(cos_max);
        }
        return area_to_solid_angle(1.0 / l.n.w, dist, n, wi);
    }
    return 0.0;
}

// Radiance from the environment along direction w (toward the environment), and
// the solid-angle pdf with which sample_light returns w.
vec3 environment_radiance(LightData l, vec3 w, out float pdf) {
    pdf = 0.0;
    if (light_kind_present(kLightConstant) && l.info.x == kLightConstant) {
        pdf = uniform_sphere_pdf();
        return l.radiance.rgb;
    }
    if (light_kind_present(kLightEnvmap) && l.info.x == kLightEnvmap) {
        float sin_theta;
        vec2 uv = envmap_uv(l, w, sin_theta);
        pdf = sin_theta > 0.0 ? distribution_2d_pdf(l.info.w, uv) / (2.0 * kPi * kPi * sin_theta) : 0.0;
        return envmap_lookup(l, uv);
    }
    return vec3(0.0);
}

// ---- Emission sampling: where light paths start ----------------------------------------
//
// Light tracing and bidirectional path tracing start a path on a light: a point and a
// direction with their densities, the point's per unit area, the direction's per unit
// solid angle (Veach 1997, sec. 10.2; pbrt-v4's Light::SampleLe). Area lights: a
// point uniform by area, a cosine-weighted direction on the emitting side (each side
// with probability 1/2 if two-sided). Point lights: uniform directions; spot lights:
// uniform in the cutoff cone. Directional and environment lights: the direction first,
// then a point uniform on the disk of the scene's bounding sphere's radius
// perpendicular to it, outside the scene (pbrt's "infinite" lights). The path's first
// throughput is Le |dot(n, d)| / (pdf_pos pdf_dir) in every case (n = d unless the
// point lies on a surface); delta positions and directions carry a density of 1.

struct LightEmission {
    vec3 p;          // start of the light path (world)
    vec3 n;          // surface normal at p on the emitting side (area lights), else d
    vec3 d;          // unit emission direction
    vec3 Le;         // radiance (area, environment), intensity (point, spot), irradiance (directional) along d
    vec2 uv;         // area lights: the surface uv at p (textured emission)
    float pdf_pos;   // density of p per unit area (1: a delta position)
    float pdf_dir;   // density of d per unit solid angle (1: a delta direction)
    bool delta_pos;  // point and spot lights
    bool delta_dir;  // directional lights
};

// Whether light l emits from a surface (parallelogram, triangle, sphere).
bool light_is_area(LightData l) {
    return l.info.x == kLightParallelogram || l.info.x == kLightTriangle || l.info.x == kLightSphere;
}

// Whether light l lies at infinity (directional, constant, environment map).
bool light_is_infinite(LightData l) {
    return l.info.x == kLightDirectional || l.info.x == kLightConstant || l.info.x == kLightEnvmap;
}

// Samples where and in which direction light l emits. u_pos, u_dir in [0,1)^2;
// scene_sphere: the scene's bounding sphere (centre xyz, radius w) for lights at
// infinity. Densities as in LightEmission; pdf_pos 0 when nothing was sampled.
LightEmission sample_light_emission(LightData l, vec2 u_pos, vec2 u_dir, vec4 scene_sphere) {
    LightEmission e = LightEmission(vec3(0.0), vec3(0.0, 0.0, 1.0), vec3(0.0, 0.0, 1.0), vec3(0.0),
                                    vec2(0.0), 0.0, 0.0, false, false);
    uint kind = l.info.x;
    if ((light_kind_present(kLightParallelogram) && kind == kLightParallelogram) ||
        (light_kind_present(kLightTriangle) && kind == kLightTriangle) ||
        (light_kind_present(kLightSphere) && kind == kLightSphere)) {
        vec3 n = l.n.xyz;
        if (kind == kLightSphere) {
            n = sample_uniform_sphere(u_pos);
            e.p = l.p.xyz + l.e1.w * n;
        } else {
            vec2 ab = kind == kLightTriangle ? sample_uniform_triangle(u_pos).yz : u_pos;
            e.p = l.p.xyz + ab.x * l.e1.xyz + ab.y * l.e2.xyz;
            e.uv = planar_light_uv(l, ab);
        }
        float side_pdf = 1.0;
        if ((l.info.y & kLightFlagTwoSided) != 0u) {
            // reuse u_dir.x for the side: each side with probability 1/2
            bool back = u_dir.x >= 0.5;
            u_dir.x = min(back ? 2.0 * u_dir.x - 1.0 : 2.0 * u_dir.x, kOneMinusEpsilon);
            n = back ? -n : n;
            side_pdf = 0.5;
        }
        vec3 local = sample_cosine_hemisphere(u_dir);
        e.n = n;
        e.d = frame_from_local(frame_from_z(n), local);
        e.pdf_pos = 1.0 / l.n.w;
        e.pdf_dir = side_pdf * cosine_hemisphere_pdf(local.z);
        e.Le = area_light_emitted(l, e.uv);
    } else if ((light_kind_present(kLightPoint) && kind == kLightPoint) ||
               (light_kind_present(kLightSpot) && kind == kLightSpot)) {
        e.p = l.p.xyz;
        e.pdf_pos = 1.0;
        e.delta_pos = true;
        e.Le = l.radiance.rgb;
        if (kind == kLightSpot) {
            float cos_cutoff = l.params.x;
            vec3 local = sample_uniform_cone(u_dir, cos_cutoff);
            e.d = frame_from_local(frame_from_z(l.n.xyz), local);
            e.pdf_dir = uniform_cone_pdf(cos_cutoff);
            e.Le *= spot_falloff(l, local.z);
        } else {
            e.d = sample_uniform_sphere(u_dir);
            e.pdf_dir = uniform_sphere_pdf();
        }
        e.n = e.d;
    } else if ((light_kind_present(kLightDirectional) && kind == kLightDirectional) ||
               (light_kind_present(kLightConstant) && kind == kLightConstant) ||
               (light_kind_present(kLightEnvmap) && kind == kLightEnvmap)) {
        if (kind == kLightDirectional) {
            e.d = l.n.xyz;
            e.pdf_dir = 1.0;
            e.delta_dir = true;
            e.Le = l.radiance.rgb;
        } else {
            // the direction toward the environment that sample_light would pick, reversed
            LightSample s = sample_light(l, scene_sphere.xyz, u_dir);
            e.d = -s.wi;
            e.pdf_dir = s.pdf;
            e.Le = s.Le;
        }
        float r = scene_sphere.w;
        Frame f = frame_from_z(e.d);
        vec2 disk = sample_uniform_disk_concentric(u_pos);
        e.p = scene_sphere.xyz + r * (frame_from_local(f, vec3(disk, -1.0)));
        e.n = e.d;
        e.pdf_pos = 1.0 / (kPi * r * r);
    }
    return e;
}

// Densities with which sample_light_emission(l, ., ., scene_sphere) returns the point p
// (area lights: n its normal on the emitting side) and the direction d: pdf_pos per
// unit area, pdf_dir per unit solid angle. For delta positions and directions the
// matching density is 1 (and the other one is that of the sampled component).
void light_emission_pdf(LightData l, vec3 p, vec3 n, vec3 d, vec4 scene_sphere,
                        out float pdf_pos, out float pdf_dir) {
    pdf_pos = 0.0;
    pdf_dir = 0.0;
    uint kind = l.info.x;
    if ((light_kind_present(kLightParallelogram) && kind == kLightParallelogram) ||
        (light_kind_present(kLightTriangle) && kind == kLightTriangle) ||
        (light_kind_present(kLightSphere) && kind == kLightSphere)) {
        float cos_theta = dot(n, d);
        bool two_sided = (l.info.y & kLightFlagTwoSided) != 0u;
        pdf_pos = 1.0 / l.n.w;
        pdf_dir = cos_theta > 0.0 ? (two_sided ? 0.5 : 1.0) * cosine_hemisphere_pdf(cos_theta) : 0.0;
    } else if ((light_kind_present(kLightPoint) && kind == kLightPoint) ||
               (light_kind_present(kLightSpot) && kind == kLightSpot)) {
        pdf_pos = 1.0;
        if (kind == kLightSpot) {
            float cos_cutoff = l.params.x;
            pdf_dir = dot(d, l.n.xyz) > cos_cutoff ? uniform_cone_pdf(cos_cutoff) : 0.0;
        } else {
            pdf_dir = uniform_sphere_pdf();
        }
    } else if ((light_kind_present(kLightDirectional) && kind == kLightDirectional) ||
               (light_kind_present(kLightConstant) && kind == kLightConstant) ||
               (light_kind_present(kLightEnvmap) && kind == kLightEnvmap)) {
        pdf_pos = 1.0 / (kPi * scene_sphere.w * scene_sphere.w);
        if (kind == kLightDirectional) pdf_dir = 1.0;
        else environment_radiance(l, -d, pdf_dir);
    }
}
