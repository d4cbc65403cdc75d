"""The shader preprocessor: includes, once-only, cycles, slots, defines, #line mapping."""
import re

import numpy as np
import pytest

from glrender.errors import ShaderError, UsageError
from glrender.gl.shaders import ShaderLibrary, compile_compute, format_define, preprocess

ENTRY = """#version 450
layout(local_size_x = 1) in;
{body}
void main() {{}}
"""


def entry(body: str) -> str:
    return ENTRY.format(body=body)


def test01_nested_includes_each_file_once(shader_library):
    pre = preprocess(source=entry('#include "pp/top.glsl"\n#include "pp/leaf.glsl"'),
                     library=shader_library)
    assert pre.source.count("float leaf_value()") == 1
    assert pre.source.count("float mid_value()") == 1
    assert pre.files == ["<source>", "pp/top.glsl", "pp/leaf.glsl", "pp/mid.glsl"]


def test02_nested_includes_compile(gl_ctx, shader_library):
    src = """#version 450
layout(local_size_x = 1) in;
#include "pp/top.glsl"
layout(std430, binding = 0) buffer Out { float result[]; };
void main() { result[0] = top_value(); }
"""
    program = compile_compute(gl_ctx, source=src, library=shader_library)
    buf = gl_ctx.gl.buffer(reserve=4)
    buf.bind_to_storage_buffer(0)
    program.run(1)
    assert np.frombuffer(buf.read(), np.float32)[0] == 3.0


def test03_version_and_defines_come_first(shader_library):
    pre = preprocess(source=entry(""), defines={"USE_NEE": True, "MAX_DEPTH": 8,
                                                "RR_PROB": 0.5, "NAME": "vec3(1)"},
                     library=shader_library)
    lines = pre.source.splitlines()
    assert lines[0] == "#version 450"
    assert lines[1:5] == ["#define USE_NEE 1", "#define MAX_DEPTH 8", "#define RR_PROB 0.5",
                          "#define NAME vec3(1)"]


def test04_float_defines_keep_a_point():
    assert format_define("X", 2.0) == "#define X 2.0"
    assert format_define("X", 1e-20) == "#define X 1e-20"
    with pytest.raises(ShaderError, match="not a GLSL identifier"):
        format_define("1bad", 1)
    with pytest.raises(ShaderError, match="not finite"):
        format_define("X", float("inf"))


def test05_cycle_reports_whole_chain(shader_library):
    with pytest.raises(ShaderError) as info:
        preprocess(source=entry('#include "pp/cycle_a.glsl"'), library=shader_library)
    msg = str(info.value)
    assert "pp/cycle_a.glsl -> pp/cycle_b.glsl -> pp/cycle_c.glsl -> pp/cycle_a.glsl" in msg
    assert msg.startswith("pp/cycle_c.glsl:2:")


def test06_missing_include_names_file_and_line(shader_library):
    with pytest.raises(ShaderError, match=r'^pp/missing.glsl:1: cannot find include "pp/missing_file.glsl"'):
        preprocess(source=entry('#include "pp/missing.glsl"'), library=shader_library)


def test07_slots(shader_library):
    src = entry('#include "@integrator"')
    pre = preprocess(source=src, slots={"integrator": "pp/slot_impl.glsl"}, library=shader_library)
    assert "float slot_value()" in pre.source
    with pytest.raises(ShaderError, match=r'<source>:3: slot "@integrator" is not filled'):
        preprocess(source=src, library=shader_library)


def test08_version_must_be_line_one(shader_library):
    with pytest.raises(ShaderError, match="#version on line 1"):
        preprocess(source="// comment\n#version 450\nvoid main() {}\n", library=shader_library)
    with pytest.raises(ShaderError, match="only allowed on line 1"):
        preprocess(source="#version 450\n#version 450\n", library=shader_library)


@pytest.mark.parametrize("include, path, line", [
    ("pp/broken.glsl", "pp/broken.glsl", 5),        # error in a directly included file
    ("pp/outer.glsl", "pp/broken.glsl", 5),         # the same error one include deeper
    ("pp/undeclared.glsl", "pp/undeclared.glsl", 3),  # a semantic error
])
def test09_compile_errors_map_to_original_file_and_line(gl_ctx, shader_library, include, path, line):
    with pytest.raises(ShaderError) as info:
        compile_compute(gl_ctx, source=entry(f'#include "{include}"'), library=shader_library)
    assert (info.value.path, info.value.line) == (path, line)
    assert str(info.value).startswith(f"{path}:{line}: ")
    assert re.search(r"error", str(info.value))


