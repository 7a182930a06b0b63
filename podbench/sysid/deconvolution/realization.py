"""Low-order realization of the kernel: ``"realization"``.

The ML / SL kernel of Eq. 3.39 is the impulse response of a linear time-invariant system
(modal forces in, POC histories out) sampled by a one-step map, so its lags are the Markov
parameters of a finite-order state-space model,

    ``h[0] = D``,  ``h[p] = C A^{p−1} B`` (``p ≥ 1``),  ``h[p] = X[p]ᵀ``  (``r × k``),   (1)

and a noisy kernel estimate can be projected onto such a model. This solver does it in
three steps, all on the training data only:

1. **pilot**: a noise-robust kernel estimate (default Tikhonov with GCV, ``"cgls"``,
   :class:`~podbench.deconvolution.CGLS`; the empirical-Bayes ``"kernel"`` is slower) on
   the first ``n_pilot`` samples (an exact sub-system: sample ``s`` depends only on lags ``≤ s``);
2. **poles**: ERA (Juang & Pappa 1985; the Hankel SVD of
   :func:`podbench.sysid.statespace.era_realization`) on the pilot's Markov parameters,
   realized at order ``N`` (:func:`podbench.sysid.statespace.realize`); eigenvalues outside
   the unit circle are pulled onto it (``λ/|λ|``: the beams are undamped, a growing mode is
   noise);
3. **residues**: with the poles fixed the kernel is linear in its residues,

       ``X[p] = δ_{p0} R_0 + Σ_b φ_b[p] R_b``,                                       (2)

   ``φ_b[p] = Re λ_b^{p−1}`` and ``Im λ_b^{p−1}`` (one pair per complex pole, ``p ≥ 1``),
   ``R_b`` a ``k × r`` matrix (a common-denominator model of order up to ``N·min(k, r)``),
   so the residues are fitted by linear least squares on **every** sample of every load
   case, ``Y[s] ≈ Δt Σ_p G[s−p] X[p]`` — the record's noise is averaged over the whole
   record, not over the Hankel window. The regressors ``Δt Σ_p G[s−p] φ_b[p]`` are
   first-order recursions of the forces (``O(n)`` per pole).

**Order rule** (``order=None``): on the first ``n_rule`` samples (the whole record unless
it is long), the last ``holdout`` fraction is held out;
steps 1–3 run on the first part for each candidate order ``N = 2, 4, …, max_order``, the
fitted model predicts the held-out samples from the (measured) forces, and the smallest
order whose held-out error is within one standard error of the best is kept (``rule``). The full
record is then used with that order. Nothing of a prediction target is used.

The returned ``X`` (Eq. 3.42 layout) holds the model's Markov parameters at every lag, so
SL/ML predict with it as with any solver's kernel.
"""

from __future__ import annotations

import math

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)
import scipy.linalg

from podbench.errors import InputError, RecordTooShortError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution.block import BlockSubstitution
from podbench.sysid.deconvolution.dense import LeastSquares, TruncatedTLS
from podbench.sysid.deconvolution.kernel import KernelRegularized
from podbench.sysid.deconvolution.stls import STLS
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.deconvolution.tikhonov import CGLS, FFTTikhonov
from podbench.sysid.params import COUNT, FRACTION, Interval, Options
from podbench.sysid.statespace import era_realization, realize

__all__ = ["Realization", "holdout_choice", "pole_basis", "pole_regressors", "pole_realization",
           "MAX_HANKEL_ROWS", "DEFAULT_MAX_ORDER"]

MAX_HANKEL_ROWS = 600
"""Largest ``s·max(k, r)`` of the ERA Hankel matrix (``s`` block rows) by default: its SVD
then costs well under a second."""

PILOTS: dict[str, type[Solver]] = {
    "cgls": CGLS, "kernel": KernelRegularized, "block": BlockSubstitution, "ls": LeastSquares,
    "tls-dt": TruncatedTLS, "fft": FFTTikhonov, "stls": STLS}
"""The built-in solvers a pilot kernel may come from (direct or regularized kernel
estimates; not ``realization``, ``subspace`` or ``auto``, which are built on this one)."""

DEFAULT_MAX_ORDER = 40
"""Largest order tried by the order rule by default (20 complex pole pairs)."""

