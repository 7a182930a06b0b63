"""The problem's bound for the appendix TLS: the discarded directions without a dense matrix.

The appendix TLS (``tlsdeconv``; ``podbench.sysid.deconvolution.bordered``) needs the
eigenvectors of ``G = CᵀC``, ``C = [X y]``, below ``λ_1/tol²``. ``X`` is block
lower-triangular Toeplitz, so ``Cv`` and ``Cᵀw`` are FFT convolutions and correlations,
``O(n log n)`` per block, and ``G`` is never formed. Timed here on Chapter 5's own systems
(the linear beam's 5 % records: SL 1024 columns per mode, ML 2048; ``--synthetic``:
``benchmarks/dense_tls.py``'s), one BLAS thread, CPU seconds, against the route podbench
uses (``sytrd`` + ``stevd`` of ``XᵀX`` from correlations, the secular roots;
``gram_eigh`` + ``bordered_tls``):

* ``eigsh``: ARPACK's implicitly restarted Lanczos for the smallest eigenvalues of the FFT
  operator (``which="SA"``), ``k`` = the discarded count plus a guard;
* ``lobpcg``: SciPy's LOBPCG on the same operator (at most 500 iterations), preconditioned
  by the block-circulant approximation of ``XᵀX`` (per frequency the ``k × k`` matrix
  ``Σ_j û_j^H û_j`` of the forces' length-``n`` DFTs, shifted by 1000 times the cut
  ``λ_1/tol²`` — the best of 0.1…10⁴ times on the SL system —, inverted).

Where the discarded set is more than a quarter of the columns (the SNR rule's tol on ML),
no iterative method is tried: ``d`` vectors orthogonalized cost ``O(N d²)`` per step, a
dense eigendecomposition's order.

Each is given the discarded count ``d`` of the dense answer (a solver would need a guard
block and a count) and a budget of operator products; printed: products, CPU seconds,
the largest eigenvalue residual of the ``d`` wanted, and ``h``'s relative difference from
the dense route's. Also printed: ``G``'s spectrum around the cut from the dense route, which
bounds any Krylov method (the gap at the cut against ``λ_1``)::

    python benchmarks/tls_krylov.py                       # tol = 1000 and the SNR rule's
    python benchmarks/tls_krylov.py --budget 20000 --tol 1000
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

import warnings  # noqa: E402

import numpy as np  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402


class BorderedToeplitz:
    """``G = [X y]ᵀ[X y]`` as products by FFT: ``X`` block ``(j, i)`` = ``T(F[:, j, i])``
    (``n × n`` lower-triangular Toeplitz), ``n_cases`` row blocks, ``k`` column blocks."""

    def __init__(self, F: np.ndarray, y: np.ndarray):
        self.n, self.n_cases, self.k = F.shape
        self.L = 2 * self.n
        self.Fh = np.fft.rfft(F, self.L, axis=0)  # (L/2+1, n_cases, k)
        self.y = y
        self.N = self.k * self.n + 1
        self.products = 0

    def _x(self, v):  # X v, v (k n, m)
        V = np.fft.rfft(v.reshape(self.k, self.n, -1), self.L, axis=1)  # (k, f, m)
        W = np.einsum("fji,ifm->jfm", self.Fh, V)
        return np.fft.irfft(W, self.L, axis=1)[:, :self.n].reshape(self.n_cases * self.n, -1)

    def _xt(self, w):  # Xᵀ w, w (n_cases n, m)
        W = np.fft.rfft(w.reshape(self.n_cases, self.n, -1), self.L, axis=1)
        V = np.einsum("fji,jfm->ifm", self.Fh.conj(), W)
        return np.fft.irfft(V, self.L, axis=1)[:, :self.n].reshape(self.k * self.n, -1)

    def matmat(self, Z):
        Z = np.asarray(Z, dtype=float).reshape(self.N, -1)
        self.products += Z.shape[1]
        r = self._x(Z[:-1]) + self.y[:, None] * Z[-1][None, :]
        return np.vstack([self._xt(r), (self.y @ r)[None, :]])

    def operator(self):
        return spla.LinearOperator((self.N, self.N), matvec=self.matmat, matmat=self.matmat,
                                   dtype=float)

    def preconditioner(self, shift: float):
        """``(K + shift)⁻¹`` per frequency (``K`` the circulant approximation of ``XᵀX``), and
        ``1/(yᵀy + shift)`` on the last coordinate."""
        n, k = self.n, self.k
        F = np.fft.irfft(self.Fh, self.L, axis=0)[:n]  # the force samples again
        Fn = np.fft.fft(F, n, axis=0)  # (n, n_cases, k), the length-n circulant's symbol
        K = np.einsum("fji,fjl->fil", Fn.conj(), Fn) + shift * np.eye(k)[None]
        Kinv = np.linalg.inv(K)
        cy = 1.0 / (float(self.y @ self.y) + shift)

        def apply(Z):
            Z = np.asarray(Z, dtype=float).reshape(self.N, -1)
            V = np.fft.fft(Z[:-1].reshape(k, n, -1), axis=1)
            V = np.einsum("fil,lfm->ifm", Kinv, V)
            out = np.fft.ifft(V, axis=1).real.reshape(k * n, -1)
            return np.vstack([out, cy * Z[-1][None, :]])

        return spla.LinearOperator((self.N, self.N), matvec=apply, matmat=apply, dtype=float)


def _h(vecs: np.ndarray) -> np.ndarray:
    """``tlsdeconv``'s ``h`` from the discarded eigenvectors (columns) of ``G``."""
    s = vecs[-1]
    return -(vecs[:-1] @ s) / float(s @ s)