def test10_error_in_entry_file_itself(gl_ctx, shader_library):
    src = "#version 450\nlayout(local_size_x = 1) in;\n\nvoid main() { float x = ; }\n"
    with pytest.raises(ShaderError) as info:
        compile_compute(gl_ctx, source=src, name="kernels/t.comp.glsl", library=shader_library)
    assert (info.value.path, info.value.line) == ("kernels/t.comp.glsl", 4)


def test11_program_cache_keyed_by_source(gl_ctx, shader_library):
    src = entry('#include "pp/leaf.glsl"')
    a = compile_compute(gl_ctx, source=src, library=shader_library)
    b = compile_compute(gl_ctx, source=src, library=shader_library)
    c = compile_compute(gl_ctx, source=src, defines={"X": 1}, library=shader_library)
    assert a is b and a is not c


def test12_includes_cannot_leave_the_roots(shader_library):
    with pytest.raises(ShaderError, match="cannot find include"):
        preprocess(source=entry('#include "../conftest.py"'), library=shader_library)


def test13_packaged_shaders_found_without_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    lib = ShaderLibrary()
    assert lib.find("common/constants.glsl") is not None


def test14_shader_log_records_each_program_and_its_first_dispatch(gl_ctx, tmp_path, monkeypatch):
    """GLRENDER_SHADER_LOG: one compile line per program built (not for a cached one), one
    line per first dispatch, each naming the test; tools/shader_report.py reads them."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    log = tmp_path / "shaders.jsonl"
    monkeypatch.setenv("GLRENDER_SHADER_LOG", str(log))
    lib = ShaderLibrary().with_generated({"generated/t.glsl": "// scene A\n\nconst float kT = 1.0;"})
    src = entry('#include "generated/t.glsl"\n// test14 shader log')
    a = compile_compute(gl_ctx, source=src, defines={"T14": 1}, library=lib)
    compile_compute(gl_ctx, source=src, defines={"T14": 1}, library=lib)       # cached
    compile_compute(gl_ctx, source=src, defines={"T14": 2}, library=lib)
    a.run(1)
    a.run(1)
    records = [json.loads(line) for line in log.read_text().splitlines()]
    compiles = [r for r in records if r["event"] == "compile"]
    dispatches = [r for r in records if r["event"] == "first_dispatch"]
    assert [r["defines"] for r in compiles] == [{"T14": 1}, {"T14": 2}]
    assert len({r["key"] for r in compiles}) == 2 and compiles[0]["generated"]
    assert len(compiles[0]["generated_blocks"]["generated/t.glsl"]) == 2
    assert all("test14_shader_log" in r["test"] and r["seconds"] >= 0 for r in records)
    assert [r["key"] for r in dispatches] == [compiles[0]["key"]]
    report = subprocess.run([sys.executable, str(Path(__file__).parents[2] / "tools" / "shader_report.py"),
                             str(log), "--drop", "T14"], capture_output=True, text=True, check=True)
    assert report.stdout.startswith("2 distinct programs:")
    assert "without T14 in the source: 1 of 2 programs" in report.stdout


def test15_shader_log_path_that_cannot_be_written_is_a_clear_error(gl_ctx, tmp_path, monkeypatch):
    log = tmp_path / "missing" / "shaders.jsonl"
    monkeypatch.setenv("GLRENDER_SHADER_LOG", str(log))
    with pytest.raises(UsageError, match=r"GLRENDER_SHADER_LOG=.*missing.*cannot append"):
        compile_compute(gl_ctx, source=entry("// test15 shader log path"), defines={"T15": 1})


def test16_extension_directives_move_after_version(gl_ctx):
    """An #extension in an included file (the driver takes them only before declarations)
    moves to just after #version, once; the file keeps its line numbers."""
    lib = ShaderLibrary(generated={
        "ext/a.glsl": "float a_value() { return 1.0; }\n#extension GL_ARB_shader_ballot : enable\n"
                      "float a_two() { return 2.0; }\n",
        "ext/b.glsl": "#extension   GL_ARB_shader_ballot :  enable  // again\nfloat b_value() { return 3.0; }\n",
    })
    src = entry('#include "ext/a.glsl"\n#include "ext/b.glsl"')
    pre = preprocess(source=src, defines={"X": 1}, library=lib)
    lines = pre.source.splitlines()
    assert lines[:3] == ["#version 450", "#extension GL_ARB_shader_ballot : enable", "#define X 1"]
    assert pre.source.count("#extension") == 1
    compile_compute(gl_ctx, source=src, library=lib)
    bad = ShaderLibrary(generated={"ext/c.glsl": "float c() { return 1.0; }\nfloat c2() { return x; }\n"
                                                 "#extension GL_ARB_shader_ballot : enable\n"})
    with pytest.raises(ShaderError, match="ext/c.glsl:2"):
        compile_compute(gl_ctx, source=entry('#include "ext/c.glsl"'), library=bad)
