"""Run GLSL code over numpy arrays: the shader unit-test harness.

Example::

    out = run_glsl("vec2 r = sample_disk_concentric(u);",
                   inputs={"u": U}, outputs={"r": "vec2"},
                   includes=["sampling/disk.glsl"])
    out["r"]  # numpy array of shape (N, 2)

The body runs once per element inside ``main()``. Inputs are visible under their
names with their GLSL types; the body declares and assigns every output. A body
without ``;`` and a single output is taken as an expression. ``index`` (uint) is
the element's index. Extra read-only arrays (tables) come through ``buffers`` as
``name[]``; ``uniforms`` are scalars or vectors set per call.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ..errors import UsageError
from ..gl import shaders
from ..gl.context import default_context

# GLSL type -> (numpy dtype, components, GLSL scalar type in the SSBO)
TYPES = {
    "float": (np.float32, 1, "float"), "vec2": (np.float32, 2, "float"),
    "vec3": (np.float32, 3, "float"), "vec4": (np.float32, 4, "float"),
    "int": (np.int32, 1, "int"), "ivec2": (np.int32, 2, "int"),
    "ivec3": (np.int32, 3, "int"), "ivec4": (np.int32, 4, "int"),
    "uint": (np.uint32, 1, "uint"), "uvec2": (np.uint32, 2, "uint"),
    "uvec3": (np.uint32, 3, "uint"), "uvec4": (np.uint32, 4, "uint"),
    "bool": (np.uint32, 1, "uint"),
}
LOCAL_SIZE = 64
CHUNK = 1 << 20  # elements per dispatch: keeps every SSBO far below 128 MiB


def _check_type(kind: str, glsl_type: str, name: str) -> tuple:
    if glsl_type not in TYPES:
        raise UsageError(f"run_glsl: {kind} {name!r}: unknown type {glsl_type!r} "
                         f"(expected one of {', '.join(TYPES)})")
    return TYPES[glsl_type]


def _infer_type(array: np.ndarray, name: str) -> str:
    comps = 1 if array.ndim == 1 else array.shape[1]
    if array.ndim not in (1, 2) or not 1 <= comps <= 4:
        raise UsageError(f"run_glsl: input {name!r}: expected shape (N,) or (N, 2..4), "
                         f"got {array.shape}")
    if array.dtype == np.bool_:
        if comps != 1:
            raise UsageError(f"run_glsl: input {name!r}: only scalar bool inputs are supported")
        return "bool"
    if np.issubdtype(array.dtype, np.floating):
        base = "float" if comps == 1 else f"vec{comps}"
    elif np.issubdtype(array.dtype, np.signedinteger):
        base = "int" if comps == 1 else f"ivec{comps}"
    elif np.issubdtype(array.dtype, np.unsignedinteger):
        base = "uint" if comps == 1 else f"uvec{comps}"
    else:
        raise UsageError(f"run_glsl: input {name!r}: dtype {array.dtype} is not a float, "
                         f"int, uint or bool array")
    return base


def _prepare_input(name: str, value, glsl_type: str | None) -> tuple[str, np.ndarray]:
    array = np.asarray(value)
    glsl_type = glsl_type or _infer_type(array, name)
    dtype, comps, _ = _check_type("input", glsl_type, name)
    want = "(N,)" if comps == 1 else f"(N, {comps})"
    if comps == 1 and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if (comps == 1 and array.ndim != 1) or (comps > 1 and (array.ndim != 2 or array.shape[1] != comps)):
        raise UsageError(f"run_glsl: input {name!r}: expected shape {want} for {glsl_type}, "
                         f"got {array.shape}")
    kind_ok = {
        np.float32: np.issubdtype(array.dtype, np.floating),
        np.int32: np.issubdtype(array.dtype, np.integer) or array.dtype == np.bool_,
        np.uint32: np.issubdtype(array.dtype, np.integer) or array.dtype == np.bool_,
    }[dtype]
    if not kind_ok:
        raise UsageError(f"run_glsl: input {name!r}: dtype {array.dtype} does not fit "
                         f"GLSL {glsl_type}")
    if dtype is not np.float32 and array.dtype != np.bool_ and array.size:
        info = np.iinfo(dtype)
        if array.min() < info.min or array.max() > info.max:
            raise UsageError(f"run_glsl: input {name!r}: values out of range for {glsl_type}")
    return glsl_type, np.ascontiguousarray(array, dtype=dtype).reshape(len(array), comps)


def _uniform_decl(name: str, value) -> tuple[str, object]:
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
        glsl_type, val = value
        _check_type("uniform", glsl_type, name)
        return glsl_type, val
    if isinstance(value, (bool, np.bool_)):
        return "bool", bool(value)
    if isinstance(value, (int, np.integer)):
        return "int", int(value)
    if isinstance(value, (float, np.floating)):
        return "float", float(value)
    seq = np.asarray(value)
    if seq.ndim == 1 and 2 <= seq.size <= 4 and np.issubdtype(seq.dtype, np.number):
        prefix = "" if np.issubdtype(seq.dtype, np.floating) else "i"
        return f"{prefix}vec{seq.size}", tuple(seq.tolist())
    raise UsageError(f"run_glsl: uniform {name!r}: cannot infer a GLSL type for {value!r}; "
                     f"pass (type, value)")


def _component_expr(glsl_type: str, array: str, base: str) -> str:
    _, comps, scalar = TYPES[glsl_type]
    if glsl_type == "bool":
        return f"({array}[{base}] != 0u)"
    if comps == 1:
        return f"{array}[{base}]"
    parts = ", ".join(f"{array}[{base} + {k}u]" for k in range(comps))
    return f"{glsl_type}({parts})"


def build_source(body: str, inputs: Mapping[str, str], outputs: Mapping[str, str],
                 includes: Sequence[str], uniforms: Mapping[str, str],
                 buffers: Mapping[str, str], preamble: str) -> str:
    """The compute shader the harness runs (exposed for debugging)."""
    lines = ["#version 450", f"layout(local_size_x = {LOCAL_SIZE}) in;"]
    lines += [f'#include "{inc}"' for inc in includes]
    lines += ["uniform uint u_harness_offset;", "uniform uint u_harness_count;"]
    lines += [f"uniform {t} {n};" for n, t in uniforms.items()]
    binding = 0
    for name, glsl_type in inputs.items():
        lines.append(f"layout(std430, binding = {binding}) readonly buffer HarnessIn{binding} "
                     f"{{ {TYPES[glsl_type][2]} in_{name}[]; }};")
        binding += 1
    for name, scalar in buffers.items():
        lines.append(f"layout(std430, binding = {binding}) readonly buffer HarnessTable{binding} "
                     f"{{ {scalar} {name}[]; }};")
        binding += 1
    for name, glsl_type in outputs.items():
        lines.append(f"layout(std430, binding = {binding}) writeonly buffer HarnessOut{binding} "
                     f"{{ {TYPES[glsl_type][2]} out_{name}[]; }};")
        binding += 1
    if preamble:
        lines.append(preamble)
    lines += ["void main() {",
              "    uint index = gl_GlobalInvocationID.x;",
              "    if (index >= u_harness_count) return;",
              "    uint harness_local = index;",
              "    index += u_harness_offset;"]
    for name, glsl_type in inputs.items():
        comps = TYPES[glsl_type][1]
        lines.append(f"    {glsl_type} {name} = "
                     f"{_component_expr(glsl_type, 'in_' + name, f'harness_local * {comps}u')};")
    if ";" not in body and len(outputs) == 1:
        (out_name, out_type), = outputs.items()
        body = f"{out_type} {out_name} = {out_type}({body});"
    lines += ["    {", "    // body", *("        " + b for b in body.splitlines())]
    for name, glsl_type in outputs.items():
        _, comps, scalar = TYPES[glsl_type]
        if glsl_type == "bool":
            lines.append(f"        out_{name}[harness_local] = {name} ? 1u : 0u;")
        elif comps == 1:
            lines.append(f"        out_{name}[harness_local] = {name};")
        else:
            for k in range(comps):
                lines.append(f"        out_{name}[harness_local * {comps}u + {k}u] = {name}[{k}];")
    lines += ["    }", "}"]
    return "\n".join(lines) + "\n"


def run_glsl(body: str, inputs: Mapping[str, object] | None = None,
             outputs: Mapping[str, str] | None = None, *,
             includes: Sequence[str] = (), uniforms: Mapping[str, object] | None = None,
             buffers: Mapping[str, object] | None = None, defines: Mapping[str, object] | None = None,
             preamble: str = "", n: int | None = None, input_types: Mapping[str, str] | None = None,
             ctx=None, library: shaders.ShaderLibrary | None = None) -> dict[str, np.ndarray]:
    """Run ``body`` once per element of the inputs; return the outputs as numpy arrays.

    ``inputs``: name -> array of shape (N,) or (N, k); the GLSL type is inferred from
    dtype and shape (float/int/uint/bool, vecK/ivecK/uvecK) unless ``input_types``
    names it. ``outputs``: name -> GLSL type. ``n``: element count when there are no
    inputs. ``buffers``: name -> 1D float32/int32/uint32 array visible as ``name[]``.
    """
    inputs, outputs = dict(inputs or {}), dict(outputs or {})
    input_types = dict(input_types or {})
    if not outputs:
        raise UsageError("run_glsl: give at least one output (name -> GLSL type)")
    for name in list(inputs) + list(outputs) + list(uniforms or {}) + list(buffers or {}):
        if not name.isidentifier():
            raise UsageError(f"run_glsl: {name!r} is not a GLSL identifier")
    prepared = {}
    for name, value in inputs.items():
        prepared[name] = _prepare_input(name, value, input_types.get(name))
    for name, glsl_type in outputs.items():
        _check_type("output", glsl_type, name)
    lengths = {name: len(arr) for name, (_, arr) in prepared.items()}
    if len(set(lengths.values())) > 1:
        raise UsageError(f"run_glsl: inputs differ in length: {lengths}")
    count = next(iter(lengths.values())) if lengths else n
    if count is None:
        raise UsageError("run_glsl: without inputs, give the element count n")
    if n is not None and lengths and n != count:
        raise UsageError(f"run_glsl: n={n} but the inputs have {count} elements")
    uniform_decls = {name: _uniform_decl(name, value) for name, value in (uniforms or {}).items()}
    table_arrays = {}
    for name, value in (buffers or {}).items():
        arr = np.asarray(value)
        if arr.dtype == np.float64:
            arr = arr.astype(np.float32)
        scalar = {np.dtype(np.float32): "float", np.dtype(np.int32): "int",
                  np.dtype(np.uint32): "uint"}.get(arr.dtype)
        if scalar is None:
            raise UsageError(f"run_glsl: buffer {name!r}: dtype {arr.dtype} is not float32, "
                             f"int32 or uint32")
        table_arrays[name] = (scalar, np.ascontiguousarray(arr.reshape(-1)))

    source = build_source(body, {k: t for k, (t, _) in prepared.items()}, outputs, includes,
                          {k: t for k, (t, _) in uniform_decls.items()},
                          {k: s for k, (s, _) in table_arrays.items()}, preamble)
    ctx = ctx or default_context()
    if hasattr(ctx, "make_current"):
        ctx.make_current()
    gl = getattr(ctx, "gl", ctx)
    program = shaders.compile_compute(ctx, source=source, name="<run_glsl>", defines=defines,
                                      library=library)
    for name, (glsl_type, value) in uniform_decls.items():
        member = program.get(name, None)
        if member is not None:  # the compiler drops uniforms the body never reads
            member.value = value

    results = {name: np.empty((count, TYPES[t][1]), TYPES[t][0]) for name, t in outputs.items()}
    chunk = min(CHUNK, max(count, 1))
    in_bufs = {name: gl.buffer(reserve=max(chunk * arr.shape[1] * 4, 4))
               for name, (_, arr) in prepared.items()}
    table_bufs = [gl.buffer(arr.tobytes() if arr.size else b"\0" * 4)
                  for _, arr in table_arrays.values()]
    out_bufs = {name: gl.buffer(reserve=max(chunk * TYPES[t][1] * 4, 4)) for name, t in outputs.items()}
    try:
        binding = 0
        for name in prepared:
            in_bufs[name].bind_to_storage_buffer(binding)
            binding += 1
        for buf in table_bufs:
            buf.bind_to_storage_buffer(binding)
            binding += 1
        for name in outputs:
            out_bufs[name].bind_to_storage_buffer(binding)
            binding += 1
        for start in range(0, count, chunk):
            size = min(chunk, count - start)
            for name, (_, arr) in prepared.items():
                in_bufs[name].write(arr[start:start + size].tobytes())
            for uniform, value in (("u_harness_offset", start), ("u_harness_count", size)):
                member = program.get(uniform, None)
                if member is not None:
                    member.value = value
            program.run(group_x=(size + LOCAL_SIZE - 1) // LOCAL_SIZE)
            for name, t in outputs.items():
                dtype, comps, _ = TYPES[t]
                raw = out_bufs[name].read(size=size * comps * 4)
                results[name][start:start + size] = np.frombuffer(raw, dtype).reshape(size, comps)
    finally:
        for buf in [*in_bufs.values(), *table_bufs, *out_bufs.values()]:
            buf.release()
    out = {}
    for name, t in outputs.items():
        arr = results[name]
        if t == "bool":
            arr = arr != 0
        out[name] = arr[:, 0] if TYPES[t][1] == 1 else arr
    return out
