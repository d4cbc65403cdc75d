"""Writing a benchmark's run into benchmarks/RESULTS.md (and the commit it names).

A benchmark's section is a level-2 heading, a paragraph saying how the run was made, its
table, and then notes written by hand (earlier runs, what a run showed). A new run replaces
the heading, the paragraph and the table; the notes after the table stay.
"""
from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def commit() -> str:
    """The checkout's short commit hash, for a benchmark's table ("unknown" outside git)."""
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


#: ends a run of more than one table (or one followed by lines of its own) in its section
END_OF_RUN = "<!-- end of run -->"


def put_run(path: Path, marker: str, section: str) -> None:
    """Write ``section`` (heading, paragraph, table) into ``path`` in place of the run under
    the heading that starts with ``marker``, keeping what followed that run's table (or, for
    a run that ends with :data:`END_OF_RUN`, what followed that line); append it when there
    is no such heading."""
    text = path.read_text() if path.exists() else "# Benchmark results\n"
    start = text.find("\n" + marker)
    if start < 0:
        path.write_text(text.rstrip("\n") + "\n\n" + section.rstrip("\n") + "\n")
        return
    end = text.find("\n## ", start + 1)
    end = len(text) if end < 0 else end
    old = text[start + 1:end].split("\n")
    if END_OF_RUN in old:
        last = old.index(END_OF_RUN) + 1
    else:
        first = next((i for i, line in enumerate(old) if line.startswith("|")), len(old))
        last = first
        while last < len(old) and old[last].startswith("|"):
            last += 1
    rest = "\n".join(old[last:]).strip("\n")
    text = text[:start + 1] + section.rstrip("\n") + "\n" + ("\n" + rest + "\n" if rest else "") + text[end:]
    path.write_text(text.rstrip("\n") + "\n")


def put_run_with_targets(path: Path, marker: str, lines: list[str], targets: list[str]) -> str:
    """:func:`put_run` of a run whose table (``lines``: heading, paragraph, table) is followed
    by its target lines, the run ending with :data:`END_OF_RUN`; returns the section written."""
    section = "\n".join(lines + ["", "Targets:", ""] + targets + ["", END_OF_RUN]) + "\n"
    put_run(path, marker, section)
    return section