def _rel(a, b) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _dense(system, tol):
    """The route podbench uses: ``(h, d, λ_1, eigenvalues of G around the cut, CPU s)``."""
    from podbench.sysid.deconvolution import bordered

    G, y = system.G, system._B2[:, 0]
    bordered._CACHE.clear()
    t0 = time.process_time()
    mu, Q = bordered.gram_eigh(G)
    b, c = bordered.border(G, y), float(y @ y)
    h, r, _ = bordered.bordered_tls(mu, Q, b, c, tol, G.shape[0] * G.shape[1])
    cpu = time.process_time() - t0
    beta, sec = bordered._secular_of(mu, Q, b, c)
    lam1 = bordered._largest(sec)
    M = mu.size
    d = M + 1 - r
    p, delta = bordered._first_roots(sec, 0, min(d + 3, sec["poles"].size))
    roots = np.sort(np.concatenate([sec["poles"][p] + delta, sec["silent"]]))
    return h, d, lam1, roots[max(d - 2, 0):d + 2], cpu


def _chebyshev(op, near, d, lam1) -> str:
    """The spectrum's bound on any polynomial (Krylov) route: separating the discarded
    eigenvalues (``<= a``, the largest below the cut) from the kept (``>= b``) to 1e-8 needs
    a polynomial of degree ``m >= arccosh(1e8)/arccosh(1 + 2(b − a)/(λ_1 − b))`` (the scaled
    Chebyshev polynomial of ``[b, λ_1]`` is the smallest there), ``m`` products per vector;
    and the time of one product here."""
    a, b = float(near[min(1, d - 1)]), float(near[min(2, len(near) - 1)])
    m = np.arccosh(1e8) / np.arccosh(1.0 + 2.0 * (b - a) / (lam1 - b))
    z = np.random.default_rng(1).standard_normal((op.N, 1))
    t0 = time.process_time()
    for _ in range(50):
        op.matmat(z)
    t = (time.process_time() - t0) / 50
    return (f"polynomial degree >= {m:,.0f} per vector for 1e-8 at the cut; one product "
            f"{1e3 * t:.2f} ms, so >= {m * t:.1f} s for one vector")


def _residual(op, lam, vecs) -> float:
    R = op.matmat(vecs) - vecs * lam[None, :]
    return float(np.max(np.linalg.norm(R, axis=0)))


def chapter5_systems(level: str = "5pct") -> list:
    """The appendix TLS's systems of Chapter 5's linear beam (``scenarios/chapter5/data``,
    noise ``level``): SL on the 8-in record (one per mode, 1024 columns) and ML on the 8-
    and 12-in records (2048), as ``SingleLoad``/``MultipleLoad(n_modes=2,
    solver="tls-appendix")`` hand them to the solver."""
    from podbench.methods import MultipleLoad, SingleLoad

    from podbench.core.recordfiles import read_record
    from podbench.sysid.deconvolution import dense

    root = ROOT / "scenarios" / "chapter5" / "data" / "linear_beam" / f"noise_{level}"
    recs = [read_record(root / f"{c}.npz") for c in ("load8", "load12")]
    caught = []
    solve = dense.AppendixTLS._solve_dense

    def spy(self, system):
        caught.append(system)
        return solve(self, system)

    dense.AppendixTLS._solve_dense = spy
    try:
        SingleLoad(n_modes=2, solver="tls-appendix").fit(recs[:1])
        MultipleLoad(n_modes=2, solver="tls-appendix").fit(recs)
    finally:
        dense.AppendixTLS._solve_dense = solve
    return [("SL mode 1", caught[0]), ("SL mode 2", caught[1]), ("ML", caught[2])]


