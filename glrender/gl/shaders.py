"""The one shader preprocessor of glrender, and the program cache.

GLSL has no include mechanism, so entry points (``*.comp.glsl``, ``*.vert.glsl``,
``*.frag.glsl``) are expanded here before the driver sees them:

- ``#version`` must be the first line of an entry point; host defines are
  injected right after it (``shaders/common/params.glsl`` turns them into typed
  constants, the one door for host configuration).
- ``#include "path"`` is resolved against the shader roots (the packaged
  ``shaders/`` folder, plus any extra roots given); each file is included once,
  and an include cycle is an error naming the whole chain.
- ``#extension`` lines, wherever they are (conditional blocks too: they are not
  evaluated here), move to just after ``#version`` (the driver accepts them only before
  the first declaration), each once; a file that uses an extension says so itself, with
  ``enable`` where the code tests for it.
- ``#include "@name"`` is a slot, filled at compile time from ``slots``
  (e.g. ``{"integrator": "integrators/path.glsl"}``).
- ``#line`` directives carry a file id so that every compile or link error is
  rewritten as ``path:line: message`` of the original file. The id is encoded
  twice: as the source-string number and in the line number itself
  (``(id + 1) * LINE_BASE + line``), because Mesa reports some errors (an
  undeclared identifier, for one) with source number 0 but the right line.
"""
from __future__ import annotations

import hashlib
import importlib.resources
import json
import os
import re
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Mapping, Protocol

import moderngl

from ..errors import ShaderError, UsageError

_INCLUDE = re.compile(r'^\s*#\s*include\s+(?:"([^"]*)"|<([^>]*)>)\s*(?://.*)?$')
_VERSION = re.compile(r"^\s*#\s*version\s+\d+")
_EXTENSION = re.compile(r"^\s*#\s*extension\s+\w+\s*:\s*\w+\s*(?://.*)?$")
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
# Driver log formats: Mesa "0:12(5): error: ...", NVIDIA "0(12) : error C0000: ...",
# AMD/others "ERROR: 0:12: ...".
_LOG_PATTERNS = (
    re.compile(r"^(?P<file>\d+):(?P<line>\d+)\(\d+\):\s*(?P<msg>.*)$"),
    re.compile(r"^(?P<file>\d+)\((?P<line>\d+)\)\s*:\s*(?P<msg>.*)$"),
    re.compile(r"^(?:ERROR|WARNING):\s*(?P<file>\d+):(?P<line>\d+):\s*(?P<msg>.*)$"),
)
MAX_INCLUDE_DEPTH = 64
LINE_BASE = 100_000  # no shader file is this long


def packaged_root() -> Path:
    """The ``shaders/`` folder installed with glrender."""
    return Path(str(importlib.resources.files("glrender.shaders")))


class ShaderLibrary:
    """Where include paths are looked up: generated sources (in memory, e.g. code the
    renderer writes for one scene), then extra roots, then the packaged shaders."""

    def __init__(self, roots: Iterable[str | Path] = (), generated: Mapping[str, str] | None = None):
        self.roots = [Path(r) for r in roots] + [packaged_root()]
        self.generated = dict(generated or {})

    def with_generated(self, generated: Mapping[str, str]) -> "ShaderLibrary":
        """A library that also holds the given in-memory sources."""
        lib = ShaderLibrary.__new__(ShaderLibrary)
        lib.roots, lib.generated = list(self.roots), {**self.generated, **generated}
        return lib

    def find(self, path: str) -> Path | str | None:
        if path in self.generated:
            return path
        if Path(path).is_absolute() or ".." in Path(path).parts:
            return None
        for root in self.roots:
            candidate = root / path
            if candidate.is_file():
                return candidate
        return None

    def read(self, path: str) -> str:
        if path in self.generated:
            return self.generated[path]
        found = self.find(path)
        if found is None:
            raise ShaderError(f"shader file not found (searched {', '.join(map(str, self.roots))})",
                              path=path)
        return found.read_text(encoding="utf-8")


