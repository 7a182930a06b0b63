"""ERA's order selection against its single fit, as a ratio timed in one process.

    python benchmarks/era_order.py               # prints the ratio; --write adds a row to
    python benchmarks/era_order.py --write       # results/benchmarks.csv (group era_order)
    python benchmarks/era_order.py --case chain6     # a 6-DOF chain, three forced records
    python benchmarks/era_order.py --case painter_street  # as podbench predict --method ERA

``--case chain6``: a fixed-free chain of six 0.01 lbf·s²/in masses on 100 lbf/in springs
(Rayleigh damping α = 0.1 /s, β = 3e-4 s, as chain_ideal), three random-force records at
masses 2, 4 and 6 (1000 samples at 1 ms, seed 0); ``--case painter_street``: the 13
earliest Painter Street events (scenarios/painter_street/data), ERA as the predict
command builds it on measured inputs (Hankel of ERA_BLOCKS seconds). Best of one for
Painter Street (a fit takes seconds).

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
from benchmarks.measure import best_of  # noqa: E402
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


def chain6_records():
    import numpy as np

    from podbench.structures.files import build_structure

    s = build_structure({"name": "chain6", "kind": "chain", "units": "inch, lbf, second",
                            "description": "6-DOF benchmark chain",
                            "chain": {"n": 6, "masses": [0.01] * 6, "springs": [100.0] * 6},
                            "damping": {"type": "rayleigh", "alpha": 0.1, "beta": 3.0e-4}})
    rng = np.random.default_rng(0)
    out = []
    for dof in (1, 3, 5):
        F = np.zeros((6, 1000))
        F[dof, 1:] = rng.standard_normal(999)
        out.append(pb.simulate(s, n_samples=1000, dt=1e-3, force=F))
    return out, ERA


def painter_street_records():
    from podbench.harness.painter_street import data_folder
    from podbench.harness.predict import command_line_estimator, method_entry, read_any

    files = sorted(data_folder().glob("*.npz"))[:13]
    recs = [read_any(str(f), require_outputs=True) for f in files]
    entry = method_entry("ERA")

    def make(**kw):
        est = command_line_estimator(entry, recs, solver="auto", n_modes=None)
        return est.set_params(**kw) if kw else est
    return recs, make


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="add the row to results/benchmarks.csv")
    ap.add_argument("--case", choices=("beam", "chain6", "painter_street"), default="beam")
    args = ap.parse_args(argv)
    if args.case == "beam":
        recs, make = training_records(), ERA
    else:
        recs, make = chain6_records() if args.case == "chain6" else painter_street_records()
    repeats = 1 if args.case == "painter_street" else 3
    t = time.perf_counter()
    chosen = make().fit(recs)
    t_first = time.perf_counter() - t
    order = int(chosen.order_)
    t_select = min(t_first, best_of(lambda: make().fit(recs), repeats))
    t_single = best_of(lambda: make(order=order).fit(recs), repeats)
    ratio = t_select / t_single
    print(f"{args.case}: ERA order selection (orders 1..40, chosen {order}): "
          f"{t_select * 1e3:.1f} ms; "
          f"single fit at order {order}: {t_single * 1e3:.1f} ms; ratio {ratio:.2f}x "
          "(target <= 5x)")
    if args.write and args.case == "beam":
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
