"""The README and the hand-written documentation pages hold together without building the site:
every relative link resolves (file and #anchor), every image the README shows is committed,
every `glrender ...` command line in the README parses with glrender's own parser, the
README's gallery commands are those tools/make_gallery.py runs, and every option of
`glrender render` is explained somewhere by hand (the generated reference alone does not
count)."""
from __future__ import annotations

import argparse
import importlib.util
import re
import shlex
import sys
import unicodedata
from pathlib import Path

import pytest

from glrender.commands.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]   # docs/lab/ is generated
LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def prose(text: str) -> str:
    """``text`` without fenced code blocks and inline code spans (links there are not links)."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    return re.sub(r"`[^`\n]*`", "", text)


def links(page: Path) -> list[tuple[bool, str]]:
    """(is an image, target) of every Markdown link on ``page``."""
    return [(bang == "!", target) for bang, _, target in LINK.findall(prose(page.read_text()))]


def slug(heading: str) -> str:
    """The id Python-Markdown's toc extension gives a heading (its default slugify)."""
    text = re.sub(r"`|\*\*|\[([^\]]*)\]\([^)]*\)", r"\1", heading)
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(page: Path) -> set[str]:
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.S | re.M)
    found = {slug(m) for m in re.findall(r"^#{1,6}\s+(.*?)\s*#*\s*$", text, re.M)}
    return found | set(re.findall(r"""\bid=["']([^"']+)["']""", text))


def link_problems(page: Path, root: Path = ROOT, docs: Path = DOCS) -> list[str]:
    """One line for each link of ``page`` that does not resolve, or leaves ``docs``."""
    problems = []
    for _, target in links(page):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):           # http:, mailto:, ...
            continue
        path, _, anchor = target.partition("#")
        resolved = (page.parent / path).resolve() if path else page
        where = f"{page.relative_to(root)}: ({target})"
        if not resolved.exists():
            problems.append(f"{where}: {path} does not exist")
            continue
        if page.parent == docs and not resolved.is_relative_to(docs):
            problems.append(f"{where}: leaves docs/, where the built site cannot follow it")
        if anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
            problems.append(f"{where}: no heading or id '{anchor}' in {resolved.name}")
    return problems


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test01_relative_links_resolve(page):
    assert not link_problems(page), "\n".join(link_problems(page))


def test02_a_broken_link_is_caught(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# A title\n\n[here](missing.md), [there](#a-title), [gone](#nowhere), "
                    "`[code](not-a-link.md)`\n")
    problems = link_problems(page, root=tmp_path, docs=tmp_path)
    assert len(problems) == 2, problems
    assert "missing.md does not exist" in problems[0] and "'nowhere'" in problems[1]


def test03_readme_images_are_committed():
    images = [target for is_image, target in links(ROOT / "README.md") if is_image]
    assert len(images) >= 8
    for target in images:
        path = ROOT / target
        assert path.is_file(), f"README.md shows {target}, which does not exist"
        assert path.stat().st_size < 300_000, f"{target}: keep the README's images small"


def readme_commands() -> list[str]:
    """Every `glrender ...` command line of the README: in code blocks (indented or fenced,
    comments dropped) and in inline code spans."""
    text = (ROOT / "README.md").read_text()
    lines = [m.group(1) for m in re.finditer(r"^(?: {4}|\t)(glrender .*)$", text, re.M)]
    for block in re.findall(r"^```[a-z]*\n(.*?)^```", text, re.S | re.M):
        lines += [line for line in block.splitlines() if line.startswith("glrender ")]
    lines += re.findall(r"`(glrender [^`\n]*)`", text)
    return lines


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def parse(command: str) -> argparse.Namespace | None:
    """The command line parsed by glrender's parser; a command named alone or with --help
    (`glrender render`, `glrender preview --help`) need only name a command."""
    argv = shlex.split(command, comments=True)
    assert argv[0] == "glrender"
    words = [w for w in argv[1:] if w not in ("-h", "--help")]
    if len(words) <= 1:
        assert not words or words[0] in subcommands(), f"README: {command!r}: no such command"
        return None
    try:
        return build_parser().parse_args(argv[1:])
    except SystemExit as exit:
        raise AssertionError(f"README: {command!r} does not parse (exit {exit.code})") from None


def test04_readme_commands_parse():
    commands = readme_commands()
    assert len(commands) >= 10
    for command in commands:
        args = parse(command)
        scene = getattr(args, "scene", None) if args else None
        if scene and scene.startswith("scenes/"):
            assert (ROOT / scene).is_file(), f"README: {command!r} names a missing scene"


def test05_readme_gallery_is_make_gallery():
    """The README shows the commands that made its images (outputs and seeds aside)."""
    spec = importlib.util.spec_from_file_location("make_gallery", ROOT / "tools/make_gallery.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module     # dataclasses look their module up while it loads
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[spec.name]
    ignore = {"output", "out", "seed", "strategy_images"}

    def key(args: argparse.Namespace) -> dict:
        return {k: v for k, v in vars(args).items() if k not in ignore}

    shown = [key(args) for args in map(parse, readme_commands()) if args]
    for shot in module.GALLERY:
        args = parse("glrender " + shot.args.format(out="x.png", dir="d"))
        assert key(args) in shown, f"README does not show the command of {shot.name}.png"
        assert f"docs/images/{shot.name}.png" in (ROOT / "README.md").read_text()


def hand_written_text() -> str:
    return "\n".join(p.read_text() for p in PAGES)


def test06_every_render_option_is_explained():
    render = subcommands()["render"]
    text = hand_written_text()
    missing = [option for action in render._actions for option in action.option_strings
               if option not in ("-h", "--help")
               and not re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", text)]
    assert not missing, f"glrender render options no hand-written page explains: {missing}"