_DIRECT_MAX = 20_000_000
"""Regressor-matrix entries up to which the residues are fitted by an SVD-based solve of the
full matrix; beyond, by the (equilibrated) normal equations."""

_EXACT = 1e-9
"""Held-out relative residuals below this count as exact (round-off) in the order rule."""


def conj_pairs(eigs: np.ndarray) -> np.ndarray:
    """One pole per conjugate pair (``Im > 0``) and the real poles, as complex numbers;
    poles outside the unit circle pulled onto it."""
    eigs = np.asarray(eigs, dtype=complex)
    mag = np.abs(eigs)
    eigs = np.where(mag > 1.0, eigs / np.where(mag > 0, mag, 1.0), eigs)
    scale = max(float(np.max(np.abs(eigs))) if eigs.size else 1.0, 1e-300)
    tol = 1e-10 * scale
    upper = eigs[eigs.imag > tol]
    real = eigs[np.abs(eigs.imag) <= tol].real + 0j
    return np.concatenate([upper[np.argsort(-np.abs(upper), kind="stable")],
                           real[np.argsort(-np.abs(real), kind="stable")]])


def n_basis(poles: np.ndarray) -> int:
    return 1 + int(np.sum(np.where(np.abs(poles.imag) > 0, 2, 1)))


def holdout_choice(groups: np.ndarray, rule: str, *, rtol: float = 0.0, atol: float = 0.0):
    """The hold-out order rule's choice among candidates (rows of ``groups``: each
    candidate's held-out squared error per independent group — load case × column —
    relative to the held-out data).

    ``rule="1se"``: the first candidate whose total is within one standard error of the best
    total (the standard error of the best candidate's total over its groups); ``"min"``: the
    first within the best. Totals within ``best·(1 + rtol) + atol`` of the limit count as
    equal. Returns ``(chosen index, best index, totals)``.
    """
    mse = groups.sum(axis=1)
    ib = int(np.argmin(mse))
    limit = float(mse[ib])
    if rule == "1se" and groups.shape[1] > 1:
        limit += float(np.sqrt(groups.shape[1]) * np.std(groups[ib], ddof=1))
    i = int(np.flatnonzero(mse <= limit * (1 + rtol) + atol)[0])
    return i, ib, mse


def pole_basis(poles, n: int) -> np.ndarray:
    """The sequences ``φ_b[p]`` of Eq. 2 (``p = 0 … n−1``): ``δ[p]``, then for each pole
    ``λ`` (one per conjugate pair) ``Re λ^{p−1}`` and ``Im λ^{p−1}`` (a real pole: one
    sequence), zero at ``p = 0``.

    Returns
    -------
    (n, 1 + N) ndarray
    """
    poles = np.asarray(poles, dtype=complex)
    out = np.zeros((n, n_basis(poles)))
    out[0, 0] = 1.0
    p = np.arange(1, n)
    col = 1
    for lam in poles:
        seq = lam ** (p - 1)
        out[1:, col] = seq.real
        col += 1
        if lam.imag != 0:
            out[1:, col] = seq.imag
            col += 1
    return out


