"""The appendix TLS's eigendecomposition of ``XᵀX``: the factored route against the dense one.

Chapter 5's rows are the dissertation's TLS (``tls-appendix``), solved through the
eigendecomposition ``(μ, Q)`` of ``A = XᵀX`` bordered by ``Xᵀy``
(``podbench.sysid.deconvolution.bordered``); one per set of noisy forces, the largest
dense item of a cold ``podbench run chapter5``. Two routes, timed in one process on
systems shaped like Chapter 5's (``benchmarks/dense_tls.py``'s: n = 1024 samples, SL one
mode and one load case, ``A`` 1024 × 1024; ML two modes and two load cases, 2048 × 2048;
5 % per-channel noise), one BLAS thread:

* dense (the former route): LAPACK ``syevd`` of ``A`` (``scipy.linalg.eigh(driver="evd")``),
  ``Q`` formed;
* factored (``bordered.gram_eigh``): ``sytrd`` + ``stevd``, ``Q = HZ`` kept factored and
  applied to vectors only (no back-transformation).

Each includes forming ``A`` from correlations and one ``tlsdeconv`` at tol = 1000 and at
tol = 20 (the 5 % SNR rule) on the first right-hand side. Printed per system: best-of
seconds of each, their ratio, the reference workload of ``benchmarks/study_time.py`` timed
in the same process (so the seconds read as reference units on another day), and the
largest relative difference of ``h`` between the routes and of each from the full SVD of
``[X y]`` (the appendix as written). Times are CPU seconds of this process
(``time.process_time``), which a loaded machine inflates far less than wall seconds::

    python benchmarks/tls_route.py               # repeat 3
    python benchmarks/tls_route.py --repeat 5 --noise 0.01

A second table times the ``tol`` rows of one fit (:data:`TOL_ROWS`) on one ``(μ, Q)``: the
secular equation kept with the roots found so far against a fresh one per ``tol``.

``--tridiagonal`` times the prototype of ``benchmarks/tls_tridiagonal.py`` (no ``stevd``:
the secular equation by tridiagonal solves; not adopted, see there) against the current
route at 0, 1 and 5 % noise (``--chapter5``: on the linear beam's 5 % records), the SNR
rule's tol and four others: factorization and tol rows' CPU seconds, the
kept counts, ``1 − ΣV²`` and ``h``'s deviation from the current route and the full SVD.

Speed is measured here only, never asserted in the tests
(``tests/sysid/test_appendix_tls.py`` checks the factored route against the dense one).
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


def _reference() -> float:
    """One pass of ``study_time.REFERENCE``'s workload (CPU seconds), in this process."""
    import numpy as np
    import scipy.linalg as sl

    rng = np.random.default_rng(0)
    A = rng.standard_normal((800, 800))
    t = time.process_time()
    sl.svd(A, lapack_driver="gesdd")
    sl.eigh(A + A.T)
    x = 0.0
    for i in range(1_000_000):
        x += i * 1e-9
    return time.process_time() - t


def _dense_eigh(G):
    """The former route: ``A`` assembled as ``gram_eigh`` does, then ``syevd``, ``Q`` formed."""
    import scipy.linalg

    from podbench.sysid.deconvolution.bordered import gram_matrix

    A = gram_matrix(G)
    return scipy.linalg.eigh(A, driver="evd")


def _solve(eig, G, y, n_rows):
    from podbench.sysid.deconvolution import bordered

    mu, Q = eig
    b = bordered.border(G, y)
    return [bordered.bordered_tls(mu, Q, b, float(y @ y), tol, n_rows)[0]
            for tol in (1000.0, 20.0)]


def _svd_h(system, tols):
    """``tlsdeconv`` as the appendix writes it (the full SVD of ``[X y]``), at each tol."""
    import numpy as np

    X = system.dense() / system.dt
    y = system._B2[:, 0]
    _, S, Vt = np.linalg.svd(np.hstack([X, y[:, None]]))
    V = Vt.T
    n = V.shape[0] - 1
    out = []
    for tol in tols:
        r = min(int(np.count_nonzero(S[0] / S <= tol)), X.shape[0])
        out.append((V[n, :r] * V[:n, :r]).sum(axis=1) / (1 - np.sum(V[n, :r] ** 2)))
    return out


