"""ML's kernel in a basis of decaying modes whose poles come from the training records.

A lightly damped structure rings for ``1/(ζω)``: a FIR kernel must hold several of these
(tens of seconds, thousands of columns) and the records must hold twice as many lags. The
kernel of a linear structure is a sum of decaying modes,
``H[p] = Σ_j R_j λ_j^(p−1)`` for ``p ≥ 1`` (and ``H[0] = D``): with its poles ``λ_j`` known,
the residues are linear in the data and few (``n_in`` per real pole, ``2·n_in`` per complex
pair, per POC), and the kernel has every lag. Here the poles are those of an ERA
realization (:func:`podbench.sysid.statespace.era_realization`) of the FIR kernel that
ML's own lag rule fits first (a *pilot*: ERA's Hankel matrix reads only its first lags), the
stable ones (``|λ| < 1``), and the residues are fitted by least squares over the whole
records: each input is filtered by each pole, ``x[s+1] = λ x[s] + u[s]`` (real and
imaginary parts of a complex pole as two regressors, the real block form of the pair),
and the POC histories ``v = Uᵀ y`` are regressed on these states and, with direct
feedthrough, on ``u`` itself. The realization order is the lowest whose
leave-one-record-out error (poles and residues fitted without the record left out) is
within :data:`~podbench.sysid.methods.inputs.LAG_GAIN` of the best over the even orders up to
:data:`MAX_POLE_ORDER`. The basis is the orthonormal-basis-function idea of system
identification (Heuberger, Van den Hof & Wahlberg 2005) with the poles from the data; it is
beyond the dissertation, a named variant of ML on measured inputs (``kernel="poles"``).

The fitted model is a state space in the POC coordinates: ``A`` block diagonal (one block per
pole and input), ``B`` selecting each input's states, ``C`` the residues, ``D`` the lag-0
kernel (units: ``C`` in (output unit)/(input unit), ``D`` likewise, per sample).
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from podbench.errors import InputError
from podbench.sysid.deconvolution.lagged import solve_ls
from podbench.sysid.statespace import era_realization, realize

__all__ = ["MAX_POLE_ORDER", "pilot_factors", "pole_blocks", "fit_pole_basis",
           "pole_states"]

MAX_POLE_ORDER = 40
"""Largest realization order whose poles the basis tries (20 complex pairs)."""

_MAX_HANKEL_ROWS = 600
"""Rows of the pilot's Hankel matrix (``s·max(k, n_in)``), as the realization solvers'."""


def pilot_factors(theta: np.ndarray, n_in: int, first: int):
    """ERA's Hankel factors of a FIR kernel ``θ`` (lag-major, from lag ``first``):
    ``(P, sv, Qt, H1, D)``, ``D = h[0]`` (zero without lag 0)."""
    L = theta.shape[0] // n_in
    k = theta.shape[1]
    h = np.zeros((L + first, k, n_in))
    h[first:] = theta.reshape(L, n_in, k).transpose(0, 2, 1)
    s = min((h.shape[0] - 1) // 2, _MAX_HANKEL_ROWS // max(k, n_in))
    if s < 1:
        raise InputError(f"Parameter `kernel`: 'poles' needs a pilot kernel of at least 3 "
                         f"lags, got {h.shape[0]}")
    P, sv, Qt, H1 = era_realization(h[: 2 * s + 1], s)
    return P, sv, Qt, H1, h[0]


def pole_blocks(factors, order: int, n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the basis from the stable poles of the order-``order`` realization:
    per input, a 1 × 1 block ``λ`` for a real pole and ``[[a, −b], [b, a]]`` (``λ = a + ib``)
    for a complex pair, ``B`` feeding each block's first state."""
    lam = np.linalg.eigvals(realize(*factors, order)[0])
    lam = lam[np.abs(lam) < 1.0]
    tiny = 1e-12
    blocks = [np.array([[x.real]]) for x in lam if abs(x.imag) <= tiny]
    blocks += [np.array([[x.real, -x.imag], [x.imag, x.real]]) for x in lam if x.imag > tiny]
    if not blocks:
        return np.zeros((0, 0)), np.zeros((0, n_in))
    sizes = [b.shape[0] for b in blocks]
    a = np.zeros((sum(sizes), sum(sizes)))
    b = np.zeros(sum(sizes))
    i = 0
    for blk, size in zip(blocks, sizes, strict=True):
        a[i:i + size, i:i + size] = blk
        b[i] = 1.0
        i += size
    return np.kron(np.eye(n_in), a), np.kron(np.eye(n_in), b[:, None])


