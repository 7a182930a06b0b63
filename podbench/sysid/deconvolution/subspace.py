"""Poles by subspace identification from the input–output records: ``"subspace"``.

The kernel of Eq. 3.39 (ML) / Eq. 3.33 (SL) is the impulse response of a linear
time-invariant system with the modal forces ``u[s] = G[s, j]`` (``k`` inputs, lbf) in and the
scaled POC histories ``y[s] = Y[s, j]`` (``r`` outputs, in) out,

    ``x[s+1] = A x[s] + B u[s]``,  ``y[s]/Δt = C x[s] + D u[s]``,                    (1)

so ``X[0] = Dᵀ`` and ``X[p] = (C A^{p−1} B)ᵀ`` (Eq. 1 of :mod:`.realization`). Instead of
realizing a pilot FIR kernel (``"realization"``, ERA of a cgls kernel on a short window),
this solver takes the poles from the records themselves by the MOESP family of subspace
methods (Verhaegen & Dewilde 1992, *Int. J. Control* 56:1187; Verhaegen 1994, *Automatica*
30:61; Van Overschee & De Moor 1996, *Subspace Identification for Linear Systems*, ch. 4–6):

1. **data matrix**: with horizon ``i`` and, per load case, columns ``t = 0 … n−i`` (the
   records start at rest, so the ``i`` samples before ``t = 0`` are exactly zero), the block
   Hankel matrices of past and future inputs and outputs

       ``U_p = [u[t−i] … u[t−1]]``, ``U_f = [u[t] … u[t+i−1]]``, likewise ``Y_p``, ``Y_f``,  (2)

   stacked column-wise over the load cases, and the instruments ``Z = [U_p; Y_p]`` (past
   inputs and outputs, "PO-MOESP"; ``instruments="pi"``: past inputs only, "PI-MOESP");
2. **LQ factor** of ``[U_f; Z; Y_f] = L Q`` (lower block-triangular ``L``), computed as the
   ``R`` of a QR of the transposed data matrix, accumulated over column chunks (a tall-skinny
   QR: ``R ← qr([R; chunk])``), so memory stays ``O(chunk · 2i(k+r))`` and the cost is
   ``O(n · n_cases · (2i(k+r))²)``;
3. **extended observability matrix**: the SVD ``L₃₂ = U S Vᵀ`` of the block of ``L`` that
   couples the instruments to the future outputs once the future inputs are projected out
   (formed by projections on the numerical ranges of ``U_f`` and ``Z``, singular values
   above ``rank_tol`` of the largest, so that a pulse load's rank-deficient ``U_f`` leaves
   no round-off direction in it: :func:`_l32`);
   ``Γ_i = U[:, :N]`` spans ``[C; CA; …; CA^{i−1}]`` (Verhaegen 1994, Theorem 3). The
   instruments are past samples, uncorrelated with white noise on the future outputs (PI and
   PO) and on the future inputs (Chou & Verhaegen 1997, *Automatica* 33:1857, the
   errors-in-variables case), so ``Γ_i`` is consistent under per-channel measurement noise on
   W and F;
4. **poles**: ``A = Γ_↑⁺ Γ_↓`` (shift invariance: ``Γ_↑`` drops the last block row, ``Γ_↓``
   the first); its eigenvalues outside the unit circle are pulled onto it (the beams are
   undamped; a growing mode is noise);
5. **residues** on the whole record with the poles fixed (step 3 of :mod:`.realization`,
   Eq. 2 there): a linear least-squares fit on every sample of every load case.

**Horizon**: ``i`` block rows span ``i·Δt`` of the response, and step 4 reads each pole
from how the observability rows turn over that span. On the Chapter 5 records (10 kHz
sampling, a 10-Hz fundamental) ``i = ⌈max_order/r⌉ + 2 = 42`` spans 1/24 of the slowest
period and, in SL's single-input/single-output systems, leaves that pole undetermined under
1 % noise (measured, linear beam SL on load8: hold-out residual 0.96 / 0.59 / 0.94 at
1 / 2 / 5 %, against 0.009 / 0.018 / 0.051 at ``i = 128``; realization 0.016 / 0.029 /
0.040). On the Chapter 4 ML set the opposite holds (beam_forced_noise, LTI beam, 5 %:
median 0.138 at ``i = 12``, 0.161 at ``i = 31``). No single horizon serves both, so by
default the horizon is chosen from the data like the order: the two candidates are the
shortest horizon that admits ``max_order`` (``⌈max_order/r⌉ + 2``) and the longest the
caps allow (``2i(k+r) ≤`` :data:`MAX_DATA_ROWS`, ``i ≤ n/8``); the order rule below runs at
each, and the horizon whose chosen order predicts the held-out samples best is kept (ties:
the longer). ``horizon=`` fixes it.

**Order**: only orders ``N`` whose singular value ``S_N`` exceeds the **rank floor**
``rank_tol · S_1`` (default :data:`RANK_TOL` = 1e-8 ≈ √eps) are candidates: an order whose
subspace direction sits at round-off is not determined by the data, and its poles (and any
rule that compares them) would depend on the CPU. Among the candidates (even orders
up to ``max_order``) the hold-out rule of :mod:`.realization` chooses, on the first
``n_rule`` samples of every record (the whole record unless it is long): poles (steps 1–4)
and residues (step 5) from the first ``n_fit = n_rule − ⌈holdout·n_rule⌉`` samples, the
error of the model's prediction of samples ``n_fit … n_rule−1`` from the measured forces,
and the smallest order within one standard error of the best (``rule="1se"``; ``"min"``:
the best). Held-out errors that agree to a relative ``1e-6`` count as equal, so round-off
cannot reorder them. The chosen order is then identified from the whole records.

**Determined by the data**: with ``L₃₂`` read from the blocks of the LQ factor, as MOESP
writes it, a pulse load's future inputs are rank deficient, the LQ factor's rows for the
dependent ones are round-off, and their directions carry future-output content into
``L₃₂``: the chosen order and the kernel then move under a 1e-12 perturbation of the
records and between CPUs (docs/noise.md). The projected form (:func:`_l32`) reads
``L₃₂`` on the instruments' numerical range only and is determined by the data.
"""