def format_define(name: str, value) -> str:
    """``#define name value`` with bools as 1/0 and floats always carrying a point."""
    if not _IDENTIFIER.match(name):
        raise ShaderError(f"define name {name!r} is not a GLSL identifier")
    if isinstance(value, bool):
        text = "1" if value else "0"
    elif isinstance(value, int):
        text = str(value)
    elif isinstance(value, float):
        text = repr(float(value))
        if text in ("inf", "-inf", "nan"):
            raise ShaderError(f"define {name}: value {value} is not finite")
        if "." not in text and "e" not in text:
            text += ".0"
    else:
        text = str(value)
        if "\n" in text:
            raise ShaderError(f"define {name}: value must be on one line")
    return f"#define {name} {text}"


@dataclass
class Preprocessed:
    """The expanded source and the table mapping ``#line`` file ids to paths."""

    source: str
    files: list[str] = field(default_factory=list)

    @property
    def key(self) -> str:
        return hashlib.sha256(self.source.encode()).hexdigest()

    def locate(self, file_id: int, line: int) -> tuple[str, int]:
        if line >= LINE_BASE:  # the file id encoded in the line number wins
            file_id, line = line // LINE_BASE - 1, line % LINE_BASE
        path = self.files[file_id] if 0 <= file_id < len(self.files) else f"<file {file_id}>"
        return path, line

    def map_log(self, log: str) -> tuple[str, tuple[str, int, str] | None]:
        """Rewrite driver log lines to ``path:line: message``.

        Returns the rewritten log and the first error (else the first located line).
        """
        out, located = [], []
        for raw in log.splitlines():
            text = raw.strip()
            for pattern in _LOG_PATTERNS:
                m = pattern.match(text)
                if m:
                    path, line = self.locate(int(m["file"]), int(m["line"]))
                    msg = m["msg"].strip()
                    out.append(f"{path}:{line}: {msg}")
                    located.append((path, line, msg))
                    break
            else:
                if text:
                    out.append(text)
        errors = [loc for loc in located if "error" in loc[2].lower()]
        first = errors[0] if errors else (located[0] if located else None)
        return "\n".join(out), first


def line_directive(line: int, file_id: int) -> str:
    """``#line`` making the next line read as ``line`` of file ``file_id``."""
    return f"#line {(file_id + 1) * LINE_BASE + line} {file_id}"


class _Expander:
    def __init__(self, library: ShaderLibrary, slots: Mapping[str, str]):
        self.library, self.slots = library, dict(slots)
        self.files: list[str] = []
        self.done: set[str] = set()
        self.out: list[str] = []
        self.extensions: list[str] = []

    def file_id(self, path: str) -> int:
        self.files.append(path)
        return len(self.files) - 1

    def expand(self, path: str, text: str, stack: list[tuple[str, int]], first_line: int = 1):
        fid = self.file_id(path)
        if len(stack) > MAX_INCLUDE_DEPTH:
            raise ShaderError(f"includes nested deeper than {MAX_INCLUDE_DEPTH}", *stack[-1])
        self.done.add(path)
        lines = text.splitlines()
        self.out.append(line_directive(first_line, fid))
        for number, line in enumerate(lines[first_line - 1:], start=first_line):
            m = _INCLUDE.match(line)
            if not m:
                if _VERSION.match(line):
                    raise ShaderError("#version is only allowed on line 1 of an entry point",
                                      path, number)
                if _EXTENSION.match(line):
                    directive = " ".join(line.split("//")[0].split())
                    if directive not in self.extensions:
                        self.extensions.append(directive)
                    line = ""  # keep line numbering of this file intact
                self.out.append(line)
                continue
            target = m.group(1) if m.group(1) is not None else m.group(2)
            if target.startswith("@"):
                slot = target[1:]
                if slot not in self.slots:
                    given = ", ".join(sorted(self.slots)) or "none"
                    raise ShaderError(f'slot "@{slot}" is not filled (slots given: {given})',
                                      path, number)
                target = self.slots[slot]
            chain = [p for p, _ in stack] + [path]
            if target in chain:
                cycle = " -> ".join(chain[chain.index(target):] + [target])
                raise ShaderError(f"include cycle: {cycle}", path, number)
            if target in self.done:
                self.out.append("")  # keep line numbering of this file intact
                continue
            if self.library.find(target) is None:
                raise ShaderError(f'cannot find include "{target}"', path, number)
            self.expand(target, self.library.read(target), stack + [(path, number)])
            self.out.append(line_directive(number + 1, fid))