def pole_states(A: np.ndarray, B: np.ndarray, u: np.ndarray, first: int) -> np.ndarray:
    """The regressors of a record's inputs ``u`` (n_in × n): the zero-state states of the
    basis ``(A, B)`` of :func:`pole_blocks` and, with lag 0 (``first == 0``), the inputs
    themselves. Each block is one first-order recursion ``x[s+1] = λ x[s] + u_i[s]`` (a
    complex ``λ``: the real and imaginary parts of ``x`` are the block's two states), run by
    :func:`scipy.signal.lfilter`."""
    u = np.asarray(u, dtype=float)
    N = A.shape[0]
    X = np.empty((N, u.shape[1]))
    i = 0
    while i < N:
        src = u[int(np.argmax(B[i]))]
        if i + 1 < N and A[i + 1, i] != 0.0:  # a complex pair's 2 × 2 block
            x = scipy.signal.lfilter([0.0, 1.0], [1.0, -complex(A[i, i], A[i + 1, i])], src)
            X[i], X[i + 1] = x.real, x.imag
            i += 2
        else:
            X[i] = scipy.signal.lfilter([0.0, 1.0], [1.0, -A[i, i]], src)
            i += 1
    return np.vstack([X, u]) if first == 0 else X


def _grams(states, Z):
    return [(F @ F.T, F @ z.T, np.sum(z * z, axis=1)) for F, z in zip(states, Z, strict=True)]


def _fold_error(grams, j: int, scale: np.ndarray) -> float:
    """Relative error of record ``j`` from the residues fitted to the other records."""
    A = sum(g[0] for i, g in enumerate(grams) if i != j) / np.outer(scale, scale)
    B = sum(g[1] for i, g in enumerate(grams) if i != j) / scale[:, None]
    th = solve_ls(A, B) / scale[:, None]
    Aj, Bj, cj = grams[j]
    e2 = float(np.sum(cj) - 2 * np.sum(th * Bj) + np.sum(th * (Aj @ th)))
    return float(np.sqrt(max(e2, 0.0) / float(np.sum(cj))))


def _scale(grams) -> np.ndarray:
    d = np.sqrt(sum(np.diag(g[0]) for g in grams))
    return np.where(d > 0, d, 1.0)


def fit_pole_basis(recs, U, pilots, full_pilot, n_in: int, first: int, *, order="auto",
                   gain: float = 0.01):
    """The kernel in the pole basis (module docstring).

    Parameters
    ----------
    recs : list of Record
        Training records (measured inputs ``u``, outputs ``y``).
    U : (m, k) ndarray
        The POC basis.
    pilots : list
        Per record ``j``, the pilot's Hankel factors (:func:`pilot_factors`) of the FIR
        kernel fitted without record ``j`` (the leave-one-record-out folds).
    full_pilot : tuple
        The pilot's factors from every record (the model's poles).
    order : "auto" or int
        Realization order of the poles, or the rule (lowest within ``gain`` of the best
        leave-one-record-out error over even orders 2 … :data:`MAX_POLE_ORDER`).

    Returns
    -------
    (A, B, C, D), info, cv
        The state space in the POC coordinates, ``{"pole_order", "n_poles", "cv_error"}``,
        and every order's leave-one-record-out error.
    """
    Z = [U.T @ r.y for r in recs]
    top = min(MAX_POLE_ORDER, full_pilot[1].size)
    if order == "auto":
        orders = list(range(2, top + 1, 2))
    elif isinstance(order, (int, np.integer)) and not isinstance(order, bool) and \
            1 <= order <= full_pilot[1].size:
        orders = [int(order)]
    else:
        raise InputError(f"Parameter `pole_order`: expected 'auto' or an integer in 1 … "
                         f"{full_pilot[1].size}, got {order!r}")
    cv: dict = {}
    for N in orders if len(orders) > 1 else ():
        errs = []
        for j, fac in enumerate(pilots):
            A, B = pole_blocks(fac, N, n_in)
            grams = _grams([pole_states(A, B, r.u, first) for r in recs], Z)
            errs.append(_fold_error(grams, j, _scale(grams)))
        cv[("poles", N)] = float(np.mean(errs))
    if cv:
        best = min(cv.values())
        N = next(n for n in orders if cv[("poles", n)] <= best * (1.0 + gain))
    else:
        N = orders[0]
    A, B = pole_blocks(full_pilot, N, n_in)
    grams = _grams([pole_states(A, B, r.u, first) for r in recs], Z)
    s = _scale(grams)
    th = solve_ls(sum(g[0] for g in grams) / np.outer(s, s),
                  sum(g[1] for g in grams) / s[:, None]) / s[:, None]
    ns = A.shape[0]
    C = th[:ns].T
    D = th[ns:].T if first == 0 else np.zeros((U.shape[1], n_in))
    info = {"pole_order": N, "n_poles": ns // max(n_in, 1),
            "cv_error": cv.get(("poles", N), float("nan"))}
    return (A, B, C, D), info, cv
