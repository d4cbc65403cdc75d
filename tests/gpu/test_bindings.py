"""One host/device contract for binding points and flag bits: glrender/gpu/bindings.py and
shaders/common/bindings.glsl state the same names and numbers, every binding in the shaders
names one of them, and no kernel sees two blocks or samplers on one binding point."""
from __future__ import annotations

import re

import pytest

from glrender import integrators
from glrender.gl.shaders import ShaderLibrary, packaged_root, preprocess
from glrender.gpu import bindings

HEADER = ShaderLibrary().read("common/bindings.glsl")
# layout(std140, binding = X) uniform Name | layout(std430, binding = X) [readonly] buffer Name
# | layout(binding = X) uniform samplerType name;
DECLARATION = re.compile(
    r"layout\((?:(std140|std430), )?binding = (\w+)\)\s+(?:readonly\s+)?(uniform|buffer)\s+(\w+)(?:\s+(\w+))?")
SPACE = {"std140": "UBO_", "std430": "SSBO_", None: "TEX_"}


def code_lines(text: str) -> str:
    """The text without its // comments."""
    return "\n".join(line.split("//", 1)[0] for line in text.splitlines())


def declarations(text: str) -> list[tuple[str, str, str]]:
    """(packing or None, the binding as written, the block or sampler name) of each binding."""
    out = []
    for packing, binding, kind, first, second in DECLARATION.findall(code_lines(text)):
        packing = packing or None
        is_sampler = packing is None and kind == "uniform"
        out.append((packing, binding, second if is_sampler else first))
    return out


def test01_header_and_module_agree():
    macros = {k: int(v) for k, v in re.findall(r"^#define ((?:UBO|SSBO|TEX)_\w+) (\d+)$", HEADER, re.M)}
    assert macros == bindings.binding_points()
    flags = {k: int(v) for k, v in re.findall(r"^const uint (k\w+Flag\w+) = (\d+)u;", HEADER, re.M)}
    expected = {"k" + "".join(part.capitalize() for part in name.split("_")): bit
                for name, bit in bindings.flag_bits().items()}
    assert flags == expected
    assert len(flags) >= 7 and len(macros) >= 30


def test02_every_binding_names_a_point_of_its_space():
    seen = 0
    for path in sorted(packaged_root().rglob("*.glsl")):
        text = path.read_text()
        for packing, binding, name in declarations(text):
            seen += 1
            rel = path.relative_to(packaged_root())
            assert not binding.isdigit(), f"{rel}: {name} is bound to the number {binding}: name it " \
                                          f"in common/bindings.glsl"
            assert binding.startswith(SPACE[packing]), f"{rel}: {name} uses {binding}"
            assert binding in bindings.binding_points(), f"{rel}: {binding} is not in bindings.py"
        # no flag bit is written as a number beside the header
        if path.name != "bindings.glsl":
            assert not re.search(r"const uint k\w+Flag\w+ = ", text), f"{path}: a flag outside bindings.glsl"
    assert seen >= 30


def entry_points() -> list[tuple[str, dict[str, str]]]:
    """Every kernel and its slots: the render kernel once per integrator file."""
    scene = {"scene": "scene/layout.glsl"}    # the generated scene code declares no binding
    out = [("kernels/render.comp.glsl", {**scene, "integrator": spec.glsl})
           for spec in map(integrators.get, integrators.names()) if spec.glsl is not None]
    out.append(("kernels/wavefront.comp.glsl", {**scene, "integrator": "integrators/path.glsl"}))
    for path in sorted(packaged_root().rglob("*.comp.glsl")):
        rel = path.relative_to(packaged_root()).as_posix()
        if rel not in ("kernels/render.comp.glsl", "kernels/wavefront.comp.glsl"):
            out.append((rel, scene))
    return out


@pytest.mark.parametrize("entry, slots", entry_points(), ids=lambda v: v if isinstance(v, str) else "")
def test03_no_kernel_binds_two_things_to_one_point(entry, slots):
    """Preprocessed without defines, so every conditional block counts: a superset of what
    any compiled variant sees."""
    source = preprocess(entry, slots=slots).source
    points = bindings.binding_points()
    taken: dict[tuple[str, int], str] = {}
    for packing, binding, name in declarations(source):
        key = (SPACE[packing], points[binding])
        assert taken.setdefault(key, name) == name, \
            f"{entry}: {name} and {taken[key]} share {key[0]}{key[1]}"
    assert taken, f"{entry} declares no binding"
