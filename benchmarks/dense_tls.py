"""The dense solvers' fast paths against their references, timed in one process (issue 24
item 10).

Systems shaped like Chapter 5's (``scenarios/chapter5``): n = 1024 samples at Δt = 1e-4 s,
a 0.5-ms half-sine strike with a rebound (lbf), a kernel of two damped modes (in/(lbf·s)),
per-channel noise on force and response (seed 0). SL: one mode, one load case
(1024 × 1024, one right-hand side); ML: two modes, two load cases (2048 × 2048, two
right-hand sides). For each, one BLAS thread, best of ``--repeat``:

* ``tls`` with ``scale=True`` (Chapter 5's ``tls-scaled``): the fast path (eigenvectors of
  ``[A | B]ᵀ[A | B]`` below the cut, a Rayleigh–Ritz step on ``[A | B]``) against the
  reference (the economy SVD, ``dense._tls_svd``), with their relative difference;
* the memo of the built-in dense solvers: a repeated ``ls`` solve of the same system
  against the first one (``gelsd``).

::

    python benchmarks/dense_tls.py                # noise 5 %, repeat 2
    python benchmarks/dense_tls.py --noise 0.01 --repeat 3

Speed is measured here only, never asserted in the tests
(``tests/sysid/test_dense_fast.py`` checks the answers).
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

N, DT = 1024, 1.0e-4


def _strike(n, delay, amp, rng, noise):
    import numpy as np

    t = np.arange(n) * DT
    f = np.zeros(n)
    for t0, a in ((1e-4 + delay, amp), (3e-3 + delay, 0.35 * amp)):
        on = (t >= t0) & (t < t0 + 5e-4)
        f[on] += a * np.sin(np.pi * (t[on] - t0) / 5e-4)
    return f + noise * np.sqrt(np.mean(f ** 2)) * rng.standard_normal(n)


def _system(k: int, n_cases: int, noise: float, seed: int = 0):
    """``(Q_list, B)`` of a k-mode, n_cases-case convolution system with noisy data."""
    import numpy as np

    from podbench.sysid.deconvolution import convolution_product

    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    kern = np.zeros((k * N, k))
    for i in range(k):
        w = 2 * np.pi * (10.0 + 53.0 * i)
        kern[i * N:(i + 1) * N, i] = np.exp(-0.01 * w * t) * np.sin(w * t) / w
    Q = [np.vstack([_strike(N, 1e-4 * (i + j), 2.0 - 0.2 * i, rng, noise) for i in range(k)])
         for j in range(n_cases)]
    B = convolution_product(Q, kern, DT)
    B = B + noise * np.sqrt(np.mean(B ** 2, axis=0)) * rng.standard_normal(B.shape)
    return Q, B


def _best(fn, repeat: int):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def run(noise: float, repeat: int) -> list[str]:
    import numpy as np

    from podbench.sysid.deconvolution import ConvolutionSystem, dense

    lines = [f"noise {noise:g}, one BLAS thread, best of {repeat} (s)",
             f"{'system':<22}{'path':<12}{'reference':>10}{'fast':>10}{'ratio':>8}"
             f"{'rel. diff':>11}"]
    for label, k, cases in (("SL 1024 x 1024, r=1", 1, 1), ("ML 2048 x 2048, r=2", 2, 2)):
        Q, B = _system(k, cases, noise)
        system = ConvolutionSystem(Q, B, DT)
        A, B2 = system.dense(), system._B2
        da, db = dense._column_scales(A), dense._column_scales(B2)
        t_ref, (Xr, _) = _best(lambda A=A, B2=B2, da=da, db=db: dense._tls_svd(
            A / da, B2 / db, None, None, None), repeat)
        t_new, (Xf, _) = _best(lambda A=A, B2=B2: dense._tls(A, B2, None, None, None, True),
                               repeat)
        Xr = Xr / da[:, None] * db[None, :]
        diff = float(np.linalg.norm(Xf - Xr) / np.linalg.norm(Xr))
        lines.append(f"{label:<22}{'tls-scaled':<12}{t_ref:>10.3f}{t_new:>10.3f}"
                     f"{t_ref / t_new:>8.1f}{diff:>11.1e}")
        dense._MEMO.clear()
        t_first, first = _best(lambda system=system: (dense._MEMO.clear(), dense.LeastSquares()
                                                       .solve(system))[1], 1)
        t_hit, hit = _best(lambda system=system: dense.LeastSquares().solve(system), repeat)
        same = 0.0 if np.array_equal(first.X, hit.X) else float("nan")
        lines.append(f"{label:<22}{'ls memo':<12}{t_first:>10.3f}{t_hit:>10.3f}"
                     f"{t_first / t_hit:>8.0f}{same:>11.1e}")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--noise", type=float, default=0.05, help="per-channel noise (default 0.05)")
    ap.add_argument("--repeat", type=int, default=2, help="best of N (default 2)")
    args = ap.parse_args(argv)
    print("\n".join(run(args.noise, args.repeat)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
