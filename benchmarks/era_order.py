"""ERA's order selection against its single fit, as a ratio timed in one process.

    python benchmarks/era_order.py               # prints the ratio; --write adds a row to
    python benchmarks/era_order.py --write       # results/benchmarks.csv (group era_order)

The training set is the peers study's forced set (scenarios/peers/peers_forced.toml: four
500-lbf, 0.5-ms pulses at 2, 7, 11, 16 in on the LTI beam, 500 samples at 0.1 ms). The
single fit is ``ERA(order=N)`` at the order the hold-out rule chooses; the selection is
``ERA()`` (the rule over orders 1 … 40: each candidate's realization from the shared SVD and
a simulation of every training record). Best of three each, one BLAS thread. Target: the
selection within 5× of the single fit.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

import podbench as pb  # noqa: E402
from benchmarks import report  # noqa: E402
from podbench.dynamics.excitations import excitation_from_dict  # noqa: E402
from podbench.sysid.methods import ERA  # noqa: E402

LOADS = (2.0, 7.0, 11.0, 16.0)


def training_records():
    s = pb.load_structure("lti_beam")
    out = []
    for x in LOADS:
        f = excitation_from_dict({"kind": "pulse", "location": x, "amplitude": 500.0,
                                  "duration": 5e-4})
        out.append(pb.simulate(s, n_samples=500, dt=1e-4, force=f))
    return out


def best_of(fn, repeats: int = 3) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="add the row to results/benchmarks.csv")
    args = ap.parse_args(argv)
    recs = training_records()
    chosen = ERA().fit(recs)
    order = int(chosen.order_)
    t_select = best_of(lambda: ERA().fit(recs))
    t_single = best_of(lambda: ERA(order=order).fit(recs))
    ratio = t_select / t_single
    print(f"ERA order selection (orders 1..40, chosen {order}): {t_select * 1e3:.1f} ms; "
          f"single fit at order {order}: {t_single * 1e3:.1f} ms; ratio {ratio:.2f}x "
          "(target <= 5x)")
    if args.write:
        path = ROOT / "results" / "benchmarks.csv"
        rows = [r for r in report.read_csv(path) if r.get("group") != "era_order"]
        rows.append(report.row(group="era_order", case="ERA lti_beam 4 pulses", n=500, k=4,
                               m=25, solver=f"order {order}", status="ok",
                               time_s=f"{t_select:.4g}", baseline="single fit",
                               baseline_time_s=f"{t_single:.4g}", speedup=f"{1 / ratio:.3g}",
                               note=f"selection/single = {ratio:.2f} "
                                    "(python benchmarks/era_order.py)"))
        report.write_csv(rows, path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
