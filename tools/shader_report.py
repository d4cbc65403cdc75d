"""Which tests build which shader programs: a report over a GLRENDER_SHADER_LOG file.

    GLRENDER_SHADER_LOG=/tmp/shaders.jsonl MESA_SHADER_CACHE_DIR=$(mktemp -d) pytest -q tests/render
    python tools/shader_report.py /tmp/shaders.jsonl [--top 30]

Every process that inherits the variable (the suite's CLI subprocesses too) appends one line
per program it builds and one per compute kernel's first dispatch (glrender/gl/shaders.py).
A program is counted once per distinct final source (``key``): with one Mesa disk cache for
the whole run, a second process building the same source finds it in that cache. The report
gives the totals, the test files by the seconds of the programs they were first to build,
and the near-duplicates: programs of one entry point whose sources differ only in their
generated scene code (each small scene compiled into its kernel) or only in some defines.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict


def load(path: str) -> tuple[dict, dict]:
    """First compile record of each distinct program key, and its first-dispatch seconds
    (the first process's)."""
    programs: dict[str, dict] = {}
    dispatch: dict[str, float] = {}
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                sys.exit(f"{path}:{n}: not a JSON line of GLRENDER_SHADER_LOG")
            if rec.get("event") == "compile":
                programs.setdefault(rec["key"], rec)
            elif rec.get("event") == "first_dispatch":
                dispatch.setdefault(rec["key"], rec["seconds"])
    return programs, dispatch


def test_file(test: str) -> str:
    return test.split("::")[0] if test else "(outside a test)"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log")
    ap.add_argument("--top", type=int, default=25, help="rows per table (default 25)")
    ap.add_argument("--drop", default="", help="comma-separated defines (or 'generated'): how "
                    "many programs would remain were they all not part of the source")
    args = ap.parse_args(argv)
    programs, dispatch = load(args.log)
    compile_s = sum(p["seconds"] for p in programs.values())
    first_s = sum(dispatch.get(k, 0.0) for k in programs)
    print(f"{len(programs)} distinct programs: {compile_s:.1f} s compile, {first_s:.1f} s first "
          f"dispatches ({sum(k in dispatch for k in programs)} dispatched)")

    by_file: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
    for k, p in programs.items():
        row = by_file[test_file(p["test"])]
        row[0] += 1
        row[1] += p["seconds"] + dispatch.get(k, 0.0)
    print(f"\nprograms first built by each test file (top {args.top} by seconds):")
    for name, (count, sec) in sorted(by_file.items(), key=lambda kv: -kv[1][1])[:args.top]:
        print(f"  {count:5d} {sec:8.1f} s  {name}")

    by_entry: dict[str, list] = defaultdict(list)
    for k, p in programs.items():
        by_entry[p["entry"]].append(p)
    print("\nprograms per entry point:")
    for entry, ps in sorted(by_entry.items(), key=lambda kv: -len(kv[1]))[:args.top]:
        scenes = {p["generated"] for p in ps}
        shapes = {json.dumps([p["defines"], p["slots"]], sort_keys=True) for p in ps}
        sec = sum(p["seconds"] + dispatch.get(p["key"], 0.0) for p in ps)
        print(f"  {len(ps):5d} {sec:8.1f} s  {entry}: {len(scenes)} generated scenes, "
              f"{len(shapes)} define/slot sets")

    # near-duplicates: same entry, defines and slots, different generated scene code
    groups: dict[str, list] = defaultdict(list)
    for p in programs.values():
        groups[json.dumps([p["entry"], p["defines"], p["slots"]], sort_keys=True)].append(p)
    multi = [g for g in groups.values() if len({p["generated"] for p in g}) > 1]
    print(f"\n{sum(len(g) for g in multi)} programs in {len(multi)} groups differ only in their "
          f"generated scene code")
    # defines that vary among programs of one entry point and slot set
    varying: dict[str, set] = defaultdict(set)
    for entry, ps in by_entry.items():
        by_slots: dict[str, list] = defaultdict(list)
        for p in ps:
            by_slots[json.dumps(p["slots"], sort_keys=True)].append(p)
        for group in by_slots.values():
            names = set().union(*(p["defines"] for p in group))
            for name in names:
                values = {json.dumps(p["defines"].get(name)) for p in group}
                if len(values) > 1:
                    varying[name] |= values
    print("\ndefines that vary within one entry point and slot set (distinct values):")
    for name, values in sorted(varying.items(), key=lambda kv: -len(kv[1]))[:args.top]:
        print(f"  {len(values):4d}  {name}")

    # what each part of the key costs: the programs that would merge if it were not part of
    # the source (a define turned into a parameter, or one kernel for all generated scenes)
    def shape(p, drop):
        defines = {k: v for k, v in p["defines"].items() if k not in drop}
        generated = "" if "(generated scene code)" in drop else p["generated"]
        return json.dumps([p["entry"], p["slots"], generated, defines], sort_keys=True)

    parts = sorted(set().union(*(p["defines"] for p in programs.values())) | {"(generated scene code)"}) \
        if programs else []
    total = len({shape(p, ()) for p in programs.values()})
    print(f"\nprograms saved if one part were not in the source (of {total}):")
    saved = [(total - len({shape(p, {part}) for p in programs.values()}), part) for part in parts]
    for n, part in sorted(saved, reverse=True)[:args.top]:
        if n:
            print(f"  {n:5d}  {part}")
    if args.drop:
        drop = {"(generated scene code)" if d == "generated" else d for d in args.drop.split(",")}
        left = len({shape(p, drop) for p in programs.values()})
        print(f"\nwithout {', '.join(sorted(drop))} in the source: {left} of {total} programs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
