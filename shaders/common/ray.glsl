// Rays and the origin offset that keeps secondary rays off the surface they leave.

// A ray o + t d, t in (0, t_max); d need not be normalized unless a caller says so.
struct Ray {
    vec3 o;
    vec3 d;
};

// Offsets a ray origin p along the geometric normal n, away from the side of
// direction w, by an amount that grows with |p| (float32 rounding of p scales
// with its magnitude; cf. Wächter & Binder, Ray Tracing Gems ch. 6).
vec3 offset_ray_origin(vec3 p, vec3 n, vec3 w) {
    const float kOrigin = 1.0 / 32.0;
    const float kFloatScale = 1.0 / 65536.0;
    const float kIntScale = 256.0;
    vec3 nn = dot(n, w) < 0.0 ? -n : n;
    ivec3 of_i = ivec3(kIntScale * nn);
    vec3 p_i = intBitsToFloat(floatBitsToInt(p) + ivec3(p.x < 0.0 ? -of_i.x : of_i.x,
                                                       p.y < 0.0 ? -of_i.y : of_i.y,
                                                       p.z < 0.0 ? -of_i.z : of_i.z));
    return vec3(abs(p.x) < kOrigin ? p.x + kFloatScale * nn.x : p_i.x,
                abs(p.y) < kOrigin ? p.y + kFloatScale * nn.y : p_i.y,
                abs(p.z) < kOrigin ? p.z + kFloatScale * nn.z : p_i.z);
}