from __future__ import annotations

import math

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)
import scipy.linalg

from podbench.errors import InputError, RecordTooShortError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution.realization import (
    conj_pairs,
    holdout_choice,
    n_basis,
    pole_basis,
    pole_realization,
)
from podbench.sysid.deconvolution.system import ConvolutionSystem
from podbench.sysid.params import COUNT, FRACTION, Interval, Options

__all__ = ["Subspace", "subspace_factor", "subspace_poles", "RANK_TOL", "MAX_DATA_ROWS"]

RANK_TOL = 1e-8
"""Default rank floor: singular values of ``L₃₂`` below ``RANK_TOL · S_1`` are round-off."""

MAX_DATA_ROWS = 512
"""Largest ``2i(k+r)`` (rows of the data matrix) by default; the horizon ``i`` is cut to it."""

_CHUNK = 4096
"""Data-matrix columns per QR update."""

_TIE = 1e-6
"""Relative difference below which two held-out errors count as equal."""


def _data_rows(u: np.ndarray, y: np.ndarray, i: int, t0: int, t1: int) -> np.ndarray:
    """Rows ``t = t0 … t1−1`` of the transposed data matrix ``[U_f; U_p; Y_p; Y_f]ᵀ`` of one
    record (``u`` ``(n, k)``, ``y`` ``(n, r)``, zero before ``t = 0``)."""
    n, k = u.shape
    r = y.shape[1]
    up = np.vstack([np.zeros((i, k)), u, np.zeros((i, k))])
    yp = np.vstack([np.zeros((i, r)), y, np.zeros((i, r))])
    t = np.arange(t0, t1)[:, None]
    fut = t + i + np.arange(i)[None, :]  # index into the padded arrays
    past = t + np.arange(i)[None, :]
    m = t1 - t0
    return np.hstack([up[fut].reshape(m, i * k), up[past].reshape(m, i * k),
                      yp[past].reshape(m, i * r), yp[fut].reshape(m, i * r)])