def preprocess(entry: str | None = None, *, source: str | None = None, name: str = "<source>",
               defines: Mapping[str, object] | None = None,
               slots: Mapping[str, str] | None = None,
               library: ShaderLibrary | None = None) -> Preprocessed:
    """Expand an entry point (a path under the shader roots, or ``source`` text)."""
    library = library or ShaderLibrary()
    if source is None:
        if entry is None:
            raise ShaderError("preprocess: give an entry path or source text")
        source, name = library.read(entry), entry
    lines = source.splitlines()
    if not lines or not _VERSION.match(lines[0]):
        raise ShaderError("an entry point must start with #version on line 1", name, 1)
    expander = _Expander(library, slots or {})
    for key, value in (defines or {}).items():
        expander.out.append(format_define(key, value))
    expander.expand(name, source, [], first_line=2)
    head = [lines[0].strip()] + expander.extensions
    return Preprocessed("\n".join(head + expander.out) + "\n", expander.files)


def _driver_log(exc: Exception) -> str:
    text = str(exc)
    # moderngl: "GLSL Compiler failed\n\ncompute_shader\n=================\n<log>"
    parts = re.split(r"\n=+\n", text, maxsplit=1)
    return parts[1] if len(parts) == 2 else text


def _raise_mapped(pre: Preprocessed, exc: Exception, stage: str):
    log = _driver_log(exc)
    mapped, first = pre.map_log(log)
    if first is not None:
        path, line, msg = first
        raise ShaderError(f"{msg}" + (f"\n{mapped}" if mapped.count("\n") else ""),
                          path, line, log=mapped) from None
    raise ShaderError(f"{stage} failed: {mapped.strip() or log.strip()}", log=mapped) from None


#: Programs compiled by this process, the seconds the driver took to compile and link them,
#: and the seconds of the compute kernels' first dispatches (llvmpipe generates machine code
#: then, or loads it from its disk cache). The test suite prints these in its summary.
COMPILE_STATS = {"programs": 0, "seconds": 0.0, "first_dispatch_seconds": 0.0}

#: ``GLRENDER_SHADER_LOG=FILE`` appends one JSON line per program built (and one per compute
#: kernel's first dispatch) to FILE, from every process that inherits the variable (the
#: test suite's CLI subprocesses too): ``tools/shader_report.py FILE`` groups them by test
#: and by kernel to show which tests build which programs.
SHADER_LOG_ENV = "GLRENDER_SHADER_LOG"


class CompileListener(Protocol):
    """Told when the driver starts and stops turning a program into machine code: the
    build (compile and link) and a compute kernel's first dispatch (where llvmpipe
    generates its code). A command's "compiling kernels" line is one."""

    def started(self) -> None: ...

    def stopped(self) -> None: ...


_LISTENERS: list[CompileListener] = []


@contextmanager
def compile_listener(listener: CompileListener) -> Iterator[CompileListener]:
    """Tell ``listener`` of every build and first dispatch inside the block."""
    _LISTENERS.append(listener)
    try:
        yield listener
    finally:
        _LISTENERS.remove(listener)


@contextmanager
def _compiling() -> Iterator[None]:
    listeners = list(_LISTENERS)
    for listener in listeners:
        listener.started()
    try:
        yield
    finally:
        for listener in reversed(listeners):
            listener.stopped()


def _log_event(record: dict) -> None:
    path = os.environ.get(SHADER_LOG_ENV)
    if not path:
        return
    record = {"pid": os.getpid(), "test": os.environ.get("PYTEST_CURRENT_TEST", ""), **record}
    line = (json.dumps(record, sort_keys=True, default=str) + "\n").encode()
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    except OSError as exc:
        raise UsageError(f"{SHADER_LOG_ENV}={path}: cannot append to it "
                         f"({exc.strerror or exc}); expected a writable file path") from None
    try:
        os.write(fd, line)   # one write of one line: lines of concurrent processes stay whole
    finally:
        os.close(fd)


