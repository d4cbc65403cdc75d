// Surface textures as Mitsuba 3 evaluates them: `bitmap` (nearest or bilinear lookups,
// repeat / mirror / clamp wrapping) and `checkerboard`, each after its own affine uv
// transform. Records and layers come from glrender/gpu/textures.py: five texels per
// texture in u_texture_records, bitmaps packed into atlas pages (layers of u_textures),
// each at its own texel offset. Filtering and wrapping are done here with texelFetch
// inside the bitmap's own rectangle, so every texture keeps its own size, filter and
// wrap mode and never reads its neighbours in the page.
//
// uv convention (Mitsuba's): u runs along the image rows, v down its rows (v = 0 is the
// first row of the file); loaders flip v where a format counts it upward (OBJ).
#include "scene/layout.glsl"

const uint kTextureBitmap = 0u;
const uint kTextureCheckerboard = 1u;
const uint kTextureFilterNearest = 0u;
const uint kTextureWrapRepeat = 0u;
const uint kTextureWrapMirror = 1u;
const uint kTextureWrapClamp = 2u;
const int kTextureRecordTexels = 5;

// Maps a texel coordinate (any integer, as a float) into [0, n) by the wrap mode
// (Mitsuba's mirror: ... 1 0 | 0 1 ... n-1 | n-1 ...). Float arithmetic keeps negative
// coordinates well defined (GLSL leaves % of negative ints undefined); exact below 2^24.
int texture_wrap(float i, float n, uint mode) {
    float j;
    if (mode == kTextureWrapClamp) {
        j = i;
    } else if (mode == kTextureWrapMirror) {
        j = mod(i, 2.0 * n);
        j = j < n ? j : 2.0 * n - 1.0 - j;
    } else {
        j = mod(i, n);
    }
    // the clamp also catches NaN and rounding at the edges
    return int(clamp(j, 0.0, n - 1.0));
}

// One texel of a bitmap at `offset` in atlas page `layer`, wrapped inside its size.
vec3 texture_texel(float x, float y, vec2 size, ivec2 offset, int layer, uint wrap) {
    ivec3 p = ivec3(offset + ivec2(texture_wrap(x, size.x, wrap), texture_wrap(y, size.y, wrap)),
                    layer);
    return texelFetch(u_textures, p, 0).rgb;
}

// The colour of texture `index` (0-based) at surface uv (any real numbers; the
// texture's wrap mode maps them into the image). Linear RGB.
vec3 texture_eval(uint index, vec2 uv) {
    int base = int(index) * kTextureRecordTexels;
    vec4 header = texelFetch(u_texture_records, base);        // kind, layer, width, height
    vec4 row0 = texelFetch(u_texture_records, base + 1);      // uv transform row 0, filter
    vec4 row1 = texelFetch(u_texture_records, base + 2);      // uv transform row 1, wrap
    vec2 st = vec2(dot(row0.xyz, vec3(uv, 1.0)), dot(row1.xyz, vec3(uv, 1.0)));
    if (uint(header.x) == kTextureCheckerboard) {
        // Mitsuba's checkerboard: colour 0 where both fractional parts lie on the same
        // side of 1/2, colour 1 elsewhere
        bvec2 upper = greaterThan(st - floor(st), vec2(0.5));
        return texelFetch(u_texture_records, base + (upper.x == upper.y ? 3 : 4)).rgb;
    }
    int layer = int(header.y);
    vec2 size = header.zw;
    ivec2 offset = ivec2(texelFetch(u_texture_records, base + 3).xy);
    uint wrap = uint(row1.w);
    vec2 x = st * size;
    if (uint(row0.w) == kTextureFilterNearest) {
        return texture_texel(floor(x.x), floor(x.y), size, offset, layer, wrap);
    }
    // bilinear between the four nearest texel centres (at integer + 1/2)
    x -= 0.5;
    vec2 i0 = floor(x);
    vec2 w = x - i0;
    vec3 c00 = texture_texel(i0.x, i0.y, size, offset, layer, wrap);
    vec3 c10 = texture_texel(i0.x + 1.0, i0.y, size, offset, layer, wrap);
    vec3 c01 = texture_texel(i0.x, i0.y + 1.0, size, offset, layer, wrap);
    vec3 c11 = texture_texel(i0.x + 1.0, i0.y + 1.0, size, offset, layer, wrap);
    return mix(mix(c00, c10, w.x), mix(c01, c11, w.x), w.y);
}
