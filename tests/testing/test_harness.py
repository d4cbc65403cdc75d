"""The GLSL test harness: types, sizes, chunking, uniforms, tables and its error messages."""
import numpy as np
import pytest

from glrender.errors import ShaderError, UsageError
from glrender.testing.harness import run_glsl


@pytest.mark.parametrize("glsl_type, dtype, comps", [
    ("float", np.float32, 1), ("vec2", np.float32, 2), ("vec3", np.float32, 3),
    ("vec4", np.float32, 4), ("int", np.int32, 1), ("ivec3", np.int32, 3),
    ("uint", np.uint32, 1), ("uvec2", np.uint32, 2), ("uvec4", np.uint32, 4),
])
def test01_round_trip_every_type(gl_ctx, glsl_type, dtype, comps):
    rng = np.random.default_rng(1)
    shape = (1000,) if comps == 1 else (1000, comps)
    if dtype == np.float32:
        x = rng.standard_normal(shape).astype(dtype)
    else:
        x = rng.integers(0 if dtype == np.uint32 else -1000, 1000, shape).astype(dtype)
    out = run_glsl(f"{glsl_type} y = x + x;", {"x": x}, {"y": glsl_type})
    assert out["y"].dtype == dtype and out["y"].shape == shape
    np.testing.assert_array_equal(out["y"], x + x)


def test02_bool_in_and_out(gl_ctx):
    b = np.array([True, False, True])
    out = run_glsl("bool y = !b;", {"b": b}, {"y": "bool"})
    np.testing.assert_array_equal(out["y"], ~b)


def test03_expression_form_and_index(gl_ctx):
    out = run_glsl("index * 3u", n=7, outputs={"k": "uint"})
    np.testing.assert_array_equal(out["k"], np.arange(7) * 3)


def test04_ten_million_elements_in_chunks(gl_ctx):
    n = 10_000_003  # not a multiple of the chunk or the work group size
    x = np.arange(n, dtype=np.uint32)
    out = run_glsl("uint y = x ^ index;", {"x": x}, {"y": "uint"})
    assert out["y"].shape == (n,) and not out["y"].any()


def test05_uniforms_tables_and_includes(gl_ctx):
    u = np.linspace(0, 1, 11, dtype=np.float32)
    table = np.array([10.0, 20.0, 30.0], np.float32)
    out = run_glsl("float y = u * scale + table[2] + kPi;", {"u": u}, {"y": "float"},
                   uniforms={"scale": 2.0}, buffers={"table": table},
                   includes=["common/constants.glsl"])
    np.testing.assert_allclose(out["y"], u * 2 + 30 + np.pi, rtol=1e-6)
    out = run_glsl("vec3 y = vec3(offset, 1.0);", n=2, outputs={"y": "vec3"},
                   uniforms={"offset": ("vec2", (0.25, 0.5))})
    np.testing.assert_array_equal(out["y"], [[0.25, 0.5, 1.0]] * 2)


def test06_several_outputs_and_defines(gl_ctx):
    x = np.arange(4, dtype=np.float32)
    out = run_glsl("float a = x * K; int b = int(x) - 1;", {"x": x}, {"a": "float", "b": "int"},
                   defines={"K": 3.0})
    np.testing.assert_array_equal(out["a"], x * 3)
    np.testing.assert_array_equal(out["b"], [-1, 0, 1, 2])


@pytest.mark.parametrize("kwargs, message", [
    (dict(inputs={"u": np.zeros((5, 3), np.float32)}, input_types={"u": "vec2"}),
     r"input 'u': expected shape \(N, 2\) for vec2, got \(5, 3\)"),
    (dict(inputs={"u": np.zeros((5, 5), np.float32)}), r"input 'u': expected shape \(N,\) or \(N, 2..4\)"),
    (dict(inputs={"u": np.array(["a", "b"])}), r"input 'u': dtype <U1 is not a float"),
    (dict(inputs={"u": np.zeros(3, np.float32)}, input_types={"u": "uint"}),
     r"input 'u': dtype float32 does not fit GLSL uint"),
    (dict(inputs={"u": np.array([-1], np.int64)}, input_types={"u": "uint"}),
     r"input 'u': values out of range for uint"),
    (dict(inputs={"u": np.zeros(3, np.float32), "v": np.zeros(4, np.float32)}),
     r"inputs differ in length"),
    (dict(inputs={}), r"without inputs, give the element count n"),
    (dict(inputs={"u": np.zeros(3, np.float32)}, outputs={"y": "vec5"}),
     r"output 'y': unknown type 'vec5'"),
    (dict(inputs={"u": np.zeros(3, np.float32)}, uniforms={"s": "text"}),
     r"uniform 's': cannot infer a GLSL type"),
])
def test07_errors_name_the_argument(gl_ctx, kwargs, message):
    kwargs.setdefault("outputs", {"y": "float"})
    with pytest.raises(UsageError, match=message):
        run_glsl("float y = 0.0;", **kwargs)


def test08_glsl_errors_point_at_the_body(gl_ctx):
    with pytest.raises(ShaderError, match=r"<run_glsl>:\d+: .*error"):
        run_glsl("float y = undefined_name;", n=1, outputs={"y": "float"})