def synthetic_systems(noise: float) -> list:
    """``benchmarks/dense_tls.py``'s systems: SL 1024 and ML 2048 columns."""
    from benchmarks.dense_tls import DT, _system
    from podbench.sysid.deconvolution import ConvolutionSystem

    out = []
    for label, k, cases in (("SL 1024", 1, 1), ("ML 2048", 2, 2)):
        Q, B = _system(k, cases, noise)
        out.append((f"{label} {noise:.0%}", ConvolutionSystem(Q, B[:, 0] if k == 1 else B, DT)))
    return out


def run(label, system, tol, budget, guard=8):
    if tol == 0:  # the SNR rule
        from podbench.sysid.deconvolution.dense import snr_tol

        tol = snr_tol(system, 0)
    h_d, d, lam1, near, t_d = _dense(system, tol)
    thr = lam1 / tol ** 2
    lines = [f"{label} tol {tol:.4g}: dense route {t_d:.2f} s, d = {d} discarded, "
             f"cut {thr:.3e} = λ1·{thr / lam1:.1e}; G's eigenvalues around the cut / λ1: "
             + ", ".join(f"{v / lam1:.3e}" for v in near)]
    op = BorderedToeplitz(system.G, system._B2[:, 0])
    lines.append("  " + _chebyshev(op, near, d, lam1))
    want = d + guard
    if want > op.N // 4:
        return lines + [f"  d + guard = {want} of {op.N} columns: not tried (a dense problem)"]
    rng = np.random.default_rng(0)
    # eigsh, smallest algebraic
    op.products = 0
    t0 = time.process_time()
    try:
        lam, vecs = spla.eigsh(op.operator(), k=want, which="SA", tol=0.0,
                               maxiter=max(1, budget // (2 * want + 1)),
                               ncv=min(op.N - 1, 2 * want + 1))
        status = "converged"
    except spla.ArpackNoConvergence as err:
        lam, vecs = err.eigenvalues, err.eigenvectors
        status = f"not converged ({lam.size} of {want} pairs)"
    t = time.process_time() - t0
    lines.append(_report("eigsh", op, lam, vecs, d, h_d, t, status))
    # LOBPCG with the circulant preconditioner
    op.products = 0
    t0 = time.process_time()
    X0 = rng.standard_normal((op.N, want))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "not reaching the requested tolerance": reported
        lam, vecs, hist = spla.lobpcg(op.operator(), X0, M=op.preconditioner(1e3 * thr),
                                      largest=False,
                                      tol=1e-12 * lam1, maxiter=500,
                                      retResidualNormsHistory=True)
    t = time.process_time() - t0
    lines.append(_report("lobpcg", op, lam, vecs, d, h_d, t, f"{len(hist)} iterations"))
    return lines


def _report(name, op, lam, vecs, d, h_d, t, status) -> str:
    if lam is None or len(lam) < d:
        return f"  {name:<7} {op.products:>7} products {t:>7.2f} s  {status}: fewer than d pairs"
    order = np.argsort(lam)[:d]
    lam, vecs = lam[order], vecs[:, order]
    products = op.products
    res = _residual(op, lam, vecs)
    op.products = products
    return (f"  {name:<7} {products:>7} products {t:>7.2f} s  {status}; residual "
            f"{res:.1e}, h vs dense {_rel(_h(vecs), h_d):.1e}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--noise", type=float, default=0.05, help="the synthetic systems' noise")
    ap.add_argument("--tol", type=float, action="append",
                    help="default 1000 and the SNR rule's (0 = the SNR rule)")
    ap.add_argument("--synthetic", action="store_true",
                    help="benchmarks/dense_tls.py's systems instead of Chapter 5's 5 %% records")
    ap.add_argument("--budget", type=int, default=6000, help="eigsh's operator products")
    ap.add_argument("--systems", default="SL,ML")
    args = ap.parse_args(argv)
    systems = synthetic_systems(args.noise) if args.synthetic else chapter5_systems()
    for tol in args.tol or [1000.0, 0.0]:
        for label, system in systems:
            if label.split()[0] in args.systems.split(","):
                print("\n".join(run(label, system, tol, args.budget)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
