// Ray / sphere intersection, numerically robust for small spheres far away.
//
// Solves |o + t d - c|^2 = r^2 with the discriminant computed from the squared
// distance between c and the ray's closest point (Haines et al., "Precision
// Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7), and the
// nearer root from the stable quadratic form.

// Ray parameter of the nearest hit in (0, t_max), or t_max if there is none.
float intersect_sphere(vec3 o, vec3 d, float t_max, vec3 center, float radius) {
    vec3 f = o - center;
    float a = dot(d, d);
    float b = -dot(f, d);
    vec3 l = f + (b / a) * d;                     // centre to the ray's closest point
    float disc = a * (radius * radius - dot(l, l));
    if (disc < 0.0) return t_max;
    float q = b + (b >= 0.0 ? sqrt(disc) : -sqrt(disc));
    float c = dot(f, f) - radius * radius;
    float t0 = c / q;
    float t1 = q / a;
    float t_near = min(t0, t1);
    float t_far = max(t0, t1);
    float t = t_near > 0.0 ? t_near : t_far;
    return (t > 0.0 && t < t_max) ? t : t_max;
}
