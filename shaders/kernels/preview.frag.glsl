#version 450
// The preview's display pass, fragment stage. Two uses (u_source):
// - kSourceAccumulation: one fragment per image pixel (an image-sized framebuffer): the
//   renderer's accumulation, read straight from its storage buffers (no read-back),
//   through exposure, a tone curve and sRGB. Pixels without samples yet show the held
//   image, if there is one (what was on screen before the camera or the kernel changed,
//   so a moving view never flashes black), else black.
// - kSourceTexture: the window, any size: the image-sized result above, nearest (the
//   costly per-pixel work then runs once per image pixel, not per window pixel).
//
// Views (glrender/preview/display.py names them in this order):
// - color: the running mean radiance;
// - albedo: the first-hit albedo AOV, sRGB-encoded (no exposure, no curve);
// - normal: the first-hit normal AOV mapped from [-1, 1] to [0, 1] (no encoding);
// - variance: the per-sample variance M2 / (n - 1), through exposure and curve like color.
#include "scene/layout.glsl"
#include "film/tonemap.glsl"
#include "film/accum.glsl"

const int kViewColor = 0;
const int kViewAlbedo = 1;
const int kViewNormal = 2;
const int kViewVariance = 3;

const int kSourceAccumulation = 0;
const int kSourceTexture = 1;

uniform uvec2 u_image;       // image width, height in pixels
uniform vec4 u_viewport;     // where the image lies in the framebuffer: x, y, width, height (pixels)
uniform int u_source;        // kSource*
uniform int u_view;          // kView*
uniform int u_curve;         // kToneCurve* (film/tonemap.glsl)
uniform float u_scale;       // 2^exposure
uniform bool u_srgb;         // encode with the sRGB transfer function
uniform bool u_has_aovs;     // the accumulation holds albedo and normal AOVs
uniform bool u_has_texture;  // u_texture holds an image (kSourceAccumulation: the held one)
uniform sampler2D u_texture; // image-sized, rows bottom to top (a framebuffer's)

out vec4 frag_color;

// The display value of image pixel `idx` of the accumulation (exposure, curve, encoding);
// count: its count of finite samples (> 0).
vec3 accumulation_color(uint idx, uint count) {
    double n = double(count);
    dvec3 mean = dvec3(accum_value(accum_sum[4u * idx]), accum_value(accum_sum[4u * idx + 1u]),
                       accum_value(accum_sum[4u * idx + 2u])) / n;
    if (u_view == kViewColor) return display_encode(vec3(mean), u_scale, u_curve, u_srgb);
    if (u_view == kViewVariance) {
        dvec3 sq = dvec3(accum_value(accum_sq[3u * idx]), accum_value(accum_sq[3u * idx + 1u]),
                         accum_value(accum_sq[3u * idx + 2u]));
        vec3 variance = count > 1u ? vec3(max(sq - mean * mean * n, 0.0LF) / (n - 1.0LF)) : vec3(0.0);
        return display_encode(variance, u_scale, u_curve, u_srgb);
    }
    if (!u_has_aovs) return vec3(0.0);
    uint base = kAovChannels * idx;
    vec3 a = vec3(dvec3(accum_value(accum_aov[base]), accum_value(accum_aov[base + 1u]),
                        accum_value(accum_aov[base + 2u])) / n);
    if (u_view == kViewAlbedo) return display_encode(a, 1.0, kToneCurveClamp, u_srgb);
    vec3 normal = vec3(dvec3(accum_value(accum_aov[base + 3u]), accum_value(accum_aov[base + 4u]),
                             accum_value(accum_aov[base + 5u])) / n);
    return clamp(0.5 * normal + 0.5, 0.0, 1.0);
}

void main() {
    // image pixel under this fragment; image rows run top to bottom, GL's y up
    vec2 uv = (gl_FragCoord.xy - u_viewport.xy) / u_viewport.zw;
    vec2 size = vec2(u_image);
    uvec2 pixel = uvec2(clamp(floor(vec2(uv.x, 1.0 - uv.y) * size), vec2(0.0), size - 1.0));
    ivec2 texel = ivec2(pixel.x, u_image.y - 1u - pixel.y);

    vec3 rgb = vec3(0.0);
    if (u_source == kSourceTexture) {
        rgb = texelFetch(u_texture, texel, 0).rgb;
    } else {
        uint idx = pixel.y * u_image.x + pixel.x;
        uint n = accum_sum[4u * idx + 3u].x;
        if (n > 0u) {
            rgb = accumulation_color(idx, n);
        } else if (u_has_texture) {
            rgb = texelFetch(u_texture, texel, 0).rgb;
        }
    }
    frag_color = vec4(rgb, 1.0);
}
