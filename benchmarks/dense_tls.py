"""The dense solvers' fast paths against their references, timed in one process.

Systems shaped like Chapter 5's (``scenarios/chapter5``): n = 1024 samples at Δt = 1e-4 s,
a 0.5-ms half-sine strike with a rebound (lbf), a kernel of two damped modes (in/(lbf·s)),
per-channel noise on force and response (seed 0). SL: one mode, one load case
(1024 × 1024, one right-hand side); ML: two modes, two load cases (2048 × 2048, two
right-hand sides). For each, one BLAS thread, best of ``--repeat``:

* ``tls-appendix`` (the dissertation's TLS, Chapter 5's rows) at tol = 1000 and at tol = 20
  (5 % noise's SNR rule): the appendix as written (the full SVD of ``[X y]``), the former
  route (the eigenvectors of ``CᵀC`` below the cut, ``dense._appendix_solve``), and the
  bordered route (``podbench.sysid.deconvolution.bordered``) cold (the eigendecomposition
  of ``XᵀX`` included) and warm (another tol on the same forces), with the relative
  difference of the bordered answer from the SVD's;
* ``ls``: LAPACK's ``gelsd`` against the cached SVD of the convolution matrix, cold and warm
  (another right-hand side on the same forces);
* ``tls-dt`` with ``scale=True`` (Chapter 5's ``tls-dt`` rows): the fast path (eigenvectors
  of ``[A | B]ᵀ[A | B]`` below the cut, a Rayleigh–Ritz step on ``[A | B]``) against the
  reference (the economy SVD, ``dense._tls_svd``), with their relative difference.

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


def _appendix_rows(label, system, repeat) -> list[str]:
    import numpy as np

    from podbench.sysid.deconvolution import AppendixTLS, bordered, dense

    X = system.dense() / DT
    y = system._B2[:, 0]
    out = []
    for tol in (1000.0, 20.0):
        def svd(tol=tol):
            C = np.hstack([X, y[:, None]])
            _, S, Vt = np.linalg.svd(C)
            r = int(np.count_nonzero(S[0] / S <= tol))
            V = Vt.T
            n = V.shape[0] - 1
            return (V[n, :r] * V[:n, :r]).sum(axis=1) / (1 - np.sum(V[n, :r] ** 2))

        def new(tol=tol, cold=True):
            if cold:
                bordered._CACHE.clear()
            return np.ravel(AppendixTLS(tol=tol).solve(system).X) * DT

        t_ref, h_ref = _best(svd, 1)
        t_old, _ = _best(lambda tol=tol: dense._appendix_solve(X, y, tol), repeat)
        t_cold, h = _best(new, 1)
        t_warm, _ = _best(lambda tol=tol: new(tol, cold=False), repeat)
        diff = float(np.linalg.norm(h[:h_ref.size] - h_ref) / np.linalg.norm(h_ref))
        out.append(f"{label:<22}{f'appendix {tol:g}':<16}{t_ref:>9.2f}{t_old:>9.2f}"
                   f"{t_cold:>9.2f}{t_warm:>9.3f}{diff:>11.1e}")
    return out


def run(noise: float, repeat: int) -> list[str]:
    import numpy as np

    from podbench.sysid.deconvolution import ConvolutionSystem, bordered, dense

    lines = [f"noise {noise:g}, one BLAS thread, best of {repeat} (s)",
             f"{'system':<22}{'path':<16}{'svd/ref':>9}{'former':>9}{'cold':>9}{'warm':>9}"
             f"{'rel. diff':>11}"]
    for label, k, cases in (("SL 1024 x 1024, r=1", 1, 1), ("ML 2048 x 2048, r=2", 2, 2)):
        Q, B = _system(k, cases, noise)
        system = ConvolutionSystem(Q, B, DT)
        lines += _appendix_rows(label, ConvolutionSystem(Q, B[:, 0], DT), repeat)
        A, B2 = system.dense(), system._B2
        t_ref, (Xr, _) = _best(lambda A=A, B2=B2: dense._lstsq(A, B2, None), 1)
        dense._MEMO.clear()
        bordered._SVD_CACHE.clear()
        t_cold, Xc = _best(lambda system=system: dense.LeastSquares().solve(system).X, 1)
        other = ConvolutionSystem(Q, 2.0 * B, DT)
        t_warm, _ = _best(lambda other=other: (dense._MEMO.clear(),
                                               dense.LeastSquares().solve(other))[1], repeat)
        diff = float(np.linalg.norm(Xc - Xr) / np.linalg.norm(Xr))
        lines.append(f"{label:<22}{'ls (gelsd)':<16}{t_ref:>9.2f}{'':>9}{t_cold:>9.2f}"
                     f"{t_warm:>9.3f}{diff:>11.1e}")
        da, db = dense._column_scales(A), dense._column_scales(B2)
        t_ref, (Xr, _) = _best(lambda A=A, B2=B2, da=da, db=db: dense._tls_svd(
            A / da, B2 / db, None, None, None), 1)
        t_new, (Xf, _) = _best(lambda A=A, B2=B2: dense._tls(A, B2, None, None, None, True),
                               repeat)
        Xr = Xr / da[:, None] * db[None, :]
        diff = float(np.linalg.norm(Xf - Xr) / np.linalg.norm(Xr))
        lines.append(f"{label:<22}{'tls-dt scaled':<16}{t_ref:>9.2f}{'':>9}{t_new:>9.2f}"
                     f"{'':>9}{diff:>11.1e}")
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
