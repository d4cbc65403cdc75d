"""``glrender lab`` and ``glrender compare``: their options and the lab command."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

LAB_DESCRIPTION = """\
Run the estimator lab: each experiment measures the techniques it compares on the same
problem from many independent seeds (mean ± standard error against the exact value,
variance per sample, measured device time per sample, efficiency = 1/(variance·cost) and
ratios to a baseline), then writes DIR/report.md, DIR/results.json and PNG figures
(matplotlib: pip install 'glrender[lab]'). Without EXPERIMENT names, all of them run."""


def add_lab_parsers(sub, cmd_lab, cmd_compare) -> None:
    from ..lab import EXPERIMENTS

    p = sub.add_parser("lab", help="measure variance-reduction techniques; write a report with plots",
                       description=LAB_DESCRIPTION,
                       epilog="experiments: " + ", ".join(EXPERIMENTS),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("experiments", nargs="*", metavar="EXPERIMENT",
                   help="experiments to run (default: all)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--quick", action="store_true",
                   help="small sizes: the whole set in well under two minutes")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="base seed of every run")
    p.add_argument("--device", default=None, metavar="auto|cpu|gpu|N",
                   help="EGL device (as for glrender render)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_lab)

    p = sub.add_parser("compare", help="error and efficiency of two renders against a reference",
                       description="Compare two renders A and B of the same scene against a "
                                   "reference R: MSE, relative MSE and the efficiency ratio "
                                   "(MSE·time of A over that of B; > 1: B is more efficient), "
                                   "written to DIR/compare.json and DIR/compare.md with heat "
                                   "maps of each render's squared error and of the per-block "
                                   "efficiency ratio (colour bars included). Images: EXR, PFM, "
                                   "HDR, NPY, PNG.")
    p.add_argument("a", metavar="A", help="first render")
    p.add_argument("b", metavar="B", help="second render")
    p.add_argument("--ref", required=True, metavar="R", help="reference image of the same scene")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--time-a", type=float, default=None, metavar="SECONDS",
                   help="render time of A (default: from --stats-a, else equal times)")
    p.add_argument("--time-b", type=float, default=None, metavar="SECONDS",
                   help="render time of B (default: from --stats-b, else equal times)")
    p.add_argument("--stats-a", default=None, metavar="FILE.json",
                   help="the --stats file of A's render (its render seconds)")
    p.add_argument("--stats-b", default=None, metavar="FILE.json",
                   help="the --stats file of B's render (its render seconds)")
    p.add_argument("--block", type=int, default=8, metavar="PIXELS",
                   help="block size of the efficiency-ratio map (default 8)")
    p.set_defaults(func=cmd_compare)


def run_lab_command(args) -> int:
    from ..film.io import check_writable
    from ..lab import run
    from ..gl.context import default_context

    check_writable(args.out, "lab report", "--out", folder=True)
    from ..lab.report import pyplot

    pyplot()            # without matplotlib: one line naming how to install it, before any work

    def progress(name):
        if not args.quiet:
            print(f"glrender lab: {name}", file=sys.stderr, flush=True)
    ctx = default_context(args.device) if args.device else None
    run(args.experiments or None, args.out, quick=args.quick, seed=args.seed, ctx=ctx,
        progress=progress)
    print(Path(args.out).resolve() / "report.md")
    return 0