def pole_realization(poles, theta: np.ndarray) -> tuple:
    """The state-space model ``(A, B, C, D)`` whose Markov parameters are Eq. 2's kernel:
    ``D = R_0ᵀ`` and ``C A^{p−1} B = Σ_b φ_b[p] R_bᵀ`` (``p ≥ 1``), i.e. ``X[p]ᵀ`` of Eq. 1
    (``r × k``, the solution's units, in/(lbf·s)).

    Exact, not a fit: a complex pole ``λ = a + ib`` (one per conjugate pair) is the real
    2-state block ``[[a, −b], [b, a]]`` per input, whose state ``M^{p−1} e₁`` is
    ``(Re λ^{p−1}, Im λ^{p−1})`` (the two sequences of :func:`pole_basis`), read out by the
    two residues; a real pole is a 1-state block. Order ``k·N`` (``N`` the model order,
    ``k`` inputs; the common-denominator form of Eq. 2). No rank decision: the model is the
    one the residues were fitted to, whatever its Hankel singular values.

    Parameters
    ----------
    poles : (N',) complex array_like
        As :func:`pole_basis`.
    theta : (k, 1 + N, r) ndarray
        The residues ``R_b`` (row ``b`` of every input).
    """
    poles = np.asarray(poles, dtype=complex)
    theta = np.asarray(theta, dtype=float)
    k, nb, r = theta.shape
    if nb != n_basis(poles):
        raise InputError(f"pole_realization: {nb} residue rows for {n_basis(poles)} basis "
                         "sequences")
    blocks, cols = [], []
    col = 1
    for lam in poles:
        w = 2 if lam.imag != 0 else 1
        M = (np.array([[lam.real, -lam.imag], [lam.imag, lam.real]]) if w == 2
             else np.array([[lam.real]]))
        for i in range(k):
            blocks.append(M)
            cols.append((i, theta[i, col:col + w].T))  # (r, w)
        col += w
    nx = sum(b.shape[0] for b in blocks)
    A = scipy.linalg.block_diag(*blocks) if blocks else np.zeros((0, 0))
    B, C = np.zeros((nx, k)), np.zeros((r, nx))
    j = 0
    for blk, (i, R) in zip(blocks, cols, strict=True):
        B[j, i] = 1.0
        C[:, j:j + blk.shape[0]] = R
        j += blk.shape[0]
    return A, B, C, theta[:, 0, :].T.copy()


def pole_regressors(G: np.ndarray, dt: float, poles) -> np.ndarray:
    """``Z[s, j, i, b] = Δt Σ_p G[s−p, j, i] φ_b[p]`` (Eq. 2's regressors) by first-order
    recursions (``φ_b`` of :func:`pole_basis`).

    Parameters
    ----------
    G : (n, n_cases, k) ndarray
        Modal forces (lbf).
    dt : float
        Δt (s).
    poles : (N',) complex array_like
        One pole per conjugate pair, and the real poles.

    Returns
    -------
    (n, n_cases, k, 1 + N) ndarray
    """
    poles = np.asarray(poles, dtype=complex)
    n, n_cases, k = G.shape
    Z = np.empty((n, n_cases, k, n_basis(poles)))
    Z[..., 0] = dt * G
    col = 1
    for lam in poles:
        if lam.imag != 0:
            z = scipy.signal.lfilter([0.0, 1.0], [1.0, -lam], G.astype(complex), axis=0)
            Z[..., col] = dt * z.real
            Z[..., col + 1] = dt * z.imag
            col += 2
        else:
            Z[..., col] = dt * scipy.signal.lfilter([0.0, 1.0], [1.0, -lam.real], G, axis=0)
            col += 1
    return Z