def subspace_factor(G, Y, horizon: int, *, instruments: str = "po") -> np.ndarray:
    """Step 2: the ``R`` factor (``= Lᵀ``) of the data matrix of Eq. 2, by a tall-skinny QR
    over chunks of columns.

    Parameters
    ----------
    G : (n, n_cases, k) ndarray
        Inputs (modal forces, lbf).
    Y : (n, n_cases, r) ndarray
        Outputs (in).
    horizon : int
        Block rows ``i`` of each Hankel matrix.
    instruments : {"po", "pi"}
        Past inputs and outputs, or past inputs only.

    Returns
    -------
    (2i(k+r), 2i(k+r)) ndarray (fewer rows if there are fewer data columns), upper
    triangular; with ``"pi"`` the ``Y_p`` block is left out (``i(2k+r)`` columns).
    """
    n, n_cases, k = G.shape
    r = Y.shape[2]
    i = int(horizon)
    cols = 2 * i * (k + r)
    keep = (np.arange(cols) if instruments == "po"
            else np.r_[0:2 * i * k, 2 * i * k + i * r:cols])
    R = np.zeros((0, keep.size))
    step = max(1, _CHUNK // n_cases)
    for t0 in range(0, n - i + 1, step):  # columns t = 0 … n−i
        t1 = min(n - i + 1, t0 + step)
        rows = [_data_rows(G[:, j], Y[:, j], i, t0, t1)[:, keep] for j in range(n_cases)]
        R = scipy.linalg.qr(np.vstack([R] + rows), mode="r", check_finite=False)[0]
        R = R[: min(R.shape[0], keep.size)]
    return R


def _range_basis(M: np.ndarray, rank_tol: float) -> np.ndarray:
    """Orthonormal basis of the range of ``M`` spanned by its singular values above
    ``rank_tol`` times the largest (none for a zero ``M``)."""
    U, s, _ = np.linalg.svd(M, full_matrices=False)
    if not s.size or not s[0] > 0:
        return U[:, :0]
    return U[:, s > rank_tol * s[0]]


def _l32(R: np.ndarray, i: int, k: int, r: int, rank_tol: float = RANK_TOL) -> np.ndarray:
    """``L₃₂``: future outputs against the instruments, future inputs projected out — up to
    an orthogonal factor on the right, which leaves its singular values and left singular
    vectors (all that steps 3–4 read) unchanged.

    The columns of ``R`` (``RᵀR = DᵀD``, ``D`` the transposed data matrix) are the data
    rows in a common basis. The future inputs' numerical range (singular values above
    ``rank_tol`` of the largest) is projected out of the instruments and future outputs,
    and the future outputs are then read on the instruments' numerical range (the same
    rule). Reading the blocks of ``L = Rᵀ`` directly, as the LQ form of MOESP does, needs
    ``U_f`` and ``Z`` of full row rank: a pulse load's future inputs are zero after the
    pulse, the rows of ``R`` for such dependent rows are round-off, and their directions,
    chosen by the CPU's round-off, carry future-output content in or out of ``L₃₂`` (measured
    in docs/noise.md: the projected form agrees between kernels to 3e-12)."""
    a = i * k
    c = i * r
    m = R.shape[1]
    RU, RZ, RY = R[:, :a], R[:, a:m - c], R[:, m - c:]
    Qu = _range_basis(RU, rank_tol)
    RZ = RZ - Qu @ (Qu.T @ RZ)
    RY = RY - Qu @ (Qu.T @ RY)
    Qz = _range_basis(RZ, rank_tol)
    return (Qz.T @ RY).T


def subspace_poles(R: np.ndarray, horizon: int, k: int, r: int, orders, *,
                   rank_tol: float = RANK_TOL):
    """Steps 3–4: the singular values of ``L₃₂`` and the poles at each order.

    Returns
    -------
    sv : ndarray
        Singular values ``S``.
    poles : dict
        ``order → poles`` (one per conjugate pair and the real ones, :func:`conj_pairs`)
        for the orders at or below the rank floor's count.
    """
    i = int(horizon)
    U, sv, _ = np.linalg.svd(_l32(R, i, k, r, rank_tol), full_matrices=False)
    n_det = int(np.sum(sv > rank_tol * sv[0])) if sv.size and sv[0] > 0 else 0
    out = {}
    for N in orders:
        if N > n_det or N > r * (i - 1):
            continue
        Gam = U[:, :N]
        A = np.linalg.lstsq(Gam[:-r], Gam[r:], rcond=None)[0]
        out[N] = conj_pairs(np.linalg.eigvals(A))
    return sv, out


def _case_regressors(g: np.ndarray, dt: float, poles: np.ndarray) -> np.ndarray:
    """Regressors of Eq. 2 of :mod:`.realization` for one load case, ``(k, 1 + N, n)``
    (first-order recursions of the forces ``g`` ``(n, k)``, time last)."""
    n, k = g.shape
    Z = np.empty((k, n_basis(poles), n))
    gt = np.ascontiguousarray(g.T)
    Z[:, 0] = dt * gt
    gc = gt.astype(complex) if np.any(poles.imag != 0) else None
    col = 1
    for lam in poles:
        if lam.imag != 0:
            z = scipy.signal.lfilter([0.0, 1.0], [1.0, -lam], gc, axis=-1)
            Z[:, col] = dt * z.real
            Z[:, col + 1] = dt * z.imag
            col += 2
        else:
            Z[:, col] = dt * scipy.signal.lfilter([0.0, 1.0], [1.0, -lam.real], gt, axis=-1)
            col += 1
    return Z


def _solve_normal(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``gram⁻¹ rhs`` with equilibrated columns; a truncated eigen-solve drops directions
    below ``1e-14`` of the largest."""
    scale = np.sqrt(np.diag(gram))
    scale = np.where(scale > 0, scale, 1.0)
    gram = gram / np.outer(scale, scale)
    rhs = rhs / scale[:, None]
    w, V = scipy.linalg.eigh(gram, check_finite=False)
    keep = w > w[-1] * 1e-14 if w.size and w[-1] > 0 else np.zeros(w.shape, bool)
    theta = V[:, keep] @ ((V[:, keep].T @ rhs) / w[keep, None])
    return theta / scale[:, None]


def fit_residues(G, Y, dt: float, poles, rows: int, *, heldout: int | None = None):
    """Least-squares residues ``(k, 1 + N, r)`` of Eq. 2 of :mod:`.realization` on samples
    ``0 … rows−1`` of every load case, by the normal equations accumulated per case.

    With ``heldout = s0`` also the squared prediction error on samples ``s0 …`` per
    (load case, output column) (the same regressors, computed once).
    """
    n, n_cases, k = G.shape
    r = Y.shape[2]
    nb = n_basis(poles)
    gram = np.zeros((k * nb, k * nb))
    rhs = np.zeros((k * nb, r))
    Zs = []
    stop = n if heldout is not None else rows
    for j in range(n_cases):
        Zj = _case_regressors(G[:stop, j], dt, poles).reshape(k * nb, stop)
        Pj = np.ascontiguousarray(Zj[:, :rows]) if rows < stop else Zj
        gram += Pj @ Pj.T
        rhs += Pj @ Y[:rows, j]
        if heldout is not None:
            Zs.append(Zj[:, heldout:])
    theta = _solve_normal(gram, rhs)
    if heldout is None:
        return theta.reshape(k, nb, r)
    err = np.concatenate([np.sum((Zj.T @ theta - Y[heldout:, j]) ** 2, axis=0)
                          for j, Zj in enumerate(Zs)])
    return theta.reshape(k, nb, r), err


class Subspace(Solver):
    """Poles by PO-/PI-MOESP subspace identification of the training records, residues
    refitted on the whole record (``"subspace"``; equations and sources in the module
    docstring).

    Parameters
    ----------
    order : int, optional
        Model order ``N``; ``None`` (default): the hold-out rule over the candidates above
        the rank floor.
    max_order : int
        Largest order tried by the rule (even orders ``2 … max_order``; default 40).
    horizon : int, optional
        Block rows ``i`` (default: chosen by the hold-out between ``⌈max_order/r⌉ + 2`` and
        the largest with ``2i(k+r) ≤`` :data:`MAX_DATA_ROWS` and ``i ≤ n/8``; see
        "Horizon" in the module docstring).
    instruments : {"po", "pi"}
        Past inputs and outputs (default, PO-MOESP) or past inputs only (PI-MOESP).
    rank_tol : float
        Rank floor relative to the largest singular value (default :data:`RANK_TOL`).
    holdout : float
        Fraction of every record's last samples held out by the order rule (default 0.25).
    rule : {"1se", "min"}
        As in :class:`~podbench.deconvolution.Realization`.
    n_rule : int, optional
        Samples (from the start of every record) on which the order rule runs (default: the
        whole record, or ``max(256, 8192 // k)`` if shorter); the chosen order's poles and
        residues are then identified from the whole record.

    Notes
    -----
    Diagnostics (``info``): ``order``, ``order_rule``, ``holdout_residual``,
    ``holdout_best_order``, ``candidates`` (orders above the rank floor, up to
    ``max_order``), ``horizon`` (the one used), ``horizons`` (the candidates),
    ``instruments``, ``poles``, ``max_pole``, ``rank`` = ``N``.

    The result's ``realization`` is the fitted model itself, exact
    (:func:`~podbench.sysid.deconvolution.realization.pole_realization`; order ``k·N``).
    """

    name = "subspace"
    structured = True
    _parameter_constraints = {"order": [None, COUNT], "max_order": [COUNT],
                              "horizon": [None, Interval("integer", 2)],
                              "instruments": [Options("po", "pi")], "rank_tol": [FRACTION],
                              "holdout": [FRACTION], "rule": [Options("1se", "min")],
                              "n_rule": [None, COUNT]}

    def __init__(self, *, order: int | None = None, max_order: int = 40,
                 horizon: int | None = None, instruments: str = "po",
                 rank_tol: float = RANK_TOL, holdout: float = 0.25, rule: str = "1se",
                 n_rule: int | None = None):
        self.order = order
        self.max_order = max_order
        self.horizon = horizon
        self.instruments = instruments
        self.rank_tol = rank_tol
        self.holdout = holdout
        self.rule = rule
        self.n_rule = n_rule

    def _horizons(self, n: int, k: int, r: int) -> list[int]:
        """The horizon (``horizon=``) or the default candidates: the shortest that admits
        ``max_order`` (``⌈max_order/r⌉ + 2``) and the longest the caps allow
        (``2i(k+r) ≤`` :data:`MAX_DATA_ROWS`, ``i ≤ n/8``), the hold-out choosing
        between them ("Horizon" in the module docstring)."""
        if self.horizon is not None:
            hs = [int(self.horizon)]
        else:
            longest = max(2, min(MAX_DATA_ROWS // (2 * (k + r)), n // 8))
            shortest = min(longest, max(2, -(-int(self.max_order) // r) + 2))
            hs = sorted({shortest, longest})
        if n < 2 * hs[0]:
            raise RecordTooShortError(f"solver 'subspace': a record of {n} samples is too "
                                      f"short for horizon {hs[0]} (need at least "
                                      f"{2 * hs[0]})", n, 2 * hs[0])
        return [i for i in hs if n >= 2 * i]

    def _rule(self, G, Y, Yt, dt, i, nr, k, r):
        """The hold-out order rule at horizon ``i`` on the first ``nr`` samples: returns
        ``(order, held-out relative residual of that order, best order, candidates)``."""
        n_fit = nr - max(1, math.ceil(self.holdout * nr))
        if n_fit < 2 * i:
            raise InputError(f"solver 'subspace': {nr} samples are too few for the "
                             f"hold-out order rule (holdout = {self.holdout}, horizon "
                             f"{i}); give `order` or a larger `n_rule`")
        R_fit = subspace_factor(G[:n_fit], Y[:n_fit], i, instruments=self.instruments)
        orders = list(range(2, int(self.max_order) + 1, 2))
        _, table = subspace_poles(R_fit, i, k, r, orders, rank_tol=self.rank_tol)
        candidates = sorted(table)
        if not candidates:
            return 0, None, None, candidates
        Gr, Yr = G[:nr], Yt[:nr]
        den = float(np.sum(Yr[n_fit:] ** 2)) or 1.0
        groups = []
        for N in candidates:
            _, err = fit_residues(Gr, Yr, dt, table[N], n_fit, heldout=n_fit)
            groups.append(err / den)
        sel, ib, mse = holdout_choice(np.array(groups), self.rule, rtol=_TIE, atol=1e-18)
        return candidates[sel], float(np.sqrt(mse[sel])), candidates[ib], candidates

    def _solve(self, system: ConvolutionSystem):
        G = np.asarray(system.G)
        Y = np.asarray(system.Y) / system.dt  # y/Δt: the Markov parameters of Eq. 1
        n, n_cases, k = G.shape
        r = Y.shape[2]
        horizons = self._horizons(n, k, r)
        fixed = self.order is not None
        Yt = np.asarray(system.Y)
        held = best = None
        candidates = []
        i = horizons[-1]
        if self.order is not None:
            order = int(self.order)
        else:
            # the rule runs on the first n_rule samples of every record: poles from the
            # first n_fit, residues on the first n_fit, error on the rest; with several
            # candidate horizons the one whose chosen order predicts the held-out samples
            # best is kept (ties: the longer)
            nr = self._n_rule(n, k)
            results = [(h, *self._rule(G, Y, Yt, system.dt, h, nr, k, r)) for h in horizons]
            scored = [res for res in results if res[2] is not None]
            if scored:
                top = min(res[2] for res in scored)
                pick = [res for res in scored if res[2] <= top * (1 + _TIE) + 1e-18][-1]
            else:
                pick = results[-1]
            i, order, held, best, candidates = pick
        R = subspace_factor(G, Y, i, instruments=self.instruments)
        sv, table = subspace_poles(R, i, k, r, [order] if order else [],
                                   rank_tol=self.rank_tol)
        if order and order not in table:
            n_det = int(np.sum(sv > self.rank_tol * sv[0])) if sv[0] > 0 else 0
            if fixed:
                raise InputError(f"solver 'subspace': order {order} is above the rank floor "
                                 f"of the data ({n_det} singular values above "
                                 f"rank_tol = {self.rank_tol:g}) or the horizon {i}")
            order = max(2 * (min(n_det, r * (i - 1)) // 2), 0)
            _, table = subspace_poles(R, i, k, r, [order] if order else [],
                                      rank_tol=self.rank_tol)
        poles = table.get(order, np.zeros(0, dtype=complex))
        theta = fit_residues(G, Yt, system.dt, poles, n)
        Xb = np.einsum("pb,ibr->pir", pole_basis(poles, n), theta)
        info = {"order": order, "order_rule": "fixed" if fixed else "holdout",
                "holdout_residual": held, "holdout_best_order": best,
                "candidates": ",".join(map(str, candidates)) if candidates else None,
                "horizon": i, "horizons": ",".join(map(str, horizons)),
                "instruments": self.instruments,
                "poles": int(poles.size),
                "max_pole": float(np.max(np.abs(poles))) if poles.size else 0.0,
                "rank": order}
        return system.stack(Xb), info, pole_realization(poles, theta)

    def _n_rule(self, n: int, k: int) -> int:
        m = max(256, 8192 // k) if self.n_rule is None else int(self.n_rule)
        return min(n, m)
