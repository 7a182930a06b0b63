"""Wall time of a cold study run against a fixed reference workload timed in the same run.

    python benchmarks/study_time.py                       # chapter5, --jobs auto, no figures
    python benchmarks/study_time.py --study chapter4 --jobs 1
    python benchmarks/study_time.py --jobs 1,2           # both in one session, one row each
    python benchmarks/study_time.py --tree /path/to/other/checkout   # time another commit
    python benchmarks/study_time.py --baseline-tree /path/to/previous/checkout  # speed-up
    python benchmarks/study_time.py --keep /tmp/ch5 --no-write   # keep the tables to compare

A shared machine's speed changes from minute to minute, so a study's wall time alone says
little; this script times a fixed reference workload (:func:`reference`: a seeded dense SVD,
an eigen-decomposition and a pure-Python loop, one BLAS thread, best of three) before and
after the study and reports the study's time in units of it. It also reports the CPU
seconds the run's processes used (its own and its spawned workers', from the children's
resource usage), which a loaded machine inflates much less than the wall time, and their
ratio to the wall time (about ``jobs`` when the run kept its processes busy).
``podbench run STUDY`` runs in a fresh process with an empty truth cache (``--cache`` in a
temporary folder: cold) and ``--no-figures``. The rows go to ``results/benchmarks.csv``
(group ``study``, each replacing a row of the same study, jobs and tree name; the other rows
are kept) unless ``--no-write``.

Speed is measured here only, never asserted in the tests (issue 24 item 10: "a cold run of
the whole Chapter 5 study finish in 2 minutes on 2 cores").
"""

from __future__ import annotations

import argparse
import os
import resource
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


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run_study(python: str, tree: Path, study: str, jobs: str,
              keep: Path | None = None) -> tuple[float, float]:
    """Wall and CPU seconds of a cold ``podbench run STUDY --no-figures --jobs JOBS`` from
    ``tree`` (its output folder kept as ``keep`` if given, e.g. to compare the tables byte
    for byte with the committed ones)."""
    env = _env()
    env["PYTHONPATH"] = str(tree)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out" if keep is None else keep.resolve()
        cmd = [python, "-m", "podbench", "run", study, "--no-figures", "--quiet",
               "--jobs", str(jobs), "--cache", str(Path(tmp) / "cache"),
               "--out", str(out)]
        t, c = time.perf_counter(), _children_cpu()
        subprocess.run(cmd, check=True, env=env, cwd=tmp, stdout=subprocess.DEVNULL)
        return time.perf_counter() - t, _children_cpu() - c


def _time_one(args, jobs: str, keep: Path | None) -> dict:
    """One timed run between two reference workloads: its row and its printed line."""
    base_note = ""
    if args.baseline_tree is not None:
        b0 = reference(args.python)
        base, _ = run_study(args.python, args.baseline_tree.resolve(), args.study, jobs)
        b1 = reference(args.python)
        base_units = base / (0.5 * (b0 + b1))
        base_note = (f"; baseline {args.baseline_tree.resolve().name}: {base:.1f} s wall, "
                     f"{base_units:.0f} reference units")
    ref0 = reference(args.python)
    load0 = os.getloadavg()[0]
    wall, cpu = run_study(args.python, args.tree.resolve(), args.study, jobs, keep)
    ref1 = reference(args.python)
    ref = 0.5 * (ref0 + ref1)
    case = f"podbench run {args.study} (cold, no figures, --jobs {jobs})"
    note = (f"reference workload {ref0:.2f} s before, {ref1:.2f} s after; the study takes "
            f"{wall / ref:.0f} reference units; {cpu:.0f} s of CPU ({cpu / wall:.2f} per wall "
            f"second); tree {args.tree.resolve().name}; load {load0:.1f} before, "
            f"{os.getloadavg()[0]:.1f} after{base_note}")
    if args.baseline_tree is not None:
        note += f"; speed-up in reference units {base_units / (wall / ref):.2f}x"
    print(f"{case}: {wall:.1f} s wall = {wall / ref:.1f} × the reference workload "
          f"({ref:.2f} s); {note}", flush=True)
    return report.row(group="study", case=case, solver=args.tree.resolve().name,
                      status="ok", time_s=f"{wall:.1f}", baseline="reference workload",
                      baseline_time_s=f"{ref:.3f}", speedup=f"{ref / wall:.4f}", note=note)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default="chapter5")
    ap.add_argument("--jobs", default="auto",
                    help="--jobs of the timed run, or several separated by commas (one run "
                         "and one row each, in this order; default auto)")
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
                    help="keep the timed runs' output folders here, one per --jobs value "
                         "(KEEP/jobs-N; the tables can then be compared with results/STUDY)")
    args = ap.parse_args(argv)
    new = [_time_one(args, j, None if args.keep is None else args.keep / f"jobs-{j}")
           for j in args.jobs.split(",")]
    if not args.no_write:
        rows = report.read_csv(args.out) if args.out.exists() else []
        for r in new:
            rows = [o for o in rows if not (o["group"] == "study" and o["case"] == r["case"]
                                            and o["solver"] == r["solver"])]
        report.write_csv(rows + new, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