def _fit_residues(Z: np.ndarray, Y: np.ndarray, rows: int) -> np.ndarray:
    """Least-squares residues ``(k, 1 + N, r)`` of Eq. 2 on samples ``0 … rows−1``
    (columns equilibrated; an SVD-based solve up to :data:`_DIRECT_MAX` matrix entries, the
    normal equations accumulated per load case beyond, solved by a truncated
    eigen-decomposition)."""
    _, n_cases, k, nb = Z.shape
    r = Y.shape[2]
    if rows * n_cases * k * nb <= _DIRECT_MAX:
        Phi = Z[:rows].reshape(rows * n_cases, k * nb)
        Yr = Y[:rows].reshape(rows * n_cases, r)
        scale = np.linalg.norm(Phi, axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        theta = scipy.linalg.lstsq(Phi / scale, Yr, lapack_driver="gelsd",
                                   check_finite=False)[0] / scale[:, None]
        return theta.reshape(k, nb, r)
    gram = np.zeros((k * nb, k * nb))
    rhs = np.zeros((k * nb, r))
    for j in range(n_cases):
        Pj = Z[:rows, j].reshape(rows, k * nb)
        gram += Pj.T @ Pj
        rhs += Pj.T @ Y[:rows, j]
    scale = np.sqrt(np.diag(gram))
    scale = np.where(scale > 0, scale, 1.0)
    gram = gram / np.outer(scale, scale)
    rhs = rhs / scale[:, None]
    w, V = scipy.linalg.eigh(gram, check_finite=False)
    keep = w > w[-1] * 1e-14
    theta = V[:, keep] @ ((V[:, keep].T @ rhs) / w[keep, None])
    return (theta / scale[:, None]).reshape(k, nb, r)


def _predict(Z: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``Y`` of the model: ``(n, n_cases, r)``."""
    return np.einsum("sjib,ibr->sjr", Z, theta, optimize=True)


class Realization(Solver):
    """Low-order state-space realization of a robust pilot kernel, residues refitted on the
    whole record (``"realization"``; see the module docstring for the three steps and the
    order rule).

    Parameters
    ----------
    order : int, optional
        Model order ``N`` (state dimension of the ERA realization whose poles are kept);
        ``None`` (default): chosen by the hold-out rule.
    max_order : int
        Largest order tried by the rule (even orders ``2 … max_order``; default
        :data:`DEFAULT_MAX_ORDER`).
    holdout : float
        Fraction of the record's last samples held out by the rule (default 0.25).
    rule : {"1se", "min"}
        ``"1se"`` (default): the smallest order whose held-out squared error is within one
        standard error of the best (the one-standard-error rule of cross-validation, Hastie,
        Tibshirani & Friedman, *Elements of Statistical Learning*, §7.10; the error is a sum
        over the independent (load case, POC column) groups, its standard error
        ``√g·std`` over the ``g`` groups); ``"min"``: the order of the smallest held-out
        error.
    pilot : str
        Built-in solver of the pilot kernel (default ``"cgls"``; ``"kernel"``, ``"block"``,
        ``"ls"``, … — ``"block"`` on exact data recovers a low-order system exactly).
    n_pilot : int, optional
        Samples of the pilot's sub-system (default: the whole record, or
        ``max(64, 4096 // k)`` if shorter).
    n_rule : int, optional
        Samples (from the start) on which the order rule runs (default: the whole record,
        or ``max(256, 8192 // k)`` if shorter); the chosen order's residues are then fitted
        on the whole record.
    blocks : int, optional
        Block rows ``s`` of the ERA Hankel matrix (default: as many as the pilot's lags
        allow, ``s ≤ (n_pilot − 1)/2``, with ``s·max(k, r) ≤`` :data:`MAX_HANKEL_ROWS`).

    Notes
    -----
    Diagnostics (``info``): ``order`` (the ``N`` used), ``order_rule`` (``"holdout"`` or
    ``"fixed"``), ``holdout_residual`` (relative, at the chosen order; None if fixed),
    ``holdout_best_order`` (the order of the smallest held-out residual), ``poles``
    (distinct poles kept), ``max_pole`` (largest ``|λ|``), ``pilot``, ``n_pilot``,
    ``n_rule``, ``blocks``, ``rank`` = ``N``.

    The result's ``realization`` is the fitted model itself, exact
    (:func:`~podbench.sysid.deconvolution.realization.pole_realization`; order up to ``k·N``).
    """

    name = "realization"
    structured = True
    _parameter_constraints = {"order": [None, COUNT], "max_order": [COUNT],
                              "holdout": [FRACTION], "rule": [Options("1se", "min")],
                              "pilot": [Options(*PILOTS)],
                              "n_pilot": [None, Interval("integer", 5)],
                              "n_rule": [None, COUNT], "blocks": [None, COUNT]}

    def __init__(self, *, order: int | None = None, max_order: int = DEFAULT_MAX_ORDER,
                 holdout: float = 0.25, rule: str = "1se", pilot: str = "cgls",
                 n_pilot: int | None = None, n_rule: int | None = None,
                 blocks: int | None = None):
        self.order = order
        self.max_order = max_order
        self.holdout = holdout
        self.rule = rule
        self.pilot = pilot
        self.n_pilot = n_pilot
        self.n_rule = n_rule
        self.blocks = blocks

    # ------------------------------------------------------------------ parameters
    def _pilot_solver(self) -> Solver:
        return PILOTS[self.pilot]()

    def determined(self):
        """The realization is built on the pilot kernel: its pilot solver's digits."""
        return self._pilot_solver().determined()

    # ------------------------------------------------------------------ steps
    def _n_pilot(self, n: int, k: int) -> int:
        m = max(64, 4096 // k) if self.n_pilot is None else int(self.n_pilot)
        return min(n, m)

    def _hankel(self, system: ConvolutionSystem, n: int):
        """Steps 1–2 on the first ``n`` samples: the ERA factors and ``h[0]``."""
        k, r = system.k, system.n_rhs
        m = self._n_pilot(n, k)
        sub = _sub_system(system, m)
        Xp = sub.blocks(self._pilot_solver().solve(sub).X)  # (m, k, r)
        h = Xp.transpose(0, 2, 1)  # (m, r, k): h[p] = X[p]ᵀ
        s_max = (m - 1) // 2
        s = (min(s_max, max(1, MAX_HANKEL_ROWS // max(k, r))) if self.blocks is None
             else min(s_max, int(self.blocks)))
        if s < 1:
            raise InputError(f"solver 'realization': {m} pilot samples are too few for a "
                             "Hankel matrix (need at least 3)")
        P, sv, Qt, H1 = era_realization(h[: 2 * s + 1], s)
        return (P, sv, Qt, H1, h[0]), m, s

    @staticmethod
    def _poles(factors, order: int) -> np.ndarray:
        P, sv, Qt, H1, D = factors
        N = min(order, int(np.sum(sv > sv[0] * 1e-14)) if sv.size and sv[0] > 0 else 0)
        if N == 0:
            return np.zeros(0, dtype=complex)
        A = realize(P, sv, Qt, H1, D, N)[0]
        return conj_pairs(np.linalg.eigvals(A))

    def _n_rule(self, n: int, k: int) -> int:
        m = max(256, 8192 // k) if self.n_rule is None else int(self.n_rule)
        return min(n, m)

    def _choose_order(self, system: ConvolutionSystem):
        system = _sub_system(system, self._n_rule(system.n, system.k))
        n = system.n
        n_fit = n - max(1, math.ceil(self.holdout * n))
        if n_fit < 5:
            need = math.ceil(5 / (1 - self.holdout)) + 1
            raise RecordTooShortError(f"solver 'realization': a record of {n} samples is too "
                                      f"short for the hold-out order rule (holdout = "
                                      f"{self.holdout}; need about {need}); give `order`",
                                      n, need)
        factors, _, _ = self._hankel(system, n_fit)
        Yv = np.asarray(system.Y[n_fit:])
        den = float(np.sum(Yv**2))
        den = den if den > 0 else 1.0
        orders = list(range(2, int(self.max_order) + 1, 2)) or [int(self.max_order)]
        groups = []  # held-out squared error per (load case, column), relative to ‖Y_v‖²
        for N in orders:
            poles = self._poles(factors, N)
            Z = pole_regressors(np.asarray(system.G), system.dt, poles)
            theta = _fit_residues(Z, np.asarray(system.Y), n_fit)
            groups.append(np.sum((_predict(Z[n_fit:], theta) - Yv) ** 2, axis=0).ravel() / den)
        i, ib, mse = holdout_choice(np.array(groups), self.rule, atol=_EXACT**2)
        return orders[i], float(np.sqrt(mse[i])), orders[ib]

    # ------------------------------------------------------------------ solve
    def _solve(self, system: ConvolutionSystem):
        n = system.n
        if self.order is None:
            order, held, best_order = self._choose_order(system)
            rule = "holdout"
        else:
            order, held, best_order, rule = int(self.order), None, None, "fixed"
        factors, m, s = self._hankel(system, n)
        poles = self._poles(factors, order)
        G = np.asarray(system.G)
        Z = pole_regressors(G, system.dt, poles)
        theta = _fit_residues(Z, np.asarray(system.Y), n)
        Xb = np.einsum("pb,ibr->pir", pole_basis(poles, n), theta)  # (n, k, r)
        info = {"order": order, "order_rule": rule, "holdout_residual": held,
                "holdout_best_order": best_order, "poles": int(poles.size),
                "max_pole": float(np.max(np.abs(poles))) if poles.size else 0.0,
                "pilot": self.pilot, "n_pilot": m,
                "n_rule": self._n_rule(n, system.k) if rule == "holdout" else None,
                "blocks": s, "rank": order}
        return system.stack(Xb), info, pole_realization(poles, theta)


def _sub_system(system: ConvolutionSystem, m: int) -> ConvolutionSystem:
    """The exact sub-system of the first ``m`` samples of every load case."""
    if m == system.n:
        return system
    return ConvolutionSystem([q[:, :m] for q in system.Q_list],
                             system.Y[:m].transpose(1, 0, 2).reshape(-1, system.n_rhs),
                             system.dt)
