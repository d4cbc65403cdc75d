// Camera rays: the measurement equation's pixel, lens and time integrals.
//
// Mitsuba's perspective / thin-lens and orthographic cameras: camera space looks along
// +z with +y up and +x to the left of the image. u_params.camera_screen.xy is half the
// film's extent along x and y (host-side, per fov_axis): on the plane z = 1 for a
// perspective camera (tangents of the half angles), on the plane z = 0 in camera units
// for an orthographic one, whose rays all run along +z. A thin lens of radius R focused
// at distance F: the ray leaves a point of the lens disk (concentric mapping) toward the
// point of the focal plane the pinhole ray would reach. The camera-to-world matrix is
// interpolated linearly between shutter open and close (time tau in [0, 1]) and the
// direction renormalized.
#include "scene/layout.glsl"
#include "sampling/disk.glsl"

// u_params.camera_projection (glrender/gpu/layout.py CAMERA_PROJECTIONS)
const uint kCameraPerspective = 0u;
const uint kCameraOrthographic = 1u;

// Normalized time in [0, 1] sampled from the shutter function; u in [0, 1).
float sample_shutter_time(float u) {
    if (u_params.shutter.z == 1.0)  // tent: triangle density on [0, 1]
        return u < 0.5 ? sqrt(0.5 * u) : 1.0 - sqrt(0.5 * (1.0 - u));
    return u;
}

// Ray through film position `film` (pixels, origin at the top-left corner) at
// normalized time tau; u_lens in [0,1)^2 (thin lens only). t_min, t_max: the near and
// far clip planes' distances along the ray.
void camera_ray(vec2 film, vec2 u_lens, float tau, out vec3 o, out vec3 d, out float t_min, out float t_max) {
    vec2 ndc = film / vec2(u_params.image.xy);
    vec3 dir = vec3((1.0 - 2.0 * ndc.x) * u_params.camera_screen.x,
                    (1.0 - 2.0 * ndc.y) * u_params.camera_screen.y, 1.0);
    vec3 origin = vec3(0.0);
    float lens_radius = u_params.camera_screen.z;
    if (u_params.camera_projection == kCameraOrthographic) {
        // the film point on the plane z = 0, looking along +z (no lens)
        origin = vec3(dir.xy, 0.0);
        dir = vec3(0.0, 0.0, 1.0);
    } else if (lens_radius > 0.0) {
        vec3 focus = dir * u_params.camera_screen.w;
        origin = vec3(lens_radius * sample_uniform_disk_concentric(u_lens), 0.0);
        dir = focus - origin;
    }
    float inv_z = 1.0 / length(dir);
    dir *= inv_z;
    mat4 m = u_params.camera_open;
    if (tau > 0.0) m = m + tau * (u_params.camera_close - u_params.camera_open);
    o = (m * vec4(origin, 1.0)).xyz;
    d = normalize(mat3(m) * dir);
    // near / far clip planes are distances along camera z
    t_min = u_params.camera_clip.x / max(dir.z, 1e-6);
    t_max = u_params.camera_clip.y / max(dir.z, 1e-6);
}