def _rel(a, b) -> float:
    import numpy as np

    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def run(noise: float, repeat: int) -> list[str]:
    from benchmarks.dense_tls import DT, _system
    from podbench.sysid.deconvolution import ConvolutionSystem, bordered

    ref = min(_reference() for _ in range(repeat))
    lines = [f"noise {noise:g}, one BLAS thread, best of {repeat}, CPU seconds; reference "
             f"workload {ref:.3f} s",
             f"{'system':<9}{'dense':>7}{'factored':>10}{'ratio':>7}{'dense u':>9}"
             f"{'fact. u':>9}{'h: fact-dense':>15}{'dense-svd':>11}{'fact-svd':>10}"]
    for label, k, cases in (("SL 1024", 1, 1), ("ML 2048", 2, 2)):
        Q, B = _system(k, cases, noise)
        system = ConvolutionSystem(Q, B, DT)
        G, y, n_rows = system.G, system._B2[:, 0], cases * system.G.shape[0]
        t_d, t_f = float("inf"), float("inf")
        for _ in range(repeat):
            t0 = time.process_time()
            h_d = _solve(_dense_eigh(G), G, y, n_rows)
            t_d = min(t_d, time.process_time() - t0)
            bordered._CACHE.clear()
            t0 = time.process_time()
            h_f = _solve(bordered.gram_eigh(G), G, y, n_rows)
            t_f = min(t_f, time.process_time() - t0)
        one = ConvolutionSystem(Q, B[:, 0], DT)
        h_s = _svd_h(one, (1000.0, 20.0))
        diff = max(_rel(a, b) for a, b in zip(h_f, h_d, strict=True))
        d_ds = max(_rel(a, b) for a, b in zip(h_d, h_s, strict=True))
        d_fs = max(_rel(a, b) for a, b in zip(h_f, h_s, strict=True))
        lines.append(f"{label:<9}{t_d:>7.2f}{t_f:>10.2f}{t_d / t_f:>7.2f}{t_d / ref:>9.2f}"
                     f"{t_f / ref:>9.2f}{diff:>15.1e}{d_ds:>11.1e}{d_fs:>10.1e}")
    return lines


TOL_ROWS = (20.0, 10.0, 100.0, 1000.0, 10000.0)
"""The ``tol`` rows of one Chapter 5 fit: the SNR rule (about 20 at 5 % noise) and the
``tls-tol<N>`` variants."""


def run_tol_rows(noise: float, repeat: int) -> list[str]:
    """The ``tol`` rows of one fit on one ``(μ, Q)``: the secular equation kept with its roots
    (``bordered_tls``'s route: each ``tol`` finds only the roots the largest discarded set
    so far lacks) against a fresh secular equation per ``tol`` (every root found again),
    CPU seconds, and whether ``h``, ``r`` and ``den`` agree byte for byte."""
    import numpy as np

    from benchmarks.dense_tls import DT, _system
    from podbench.sysid.deconvolution import ConvolutionSystem, bordered

    lines = [f"{'tol rows':<9}{'fresh':>7}{'kept':>10}{'ratio':>7}  same bytes"]
    for label, k, cases in (("SL 1024", 1, 1), ("ML 2048", 2, 2)):
        Q, B = _system(k, cases, noise)
        G = ConvolutionSystem(Q, B, DT).G
        y = ConvolutionSystem(Q, B, DT)._B2[:, 0]
        n_rows = cases * G.shape[0]
        mu, Qf = bordered.gram_eigh(G)
        b, c = bordered.border(G, y), float(y @ y)
        t_fresh, t_kept = float("inf"), float("inf")
        for _ in range(repeat):
            t0 = time.process_time()
            fresh = [bordered.bordered_tls(mu, Qf, b, c, tol, n_rows,
                                           sec=bordered.secular(mu, Qf.T @ b, c))
                     for tol in TOL_ROWS]
            t_fresh = min(t_fresh, time.process_time() - t0)
            Qf.secular_memo.clear()
            t0 = time.process_time()
            kept = [bordered.bordered_tls(mu, Qf, b, c, tol, n_rows) for tol in TOL_ROWS]
            t_kept = min(t_kept, time.process_time() - t0)
        same = all(a[0].tobytes() == f[0].tobytes() and a[1:] == f[1:]
                   for a, f in zip(kept, fresh, strict=True))
        lines.append(f"{label:<9}{t_fresh:>7.2f}{t_kept:>10.2f}{t_fresh / t_kept:>7.2f}  "
                     f"{same} (r = {', '.join(str(int(np.int64(a[1]))) for a in kept)})")
    return lines