def _describe(pre: Preprocessed, entry: str | None, name: str, defines, slots,
              library: ShaderLibrary | None) -> dict:
    """What the shader log says about one program: its entry point, defines and slots,
    the hash of its final source (``key``) and of its in-memory generated files (e.g. the
    scene code the renderer writes), so programs that differ only there can be told apart."""
    generated = dict(library.generated) if library is not None else {}
    scene = hashlib.sha256(repr(sorted(generated.items())).encode()).hexdigest()[:16] \
        if generated else ""
    # each generated file's blank-line separated blocks, hashed: which parts of the scene
    # code (lights, materials, geometry) tell two programs apart
    blocks = {path: [hashlib.sha256(b.encode()).hexdigest()[:8] for b in text.split("\n\n")]
              for path, text in sorted(generated.items())}
    return {"entry": entry or name, "key": pre.key[:16], "defines": dict(defines or {}),
            "slots": dict(slots or {}), "generated": scene, "generated_blocks": blocks,
            "lines": pre.source.count("\n")}


class ComputeKernel:
    """A compiled compute shader (moderngl's, every attribute passed through) whose first
    ``run`` waits for the device and adds its time to ``COMPILE_STATS``."""

    def __init__(self, program: moderngl.ComputeShader, key: str = ""):
        self._program = program
        self._first = True
        self._key = key

    def run(self, *args, **kwargs):
        if not self._first:
            return self._program.run(*args, **kwargs)
        self._first = False
        t0 = time.perf_counter()
        with _compiling():
            self._program.run(*args, **kwargs)
            self._program.ctx.finish()
        seconds = time.perf_counter() - t0
        COMPILE_STATS["first_dispatch_seconds"] += seconds
        _log_event({"event": "first_dispatch", "key": self._key, "seconds": round(seconds, 4)})

    def __getattr__(self, name):
        return getattr(self._program, name)

    def __getitem__(self, name):
        return self._program[name]

    def __setitem__(self, name, value):
        self._program[name] = value


def _timed_build(build, describe=None):
    t0 = time.perf_counter()
    try:
        with _compiling():
            return build()
    finally:
        seconds = time.perf_counter() - t0
        COMPILE_STATS["programs"] += 1
        COMPILE_STATS["seconds"] += seconds
        if describe is not None and os.environ.get(SHADER_LOG_ENV):
            _log_event({"event": "compile", "seconds": round(seconds, 4), **describe()})


def _cache_of(ctx) -> dict:
    cache = getattr(ctx, "_glrender_programs", None)
    if cache is None:
        cache = {}
        setattr(ctx, "_glrender_programs", cache)
    return cache


def compile_compute(ctx, entry: str | None = None, *, source: str | None = None,
                    name: str = "<source>", defines: Mapping[str, object] | None = None,
                    slots: Mapping[str, str] | None = None,
                    library: ShaderLibrary | None = None) -> ComputeKernel:
    """Preprocess and compile a compute entry point; cached per context by final source."""
    gl = getattr(ctx, "gl", ctx)
    pre = preprocess(entry, source=source, name=name, defines=defines, slots=slots,
                     library=library)
    cache = _cache_of(gl)
    program = cache.get(pre.key)
    if program is None:
        try:
            program = ComputeKernel(
                _timed_build(lambda: gl.compute_shader(pre.source),
                             lambda: _describe(pre, entry, name, defines, slots, library)),
                pre.key[:16])
        except moderngl.Error as exc:
            _raise_mapped(pre, exc, "compute shader compile")
        cache[pre.key] = program
    return program


def compile_program(ctx, vertex: str, fragment: str, *,
                    defines: Mapping[str, object] | None = None,
                    library: ShaderLibrary | None = None) -> moderngl.Program:
    """Preprocess and link a vertex + fragment program (the preview's display pass)."""
    gl = getattr(ctx, "gl", ctx)
    vs = preprocess(vertex, defines=defines, library=library)
    fs = preprocess(fragment, defines=defines, library=library)
    key = vs.key + fs.key
    cache = _cache_of(gl)
    program = cache.get(key)
    if program is None:
        try:
            program = _timed_build(
                lambda: gl.program(vertex_shader=vs.source, fragment_shader=fs.source),
                lambda: {"entry": f"{vertex} + {fragment}", "key": key[:16],
                         "defines": dict(defines or {}), "slots": {}, "generated": "",
                         "lines": vs.source.count("\n") + fs.source.count("\n")})
        except moderngl.Error as exc:
            text = str(exc)
            _raise_mapped(fs if "fragment_shader" in text else vs, exc, "program link")
        cache[key] = program
    return program
