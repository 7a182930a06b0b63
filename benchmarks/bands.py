"""Cost of a 90 % prediction band against the plain fit and predict (issue 21 target: ≤ 5×).

The LTI beam of §4.1 at the calibration study's designs (``scenarios/calibration``:
rectangular 500-lbf, 0.5-ms pulses, n = 500 samples, Δt = 1e-4 s): ML6 fits 4 modes on the
loads at 2, 6, 10, 14, 18, 22 in; ML4 is Chapter 4's design (2, 7, 11, 16 in); SL fits the
load at 2 in; MDS5 / POVR the free-response designs (static deflections). The input/output
methods (FIR-LS, ML-TC) take one input channel, the load at 14 in, in six records of other
pulse shapes, durations and hits (lag grid 10, 20, 40 ms). Each case is run on the clean
records and, with ``--noise``, on records with per-channel noise
(:func:`podbench.noise.noisy`, seed 0).

For each case, in this process, one BLAS thread, best of ``--repeat``:
``plain`` = fit + ``predict(target)``; ``band`` = fit + ``predict(target, coverage=0.9)``
(the calibration: leave-one-record-out refits and/or noise refits, then the band).
The ratio band / plain is the cost target of issue 21; ``floor`` is (plain + the
calibration's refits) / plain (:func:`refit_time`: the leave-one-record-out folds and the
noise refits), the least a band built on refits can cost::

    python benchmarks/bands.py                   # every case, clean and 1 % noise
    python benchmarks/bands.py --cases ML6-cgls ML4-cgls --repeat 5
    python benchmarks/bands.py --cpu --repeat 15  # CPU time of this process (a shared machine)
    python benchmarks/bands.py --max-folds 3     # the variant bands.MAX_FOLDS = 3

``--cpu`` times with ``time.process_time`` instead of the wall clock: with one BLAS thread
the process's CPU time is the work done, which other processes on a loaded machine move far
less than the wall time (still by cache sharing: take more repeats).

The cases here are a few milliseconds of one beam; the cost on the path the acceptance check
runs (``podbench predict … --coverage 0.9`` on files of held-out-like designs) is
``benchmarks/bands_cli.py``'s.

Speed is measured here only, never asserted in the tests.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))

N, DT = 500, 1.0e-4
ML6 = (2.0, 6.0, 10.0, 14.0, 18.0, 22.0)
ML4 = (2.0, 7.0, 11.0, 16.0)
IO_LAGS = (0.01, 0.02, 0.04)
"""Lag grid (s) of the input/output methods (100, 200, 400 samples of the 500)."""
FREE = ([(17.0, 300.0), (18.0, 200.0), (24.0, -260.0)], [(24.0, 100.0)], [(8.0, -300.0)],
        [(12.0, 250.0), (20.0, -150.0)], [(5.0, 400.0), (22.0, 80.0)])


def _forced(s, positions):
    import podbench as pb
    from podbench.dynamics.excitations import Pulse

    return [pb.simulate(s, n_samples=N, dt=DT, force=Pulse(x, 500.0, 5e-4)) for x in positions]


def _cases():
    """``{label: (make_method, train, target)}`` on the LTI beam."""
    import numpy as np

    import podbench as pb
    from podbench.core.records import Record
    from podbench.dynamics.excitations import Pulse, StaticDisplacement
    from podbench.sysid.methods import MDS, POVR, FIRLeastSquares, MultipleLoad, SingleLoad

    s = pb.load_structure("lti_beam")
    ml6, ml4 = _forced(s, ML6), _forced(s, ML4)
    forced_target = pb.simulate(s, n_samples=N, dt=DT,
                                force=Pulse(8.0, 500.0, 5e-4, hits=[[3.0e-3, 0.4]]))
    free = [pb.simulate(s, n_samples=N, dt=DT, initial_displacement=StaticDisplacement(
        loads, reference=s)) for loads in FREE]
    free_target = pb.simulate(s, n_samples=N, dt=DT, initial_displacement=StaticDisplacement(
        [(15.0, 200.0), (24.0, 120.0)], reference=s))
    # one input channel (the load at 14 in): six pulses of other shapes, durations, hits
    io_forces = [Pulse(14.0, 500.0, d, shape=sh) for d, sh in
                 ((5e-4, "rectangular"), (1e-3, "rectangular"), (2e-3, "rectangular"),
                  (1e-3, "half_sine"), (3e-3, "half_sine"))]
    io_forces.append(Pulse(14.0, 500.0, 5e-4, hits=[[2.0e-3, 0.5]]))
    io_sims = [pb.simulate(s, n_samples=N, dt=DT, force=f) for f in io_forces]
    row = int(np.argmax(np.abs(io_sims[0].F).sum(axis=1)))
    io6 = [Record(u=r.F[row:row + 1], y=r.W, dt=DT, input_units="lbf", output_units="in")
           for r in io_sims]
    io_target = pb.simulate(s, n_samples=N, dt=DT,
                            force=Pulse(14.0, 300.0, 5e-4, hits=[[3.0e-3, 0.4]]))
    io_target = Record(u=io_target.F[row:row + 1], y=io_target.W, dt=DT,
                       input_units="lbf", output_units="in")
    return {
        "ML6-cgls": (lambda: MultipleLoad(n_modes=4, solver="cgls"), ml6, forced_target),
        "ML6-fft": (lambda: MultipleLoad(n_modes=4, solver="fft"), ml6, forced_target),
        "ML4-cgls": (lambda: MultipleLoad(solver="cgls"), ml4, forced_target),
        "ML4-block": (lambda: MultipleLoad(solver="block"), ml4, forced_target),
        "SL-cgls": (lambda: SingleLoad(n_modes=4, solver="cgls"), ml6[:1], forced_target),
        "MDS5": (lambda: MDS(n_modes=3), free, free_target),
        "POVR": (lambda: POVR(n_modes=3), free[:1], free_target),
        "FIR-LS (IO)": (lambda: FIRLeastSquares(lag_grid=IO_LAGS), io6, io_target),
        "ML-TC (IO)": (lambda: MultipleLoad(inputs="measured", n_lags="auto", solver="ls",
                                                 prior="tc", lag_grid=IO_LAGS), io6, io_target),
    }


def _noisy(recs, label, level):
    import numpy as np

    from podbench.sysid.noise import NoiseSpec, noisy

    spec = NoiseSpec(level=level, seed=0)
    out = []
    for j, r in enumerate(recs):
        if r.u is not None and not r.collocated:  # per-channel noise on y of an IO record
            rng = np.random.default_rng(j)
            y = r.y + level * np.sqrt(np.mean(r.y ** 2, axis=1, keepdims=True)) * \
                rng.standard_normal(r.y.shape)
            out.append(r.replace(y=y))
        else:
            out.append(noisy(r, spec, "bands_bench", "lti_beam", f"{label}{j}"))
    return out


@contextlib.contextmanager
def refits_timed(clock=None):
    """Within the block, the time (s, ``clock``, default :data:`CLOCK`) spent in the band's
    calibration refits accumulates in the yielded one-element list: the leave-one-record-out
    folds (``bands._residuals``: the refits or the method's ``fold_predictions``, and the
    folds' envelopes) and the noise refits (``bands._noise_refits``). Reset it to 0 between
    runs."""
    from podbench.sysid.methods import bands

    clock = clock or CLOCK
    spent = [0.0]

    def timed(f):
        def wrapper(*a, **k):
            t0 = clock()
            try:
                return f(*a, **k)
            finally:
                spent[0] += clock() - t0
        return wrapper

    old = bands._residuals, bands._noise_refits
    bands._residuals, bands._noise_refits = timed(old[0]), timed(old[1])
    try:
        yield spent
    finally:
        bands._residuals, bands._noise_refits = old


def refit_time(fn, repeat: int) -> float:
    """The least time (s) over ``repeat`` calls of ``fn`` (a band) spent in the
    calibration's refits (:func:`refits_timed`). Plain fit + predict + this time is the
    floor of the band's cost: what remains above it is the estimate and the band
    themselves."""
    best = float("inf")
    with refits_timed() as spent:
        for _ in range(repeat):
            spent[0] = 0.0
            fn()
            best = min(best, spent[0])
    return best


CLOCK = time.perf_counter
"""The clock of every timing here (``--cpu``: ``time.process_time``)."""


def best_of(fn, repeat: int) -> float:
    """The least time (s, :data:`CLOCK`) of ``repeat`` calls of ``fn``."""
    best = float("inf")
    for _ in range(repeat):
        t0 = CLOCK()
        fn()
        best = min(best, CLOCK() - t0)
    return best


def measure(labels, levels, repeat: int):
    import numpy as np

    cases = _cases()
    for label in labels:
        make, train, target = cases[label]
        for level in levels:
            recs = train if level == 0 else _noisy(train, label, level)
            truth = np.asarray(target.y if hasattr(target, "y") else target.W)
            try:
                t_plain = best_of(lambda m=make, r=recs, x=target: m().fit(r).predict(x),
                                repeat)
                t_band = best_of(lambda m=make, r=recs, x=target:
                               m().fit(r).predict(x, coverage=0.9), repeat)
                t_refits = refit_time(lambda m=make, r=recs, x=target:
                                      m().fit(r).predict(x, coverage=0.9), repeat)
                p = make().fit(recs).predict(target, coverage=0.9)
            except Exception as exc:  # a failed fit is a row of the table
                yield (label, level, float("nan"), float("nan"), float("nan"), float("nan"),
                       f"{type(exc).__name__}", float("nan"), float("nan"), float("nan"))
                continue
            yield (label, level, t_plain, t_band, t_band / t_plain,
                   1.0 + t_refits / t_plain, p.source,
                   p.covers(truth), p.error_estimate,
                   float(np.linalg.norm(p.mean - truth) / np.linalg.norm(truth)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=None)
    ap.add_argument("--noise", nargs="*", type=float, default=[0.0, 0.01],
                    help="training noise levels (fraction of each channel's RMS)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--max-folds", type=int, default=None,
                    help="the variant bands.MAX_FOLDS (default: leave-one-record-out)")
    ap.add_argument("--cpu", action="store_true",
                    help="time the process's CPU (time.process_time), not the wall clock")
    args = ap.parse_args(argv)
    if args.cpu:
        global CLOCK
        CLOCK = time.process_time
    if args.max_folds is not None:
        from podbench.sysid.methods import bands

        bands.MAX_FOLDS = args.max_folds
    labels = args.cases or list(_cases())
    print("| case | noise | plain (s) | band (s) | band / plain | floor | source | coverage | "
          "estimate | realized |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for row in measure(labels, args.noise, args.repeat):
        label, level, tp, tb, ratio, floor, source, cov, est, real = row
        print(f"| {label} | {level:g} | {tp:.3g} | {tb:.3g} | {ratio:.2f}× | {floor:.2f}× | "
              f"{source} | "
              f"{cov:.3f} | {est:.3g} | {real:.3g} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
