"""`glrender --help` and each command's help list every option, and match the documentation
(README.md and the hand-written pages of docs/)."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from cli_run import ROOT, glrender
from glrender.commands.cli import build_parser

OPTION = re.compile(r"(?<![\w-])(--[a-z][a-z-]*[a-z]|-[a-zA-Z])(?![\w-])")
# what issue 8 asks `glrender render` for
REQUIRED = ["-o", "--spp", "--time", "--integrator", "--strategy", "--max-depth", "--width",
            "--height", "--seed", "--device", "--threads", "--aov", "--stats", "--checkpoint-every",
            "--resume", "-D", "--quiet", "--debug"]


def documentation() -> str:
    """README.md and every hand-written page of docs/ (the command-line reference is
    generated from the parser, so it would prove nothing)."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    return "\n".join(p.read_text() for p in pages)


def glrender_lines(text: str) -> list[str]:
    """The glrender command lines of the indented blocks in ``text`` (with their deeper
    indented continuation lines); other programs' lines (dask, benchmarks) are not ours."""
    lines, ours = [], False
    for line in text.splitlines():
        if not line.startswith("    "):
            ours = False
            continue
        if not line.startswith("     "):              # a block's line, not a continuation
            first = line.split()[0] if line.split() else ""
            ours = first in ("glrender", "./dev.sh") or line.split()[:3] == ["python", "-m", "glrender"]
        if ours:
            lines.append(line)
    return lines


def readme_options(spans: bool = True) -> set[str]:
    """The options the documentation names: on glrender command lines of indented blocks,
    and (``spans``) in code spans of prose that start with an option (`--time SECONDS`)."""
    text = documentation()
    usage = glrender_lines(text)
    prose = re.sub(r"(?ms)^```.*?^```", "", text)        # fenced code is not option prose
    found = [span for span in re.findall(r"`([^`]+)`", prose) if span.startswith("-")] if spans else []
    return set(OPTION.findall("\n".join(usage + found)))


def parser_options() -> dict[str, set[str]]:
    """Each command's option strings, from the parser itself (help options aside)."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    options = {name: {s for a in p._actions for s in a.option_strings} - {"-h", "--help"}
               for name, p in sub.choices.items()}
    options["glrender"] = {s for a in parser._actions for s in a.option_strings} - {"-h", "--help"}
    return options


@pytest.fixture(scope="module")
def help_texts():
    texts = {}
    for command in parser_options():
        if command == "glrender":
            continue
        r = glrender(command, "--help")
        assert r.returncode == 0 and r.stderr == ""
        texts[command] = r.stdout
    r = glrender("--help")
    assert r.returncode == 0
    texts["glrender"] = r.stdout
    return texts


def test01_render_help_has_every_option_of_the_issue(help_texts):
    found = set(OPTION.findall(help_texts["render"]))
    assert not set(REQUIRED) - found


def test02_help_lists_every_option_the_readme_names(help_texts):
    readme = readme_options(spans=False)
    assert len(readme) > 10
    in_help = set().union(*(OPTION.findall(t) for t in help_texts.values()))
    assert not readme - in_help, readme - in_help


def test03_readme_names_every_option(help_texts):
    readme = readme_options()
    for command, options in parser_options().items():
        missing = sorted(options - readme)
        assert not missing, f"options of `glrender {command}` missing from the documentation: {missing}"
        if command in help_texts:
            assert set(OPTION.findall(help_texts[command])) >= options, command


def test04_top_level_help_names_the_commands(help_texts):
    for command in ("render", "info", "sampling"):
        assert command in help_texts["glrender"]


def test05_console_script_and_version():
    script = Path(sys.executable).parent / "glrender"
    assert script.exists(), "glrender is installed with pip install -e ."
    r = subprocess.run([str(script), "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.startswith("glrender ")
    assert glrender("--version").stdout == r.stdout
