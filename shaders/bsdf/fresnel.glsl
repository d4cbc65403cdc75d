// Fresnel reflectance of dielectric and conductor interfaces, and mirror/refraction of directions.
//
// Local frame, +z = the interface normal. `cos_theta` is the cosine between the normal
// and the direction on the incident side (either wo or wi: Fresnel reflectance is the
// same both ways); its sign says the side, > 0 outside. `eta` is the relative IOR
// interior / exterior (Mitsuba's convention: > 1 when the normal points into the less
// dense medium). Formulas as in Mitsuba 3's fresnel.h, so the models match it.

// The unpolarized Fresnel term of a dielectric interface and the refracted cosine.
struct FresnelDielectric {
    float F;            // reflectance in [0, 1]; 1 under total internal reflection
    float cos_theta_t;  // cosine of the refracted direction, on the other side (0 under TIR)
    float eta_it;       // IOR of the far side / IOR of the incident side
    float eta_ti;       // 1 / eta_it: the scale of the x, y components when refracting
};

// Reflectance of unpolarized light at a dielectric interface (average of the s and p
// amplitudes squared, Hecht 4.34-4.40), for cos_theta in [-1, 1] and eta > 0.
// Index-matched (eta = 1) gives F = 0; grazing (cos_theta = 0) gives F = 1.
FresnelDielectric fresnel_dielectric(float cos_theta, float eta) {
    bool outside = cos_theta >= 0.0;
    float eta_it = outside ? eta : 1.0 / eta;
    float eta_ti = outside ? 1.0 / eta : eta;
    // Snell's law: cos^2 theta_t = 1 - sin^2 theta_i / eta_it^2 (negative under TIR)
    float cos_t2 = 1.0 - (1.0 - cos_theta * cos_theta) * (eta_ti * eta_ti);
    float ci = abs(cos_theta);
    float ct = sqrt(max(cos_t2, 0.0));
    float a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    float a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    float F = 0.5 * (a_s * a_s + a_p * a_p);
    if (eta == 1.0) F = 0.0;
    else if (ci == 0.0) F = 1.0;
    return FresnelDielectric(F, outside ? -ct : ct, eta_it, eta_ti);
}

// Reflectance of unpolarized light arriving from outside (cos_theta >= 0) at a
// conductor of complex relative IOR eta + i k, per RGB channel (Moeller, "Optics",
// 1988, as in Mitsuba 3). eta = 0, k = 1 is an ideal mirror (F = 1).
vec3 fresnel_conductor(float cos_theta, vec3 eta, vec3 k) {
    float c2 = cos_theta * cos_theta;
    float s2 = 1.0 - c2;
    vec3 t1 = eta * eta - k * k - s2;
    vec3 a2b2 = sqrt(max(t1 * t1 + 4.0 * k * k * eta * eta, 0.0));
    vec3 a = sqrt(max(0.5 * (a2b2 + t1), 0.0));
    vec3 term1 = a2b2 + c2;
    vec3 term2 = 2.0 * cos_theta * a;
    vec3 r_s = (term1 - term2) / (term1 + term2);
    vec3 term3 = a2b2 * c2 + s2 * s2;
    vec3 term4 = term2 * s2;
    vec3 r_p = r_s * (term3 - term4) / (term3 + term4);
    return 0.5 * (r_s + r_p);
}

// Mirror direction of w about the normal +z (local frame).
vec3 reflect_local(vec3 w) {
    return vec3(-w.xy, w.z);
}

// Mirror direction of w about the unit microfacet normal m: 2 (w.m) m - w.
vec3 reflect_about(vec3 w, vec3 m) {
    return 2.0 * dot(w, m) * m - w;
}

// Refracted direction of w (pointing away from the interface) about the normal +z,
// given fresnel_dielectric(w.z, eta)'s cos_theta_t and eta_ti.
vec3 refract_local(vec3 w, float cos_theta_t, float eta_ti) {
    return vec3(-eta_ti * w.xy, cos_theta_t);
}

// Refracted direction of w about the unit microfacet normal m, given
// fresnel_dielectric(dot(w, m), eta)'s cos_theta_t and eta_ti (Walter et al. 2007, eq. 40).
vec3 refract_about(vec3 w, vec3 m, float cos_theta_t, float eta_ti) {
    return m * (dot(w, m) * eta_ti + cos_theta_t) - w * eta_ti;
}
