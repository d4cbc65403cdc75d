"""Host configuration enters the shaders through one door, common/params.glsl: every host
macro a shader tests is one that params.glsl states (required, or optional with a default)
and glrender/render/params.py produces."""
from __future__ import annotations

import re

from glrender.gl.shaders import packaged_root
from glrender.render.params import OPTIONAL_DEFINES, shader_defines

PARAMS = (packaged_root() / "common" / "params.glsl").read_text()
# loop_counter.glsl also serves sampling code compiled without params.glsl: it tests its two
# required counters itself, in the form that needs no default (#if defined(X) && X)
SELF_CONTAINED = {"common/loop_counter.glsl": {"GLRENDER_COUNT_LOOPS", "GLRENDER_COUNT_RAYS"}}


def host_macros(text: str) -> set[str]:
    code = "\n".join(line.split("//", 1)[0] for line in text.splitlines())
    return set(re.findall(r"\b(?:GLRENDER|BDPT)_[A-Z0-9_]+\b", code))


def test01_every_host_macro_goes_through_params_glsl():
    required = set(shader_defines())
    optional = set(OPTIONAL_DEFINES)
    assert not required & optional
    for name in required:
        assert re.search(rf"!defined\({name}\)", PARAMS), f"params.glsl does not require {name}"
    for name in optional:
        assert re.search(rf"#ifndef {name}\n#define {name} \d+\n#endif", PARAMS), \
            f"params.glsl gives {name} no default"
    for path in packaged_root().rglob("*.glsl"):
        rel = path.relative_to(packaged_root()).as_posix()
        used = host_macros(path.read_text())
        unknown = used - required - optional
        assert not unknown, f"{rel} tests host macros params.glsl does not state: {sorted(unknown)}"
        if rel in ("common/params.glsl", "common/bindings.glsl"):
            continue
        for name in used & required - SELF_CONTAINED.get(rel, set()):
            assert False, f"{rel} tests the required define {name}: read its constant"
        for line in path.read_text().splitlines():
            assert not re.match(r"\s*#ifn?def (GLRENDER|BDPT)_", line), \
                f"{rel}: '{line.strip()}' (params.glsl defines every switch: use #if or its constant)"
