"""Robust deconvolution at benchmark sizes: time against ``block`` and prediction error.

The LTI-beam pulse cases of :func:`benchmarks.groups._beam_cases` (k pulse loads at
24 … 24 − 1.5(k − 1) in, a half-sine at 23 in to predict, Δt = 1e-4 s), ML with k POMs.
``block`` runs on the clean records (its time is the reference); every other solver runs on
records with per-channel measurement noise (:func:`podbench.noise.noisy`, ``level`` of each
channel's RMS on every sensor row of W and the loaded row of F, seed 0), and predicts the
noise-free new load; error = ``‖Ŵ − W‖_F / ‖W‖_F``. Each fit runs in this process, one
BLAS thread, solvers one after the other (ratios against ``block`` of the same run)::

    python benchmarks/robust.py                       # n=1000,k=6 and n=8000,k=16, 1 %
    python benchmarks/robust.py --sizes 1000x6 --solvers subspace,auto,kernel

Speed is measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))


def run(n: int, k: int, solvers, level: float, seed: int = 0):
    import numpy as np

    from benchmarks.groups import DT, _beam_cases
    from podbench.sysid.methods import MultipleLoad
    from podbench.sysid.noise import NoiseSpec, noisy

    train, new, _ = _beam_cases(n, k)
    spec = NoiseSpec(level=level, seed=seed)
    noisy_train = [noisy(r, spec, "robust_bench", "lti_beam", f"load{j}")
                   for j, r in enumerate(train)]
    rows = []
    base = None
    for solver in ["block", *solvers]:
        recs = train if solver == "block" else noisy_train
        model = MultipleLoad(n_modes=k, solver=solver)
        t0 = time.perf_counter()
        try:
            model.fit([r.W for r in recs], [r.F for r in recs], dt=DT)
            pred = model.predict(new.F)
            err = float(np.linalg.norm(pred - new.W) / np.linalg.norm(new.W))
            info = getattr(model, "solver_info_", {}) or {}
            note = ", ".join(f"{key}={info[key]}" for key in
                             ("choice", "order", "candidates", "noise_floor") if key in info)
        except Exception as exc:  # a failed fit is a row of the table
            err, note = float("nan"), f"{type(exc).__name__}: {exc}".splitlines()[0][:120]
        t = time.perf_counter() - t0
        if solver == "block":
            base = t
        rows.append((n, k, solver, 0.0 if solver == "block" else level, t, t / base, err, note))
        print(f"seed={seed} n={n:5d} k={k:2d} {solver:12s} noise={rows[-1][3]:g} time={t:8.2f} s "
              f"ratio={t / base:7.1f} error={err:.4g}  {note}", flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="1000x6,8000x16", help="n×k pairs, e.g. 1000x6")
    ap.add_argument("--solvers", default="subspace,auto")
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--seeds", default="0", help="noise seeds, comma-separated")
    args = ap.parse_args(argv)
    import numpy as np

    for size in args.sizes.split(","):
        n, k = (int(v) for v in size.lower().split("x"))
        rows = []
        seeds = [int(v) for v in args.seeds.split(",")]
        for seed in seeds:
            rows += run(n, k, [s for s in args.solvers.split(",") if s], args.noise, seed)
        if len(seeds) > 1:
            for solver in dict.fromkeys(r[2] for r in rows):
                e = np.array([r[6] for r in rows if r[2] == solver])
                t = np.array([r[5] for r in rows if r[2] == solver])
                print(f"n={n} k={k} {solver}: error median {np.median(e):.4g} max "
                      f"{np.max(e):.4g} over seeds {args.seeds}; time ratio median "
                      f"{np.median(t):.3g}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
