"""benchmarks/results_md.py: a benchmark's new run replaces its old one in RESULTS.md and keeps
the notes written after it."""
import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def results_md():
    spec = importlib.util.spec_from_file_location("results_md", ROOT / "benchmarks" / "results_md.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test01_a_run_replaces_the_last_and_keeps_the_notes(tmp_path):
    rm = results_md()
    path = tmp_path / "RESULTS.md"
    path.write_text("# Benchmark results\n\n## A\n\nrun 1\n\n| x |\n|---|\n| 1 |\n\nnote on A\n\n## B\n\nb\n")
    rm.put_run(path, "## A", "## A\n\nrun 2\n\n| x |\n|---|\n| 2 |\n")
    text = path.read_text()
    assert "run 1" not in text and "| 1 |" not in text
    assert text.index("run 2") < text.index("| 2 |") < text.index("note on A") < text.index("## B")
    rm.put_run(path, "## C", "## C\n\nnew\n")
    assert path.read_text().endswith("## C\n\nnew\n")


def test02_a_run_of_several_tables_ends_at_its_marker(tmp_path):
    rm = results_md()
    path = tmp_path / "RESULTS.md"
    run = "## T\n\nrun {k}\n\n| a |\n|---|\n| {k} |\n\n| b |\n|---|\n| {k}{k} |\n\n" + rm.END_OF_RUN + "\n"
    path.write_text("# Benchmark results\n\n" + run.format(k=1) + "\nnote\n")
    rm.put_run(path, "## T", run.format(k=2))
    text = path.read_text()
    assert "| 1 |" not in text and "| 11 |" not in text
    assert text.count(rm.END_OF_RUN) == 1 and text.count("| 22 |") == 1
    assert text.rstrip().endswith("note")
    assert rm.commit() not in ("", None)


def test03_a_run_with_targets_keeps_them_inside_the_run(tmp_path):
    rm = results_md()
    path = tmp_path / "RESULTS.md"
    for k in (1, 2):
        section = rm.put_run_with_targets(path, "## T", ["## T", "", f"run {k}", "", "| a |", "|---|", f"| {k} |"],
                                          [f"- target {k}: met."])
        if k == 1:
            path.write_text(path.read_text() + "\nnote\n")
    text = path.read_text()
    assert section in text and "target 1" not in text and "| 1 |" not in text
    assert text.index("- target 2: met.") < text.index(rm.END_OF_RUN) < text.index("note")
