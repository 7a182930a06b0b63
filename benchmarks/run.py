"""podbench benchmarks: structured deconvolution, POD of tall matrices, Newmark at scale.

Run from the repository root::

    python benchmarks/run.py             # full run (about 15 minutes on 2 cores)
    python benchmarks/run.py --quick     # small sizes only (about a minute)

Options:

``--quick``              (n, k) ∈ {(500, 4), (1000, 6)} with the dense pseudo-inverse at
                         (500, 4) only; POD 20,000 × 500; Newmark 10,000 DOFs.
``--only GROUP ...``     any of ``deconv``, ``pod``, ``newmark``, ``methods`` (default: all).
``--out PATH``           CSV file (default ``results/benchmarks.csv``), written atomically
                         (temporary file + ``os.replace``).
``--readme PATH``        Markdown file whose block between ``<!-- results:start -->`` and
                         ``<!-- results:end -->`` receives the table (default
                         ``benchmarks/README.md``); ``--no-readme`` leaves it alone.
``--dense-budget S``     skip a dense solve whose predicted time exceeds S seconds (default
                         900); predicted from the cube of the matrix size and the first dense
                         measurement.
``--dense-max-gb G``     skip a dense solve whose matrix exceeds G GiB (default 2).
``--newmark-max-gb G``   skip a Newmark storage mode whose n_dofs × n_samples history
                         arrays exceed G GiB (default 2).
``--no-merge``           with ``--only``, the other groups' rows of ``--out`` are kept
                         (merged, and shown in the README table under the earlier run's
                         header) unless this is given.

Layout: ``measure.py`` (a call in a fresh process, one BLAS thread: time, peak memory;
ratios against a baseline of the same run), ``groups.py`` (the benchmark groups),
``report.py`` (CSV and the README's Markdown tables); this file is the command line.

Speed and memory are measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):  # run as a script: make `benchmarks` importable
    sys.path.insert(0, str(ROOT))

from benchmarks import groups, measure, report  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes only")
    ap.add_argument("--only", nargs="+", choices=report.GROUPS, default=report.GROUPS)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "benchmarks.csv")
    ap.add_argument("--no-merge", action="store_true",
                    help="with --only: do not keep the other groups' rows of --out")
    ap.add_argument("--readme", type=Path, default=ROOT / "benchmarks" / "README.md")
    ap.add_argument("--no-readme", action="store_true")
    ap.add_argument("--dense-budget", type=float, default=900.0)
    ap.add_argument("--dense-max-gb", type=float, default=2.0)
    ap.add_argument("--newmark-max-gb", type=float, default=2.0)
    args = ap.parse_args(argv)

    def log(msg):
        print(msg, flush=True)

    started = time.perf_counter()
    rows = []
    if "deconv" in args.only:
        log("Deconvolution (ML and SL on LTI-beam pulse data):")
        sizes = groups.DECONV_SIZES_QUICK if args.quick else groups.DECONV_SIZES
        rows += groups.bench_deconv(sizes, args.dense_budget, args.dense_max_gb, args.quick,
                                    log)
    if "pod" in args.only:
        log("POD of a tall snapshot matrix:")
        rows += groups.bench_pod(args.quick, log)
    if "newmark" in args.only:
        log("Newmark on a large sparse chain:")
        rows += groups.bench_newmark(args.quick, args.newmark_max_gb, log)
    if "methods" in args.only:
        log("Identification methods on the same data:")
        rows += groups.bench_methods(args.quick, log)
    kept = []
    if set(args.only) != set(report.GROUPS) and not args.no_merge and args.out.exists():
        kept = [r for r in report.read_csv(args.out) if r["group"] not in args.only]
        log(f"kept {len(kept)} rows of the other groups from {args.out}")
    rows = sorted(kept + rows, key=lambda r: report.GROUPS.index(r["group"]))  # stable
    report.write_csv(rows, args.out)
    log(f"wrote {args.out} ({len(rows)} rows) in {time.perf_counter() - started:.0f} s")
    if not args.no_readme:
        stamp = _dt.datetime.now().strftime("%Y-%m-%d")
        mode = "--quick" if args.quick else "full run"
        command = "python benchmarks/run.py" + (" --quick" if args.quick else "")
        if set(args.only) != set(report.GROUPS):
            command += " --only " + " ".join(args.only)
        header = f"Measured {stamp} ({mode}, `{command}`) on: {measure.machine()}."
        previous = report.previous_header(args.readme) if kept else ""
        if previous:
            names = ", ".join(sorted({r["group"] for r in kept}, key=report.GROUPS.index))
            header = (f"{previous}\n\n{header.replace('Measured', 'Re-measured', 1)} "
                      f"Rows of {names} are from the run above.")
        report.write_readme(rows, args.readme, header)
        log(f"updated {args.readme}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