def run_tridiagonal(repeat: int, chapter5: bool = False) -> list[str]:
    """The prototype without ``stevd`` against the current route (module docstring), on
    ``benchmarks/dense_tls.py``'s systems at 0, 1 and 5 % noise or (``chapter5``) on the
    linear beam's 5 % records (``benchmarks/tls_krylov.py``'s ``chapter5_systems``)."""
    from benchmarks.dense_tls import DT, _system
    from benchmarks.tls_krylov import chapter5_systems
    from podbench.sysid.deconvolution import ConvolutionSystem
    from podbench.sysid.deconvolution.dense import snr_tol

    ref = min(_reference() for _ in range(repeat))
    lines = [f"tridiagonal prototype; CPU s, best of {repeat}; reference workload {ref:.3f} s",
             f"{'system':<14}{'factor':>13}{'tol rows':>13}  per tol: r, 1 − ΣV², h vs "
             "current, h vs SVD (current vs SVD)"]
    if chapter5:
        systems = chapter5_systems()
    else:
        systems = [(f"{label} {noise:.0%}", ConvolutionSystem(*_system(k, cases, noise), DT))
                   for noise in (0.0, 0.01, 0.05)
                   for label, k, cases in (("SL 1024", 1, 1), ("ML 2048", 2, 2))]
    for label, system in systems:
        tols = (snr_tol(system, 0), 10.0, 100.0, 1000.0, 10000.0)
        lines += _tridiagonal_rows(label, system, tols, repeat)
    return lines


def _tridiagonal_rows(label, system, tols, repeat) -> list[str]:
    from benchmarks import tls_tridiagonal as tt
    from podbench.sysid.deconvolution import bordered

    G, y = system.G, system._B2[:, 0]
    n_rows = G.shape[0] * G.shape[1]
    b, c = bordered.border(G, y), float(y @ y)
    times = [float("inf")] * 4
    for _ in range(repeat):
        bordered._CACHE.clear()
        t0 = time.process_time()
        mu, Qf = bordered.gram_eigh(G)
        t1 = time.process_time()
        cur = [bordered.bordered_tls(mu, Qf, b, c, t, n_rows, min_den=1e-12) for t in tols]
        t2 = time.process_time()
        tri = tt.gram_tridiagonal(G)
        t3 = time.process_time()
        new = [tt.tridiagonal_tls(tri, b, c, t, n_rows, min_den=1e-12) for t in tols]
        t4 = time.process_time()
        times = [min(a, x) for a, x in zip(times, (t1 - t0, t2 - t1, t3 - t2, t4 - t3),
                                           strict=True)]
    h_s = _svd_h(system, tols)
    lines = [f"{label:<14}{times[0]:>6.2f}→{times[2]:<5.2f}{times[1]:>6.2f}→{times[3]:<5.2f}"]
    for t, a, nw, h in zip(tols, cur, new, h_s, strict=True):
        lines.append(f"{'':<16}tol {t:<6.4g} r {a[1]}→{nw[1]}, 1−ΣV² {a[2]:.6f}→"
                     f"{nw[2]:.3g}, {_rel(nw[0], a[0]):.1e}, {_rel(nw[0], h):.1e} "
                     f"({_rel(a[0], h):.1e})")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--noise", type=float, default=0.05, help="per-channel noise (default 0.05)")
    ap.add_argument("--repeat", type=int, default=3, help="best of N (default 3)")
    ap.add_argument("--tridiagonal", action="store_true",
                    help="time the prototype without stevd (benchmarks/tls_tridiagonal.py)")
    ap.add_argument("--chapter5", action="store_true",
                    help="with --tridiagonal: on the linear beam's 5 %% records")
    args = ap.parse_args(argv)
    if args.tridiagonal:
        print("\n".join(run_tridiagonal(args.repeat, args.chapter5)))
        return 0
    print("\n".join(run(args.noise, args.repeat) + run_tol_rows(args.noise, args.repeat)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
