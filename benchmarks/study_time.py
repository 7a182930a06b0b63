"""Wall time of a cold study run against a fixed reference workload timed in the same run.

    python benchmarks/study_time.py                       # chapter5, --jobs 2, no figures
    python benchmarks/study_time.py --study chapter4 --jobs 1
    python benchmarks/study_time.py --tree /path/to/other/checkout   # time another commit
    python benchmarks/study_time.py --baseline-tree /path/to/previous/checkout  # speed-up
    python benchmarks/study_time.py --keep /tmp/ch5 --no-write   # keep the tables to compare

A shared machine's speed changes from minute to minute, so a study's wall time alone says
little; this script times a fixed reference workload (:func:`reference`: a seeded dense SVD,
an eigen-decomposition and a pure-Python loop, one BLAS thread, best of three) before and
after the study and reports the study's time in units of it. ``podbench run STUDY`` runs in
a fresh process with an empty truth cache (``--cache`` in a temporary folder: cold) and
``--no-figures``. The row goes to ``results/benchmarks.csv`` (group ``study``, replacing a
row of the same study, jobs and tree name; the other rows are kept) unless ``--no-write``.

Speed is measured here only, never asserted in the tests (issue 24 item 10: "a cold run of
the whole Chapter 5 study finish in 2 minutes on 2 cores").
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

from benchmarks import report  # noqa: E402

REFERENCE = """
import time, numpy as np, scipy.linalg as sl
rng = np.random.default_rng(0)
A = rng.standard_normal((800, 800))
best = float("inf")
for _ in range(3):
    t = time.perf_counter()
    sl.svd(A, lapack_driver="gesdd")
    sl.eigh(A + A.T)
    x = 0.0
    for i in range(1_000_000):
        x += i * 1e-9
    best = min(best, time.perf_counter() - t)
print(best)
"""


def _env() -> dict:
    env = dict(os.environ)
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[var] = "1"
    return env


def reference(python: str) -> float:
    """Seconds of the reference workload (best of three) in a fresh process."""
    out = subprocess.run([python, "-c", REFERENCE], check=True, capture_output=True,
                         text=True, env=_env())
    return float(out.stdout.strip())


def run_study(python: str, tree: Path, study: str, jobs: int, keep: Path | None = None) -> float:
    """Wall seconds of a cold ``podbench run STUDY --no-figures --jobs JOBS`` from ``tree``
    (its output folder kept as ``keep`` if given, e.g. to compare the tables byte for byte
    with the committed ones)."""
    env = _env()
    env["PYTHONPATH"] = str(tree)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out" if keep is None else keep.resolve()
        cmd = [python, "-m", "podbench", "run", study, "--no-figures", "--quiet",
               "--jobs", str(jobs), "--cache", str(Path(tmp) / "cache"),
               "--out", str(out)]
        t = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, cwd=tmp, stdout=subprocess.DEVNULL)
        return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default="chapter5")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--tree", type=Path, default=ROOT,
                    help="checkout whose podbench is timed (default: this one)")
    ap.add_argument("--baseline-tree", type=Path, default=None,
                    help="another checkout (e.g. the previous commit, `git worktree add`) "
                         "timed in the same session, before the tree: the row then states "
                         "the speed-up tree against it")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "benchmarks.csv")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--keep", type=Path, default=None,
                    help="keep the timed run's output folder here (new or empty; the tables "
                         "can then be compared with results/STUDY)")
    args = ap.parse_args(argv)
    base_note = ""
    if args.baseline_tree is not None:
        b0 = reference(args.python)
        base = run_study(args.python, args.baseline_tree.resolve(), args.study, args.jobs)
        b1 = reference(args.python)
        base_units = base / (0.5 * (b0 + b1))
        base_note = (f"; baseline {args.baseline_tree.resolve().name}: {base:.1f} s wall, "
                     f"{base_units:.0f} reference units")
    ref0 = reference(args.python)
    wall = run_study(args.python, args.tree.resolve(), args.study, args.jobs, args.keep)
    ref1 = reference(args.python)
    ref = 0.5 * (ref0 + ref1)
    case = f"podbench run {args.study} (cold, no figures, --jobs {args.jobs})"
    note = (f"reference workload {ref0:.2f} s before, {ref1:.2f} s after; the study takes "
            f"{wall / ref:.0f} reference units; tree {args.tree.resolve().name}; load "
            f"{os.getloadavg()[0]:.1f}{base_note}")
    if args.baseline_tree is not None:
        note += f"; speed-up in reference units {base_units / (wall / ref):.2f}x"
    print(f"{case}: {wall:.1f} s wall = {wall / ref:.1f} × the reference workload "
          f"({ref:.2f} s); {note}")
    if not args.no_write:
        rows = report.read_csv(args.out) if args.out.exists() else []
        rows = [r for r in rows if not (r["group"] == "study" and r["case"] == case
                                        and args.tree.resolve().name in r["note"])]
        rows.append(report.row(group="study", case=case, solver=args.tree.resolve().name,
                               status="ok", time_s=f"{wall:.1f}", baseline="reference workload",
                               baseline_time_s=f"{ref:.3f}", speedup=f"{ref / wall:.4f}",
                               note=note))
        report.write_csv(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
