"""The host/device contract: scene/layout.glsl and glrender/gpu/layout.py agree.

Struct layouts are compared by writing every field from numpy with distinct values and
reading each back on the device (binding points and flag bits: tests/gpu/test_bindings.py).
"""
import re

import numpy as np
import pytest

from glrender.gl.shaders import ShaderLibrary, compile_compute
from glrender.gpu import bindings, layout
from glrender.render.params import shader_defines

LAYOUT = ShaderLibrary().read("scene/layout.glsl")


def struct_fields(name):
    body = re.search(r"struct %s \{(.*?)\};" % name, LAYOUT, re.S).group(1)
    return [(t, n) for t, n in re.findall(r"^\s*(\w+)\s+(\w+)(?:\[\d+\])?;", body, re.M)]


@pytest.mark.parametrize("struct, dtype", [("MaterialData", layout.MATERIAL), ("LightData", layout.LIGHT),
                                           ("MediumData", layout.MEDIUM)])
def test02_struct_fields_in_order(struct, dtype):
    assert [n for _, n in struct_fields(struct)] == list(dtype.names)


COPY_SHADER = """#version 450
layout(local_size_x = 1) in;
#include "scene/layout.glsl"
layout(std430, binding = 7) buffer Out { uint words[]; };
void put(inout uint k, vec4 v) { for (int i = 0; i < 4; ++i) words[k++] = floatBitsToUint(v[i]); }
void put(inout uint k, uvec4 v) { for (int i = 0; i < 4; ++i) words[k++] = v[i]; }
void put(inout uint k, mat4 m) { for (int c = 0; c < 4; ++c) put(k, m[c]); }
void main() {
    uint k = 0u;
    for (uint i = 0u; i < 2u; ++i) {
        MaterialData m = materials[i];
        put(k, vec4(m.color0, m.opacity_texture)); put(k, vec4(m.color1, m.alpha_cutoff));
        put(k, vec4(m.color2, m.normal_scale)); put(k, vec4(m.params, m.normal_map)); put(k, m.info);
        for (int j = 0; j < 64; ++j) words[k++] = floatBitsToUint(m.table[j]);
    }
    for (uint i = 0u; i < 2u; ++i) {
        LightData l = lights[i];
        put(k, l.p); put(k, l.e1); put(k, l.e2); put(k, l.n); put(k, l.radiance);
        put(k, vec4(l.params, l.selection_pmf)); put(k, l.info);
        put(k, vec4(l.uv0, l.uv_e1)); put(k, vec4(l.uv_e2, l.emission_texture, l.pad));
    }
    put(k, u_params.camera_open); put(k, u_params.camera_close); put(k, u_params.camera_screen);
    put(k, u_params.camera_clip); put(k, u_params.shutter); put(k, u_params.filter_params);
    put(k, u_params.image); put(k, u_params.samples); put(k, u_params.dispatch); put(k, u_params.counts);
    put(k, u_params.scene_sphere);
    put(k, uvec4(floatBitsToUint(u_params.ao_distance), floatBitsToUint(u_params.sample_clamp),
                 u_params.camera_projection, floatBitsToUint(u_params.unused)));
    put(k, u_media.media_counts);
    for (int i = 0; i < kMaxMedia; ++i) {
        MediumData d = u_media.media[i];
        put(k, d.sigma_t); put(k, d.sigma_s); put(k, d.info); put(k, d.grid_from_world);
        put(k, d.sigma_grid); put(k, d.albedo_grid); put(k, d.majorant); put(k, d.majorant_grid);
    }
}
"""


def fill(dtype, count, start):
    arr = np.zeros(count, dtype)
    words = arr.view(np.uint32).reshape(count, -1)
    words[:] = np.arange(start, start + words.size, dtype=np.uint32).reshape(words.shape)
    return arr


def test03_structs_round_trip_on_device(gl_ctx):
    gl = gl_ctx.gl
    mats = fill(layout.MATERIAL, 2, 1000)
    lights = fill(layout.LIGHT, 2, 2000)
    params = fill(layout.RENDER_PARAMS, 1, 3000)
    media = fill(layout.MEDIA, 1, 4000)
    program = compile_compute(gl_ctx, source=COPY_SHADER, defines=shader_defines())
    n_words = (mats.nbytes + lights.nbytes + params.nbytes + media.nbytes) // 4
    bufs = [gl.buffer(mats.tobytes()), gl.buffer(lights.tobytes()), gl.buffer(params.tobytes()),
            gl.buffer(media.tobytes()), gl.buffer(reserve=4 * n_words)]
    bufs[0].bind_to_storage_buffer(bindings.SSBO_MATERIALS)
    bufs[1].bind_to_storage_buffer(bindings.SSBO_LIGHTS)
    bufs[2].bind_to_uniform_block(bindings.UBO_RENDER_PARAMS)
    bufs[3].bind_to_uniform_block(bindings.UBO_MEDIA)
    bufs[4].bind_to_storage_buffer(7)
    program.run(1)
    out = np.frombuffer(bufs[4].read(), np.uint32)
    expected = np.concatenate([mats.view(np.uint32), lights.view(np.uint32), params.view(np.uint32),
                               media.view(np.uint32)])
    np.testing.assert_array_equal(out, expected)
    for b in bufs:
        b.release()
