// The camera seen from the scene: where a point projects on the film and the importance
// the camera's measurement gives it (the adjoint of camera/camera.glsl's rays).
//
// A pixel's value is I_j = ∫ h_j(film(w)) L(w) d(film) with h_j the normalized pixel
// filter around the pixel's centre. On the plane z = 1 of camera space a pixel covers
// a = (2 tan(fov_x/2) / W)(2 tan(fov_y/2) / H), and d(film) = dw / (a cos^3 theta), so
// the importance per unit solid angle is W_j = h_j / (a cos^3 theta) (pbrt-v3's
// PerspectiveCamera::We with its cos^4 and the lens cosine of G cancelling one power).
// A thin lens sampled uniformly by area gives the same expression per lens point
// (the lens pdf cancels the importance's 1 / lens area). Rigid camera matrices only:
// distances in camera space are taken as world distances.
// An orthographic camera's rays have one direction (a delta in direction): no scene
// point can be connected to it, and its rays have no density per solid angle (0 here,
// which the MIS ratios count as 1, pbrt's remap0; bdpt marks its camera vertex delta).
#include "common/constants.glsl"
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "sampling/disk.glsl"
#include "camera/filter.glsl"
#include "camera/camera.glsl"

// A connection from a scene point to the lens.
struct CameraConnection {
    vec3 p;            // the lens point (world)
    vec3 wi;           // unit direction from the scene point toward p (world)
    float dist;        // distance from the scene point to p
    vec2 film;         // film position in pixels, origin at the top-left corner
    float importance;  // W_e |cos_lens| / (d^2 p_lens) without the filter's h_j (per unit area at the point)
    float pdf_dir;     // solid-angle density of a camera ray along -wi, the film taken as a whole
    bool valid;        // in front of the camera, between the clip planes, near the film
};

// world_from_camera at normalized shutter time tau (as camera_ray interpolates it).
mat4 world_from_camera_at(float tau) {
    mat4 m = u_params.camera_open;
    if (tau > 0.0) m = m + tau * (u_params.camera_close - u_params.camera_open);
    return m;
}

// Connects the world point x to the lens at time tau; u_lens in [0,1)^2 picks the lens
// point (thin lens, uniform by area; ignored for a pinhole).
CameraConnection camera_connect(vec3 x, vec2 u_lens, float tau) {
    CameraConnection c = CameraConnection(vec3(0.0), vec3(0.0, 0.0, 1.0), 0.0, vec2(0.0), 0.0, 0.0, false);
    if (u_params.camera_projection == kCameraOrthographic) return c;
    mat4 m = world_from_camera_at(tau);
    vec3 x_cam = (inverse(m) * vec4(x, 1.0)).xyz;
    float lens_radius = u_params.camera_screen.z;
    vec3 lens = lens_radius > 0.0 ? vec3(lens_radius * sample_uniform_disk_concentric(u_lens), 0.0) : vec3(0.0);
    vec3 q = x_cam - lens;
    if (!(q.z >= u_params.camera_clip.x && q.z <= u_params.camera_clip.y)) return c;
    // the pinhole direction (z = 1) whose focal-plane point the ray from the lens point meets
    vec2 dir = q.xy / q.z;
    if (lens_radius > 0.0) dir += lens.xy / u_params.camera_screen.w;
    vec2 tangents = u_params.camera_screen.xy;
    vec2 size = vec2(u_params.image.xy);
    c.film = 0.5 * (1.0 - dir / tangents) * size;
    float r = u_params.filter_params.x;
    if (any(lessThan(c.film, vec2(-r))) || any(greaterThan(c.film, size + r))) return c;
    c.p = (m * vec4(lens, 1.0)).xyz;
    vec3 to_lens = c.p - x;
    c.dist = length(to_lens);
    if (!(c.dist > 0.0)) return c;
    c.wi = to_lens / c.dist;
    float cos_theta = q.z / length(q);
    float a = 4.0 * tangents.x * tangents.y / (size.x * size.y);
    float a_cos3 = a * cos_theta * cos_theta * cos_theta;
    c.importance = 1.0 / (a_cos3 * c.dist * c.dist);
    c.pdf_dir = 1.0 / (a_cos3 * size.x * size.y);
    c.valid = true;
    return c;
}

// The solid-angle density of a camera ray along the world direction d from the lens,
// the film taken as a whole (1 / (W H a cos^3 theta)); 0 outside the field of view, and
// for an orthographic camera (a delta direction).
float camera_pdf_dir(vec3 d, float tau) {
    if (u_params.camera_projection == kCameraOrthographic) return 0.0;
    vec3 d_cam = transpose(mat3(world_from_camera_at(tau))) * d;
    if (!(d_cam.z > 0.0)) return 0.0;
    vec2 tangents = u_params.camera_screen.xy;
    vec2 size = vec2(u_params.image.xy);
    float cos_theta = d_cam.z / length(d_cam);
    float a = 4.0 * tangents.x * tangents.y / (size.x * size.y);
    return 1.0 / (a * cos_theta * cos_theta * cos_theta * size.x * size.y);
}

// 1D normalized filter density at offset x (pixels), radius r: ∫ = 1 over [-r, r].
float pixel_filter_density_1d(float x, vec4 params) {
    float r = params.x;
    if (abs(x) > r) return 0.0;
    if (kFilter == kFilterBox) return 0.5 / r;
    if (kFilter == kFilterTent) return (1.0 - abs(x) / r) / r;
    if (kFilter == kFilterGaussian) {
        float s = params.y;
        float g_r = exp(-r * r / (2.0 * s * s));
        float integral_g = s * 1.41421356237 * 1.77245385091 * erf_approx(r / (s * 1.41421356237));
        return (exp(-x * x / (2.0 * s * s)) - g_r) / (integral_g - 2.0 * r * g_r);
    }
    return mitchell_1d(x, r, params.z, params.w) / (0.5 * r);
}

// The normalized pixel filter h(offset) (offset from the pixel centre, in pixels): a
// camera sample at film position c + offset counts toward the pixel centred at c with
// this density (camera/filter.glsl samples it).
float pixel_filter_density(vec2 offset, vec4 params) {
    return pixel_filter_density_1d(offset.x, params) * pixel_filter_density_1d(offset.y, params);
}
