"""ML's kernel in a basis of decaying modes whose poles come from the training records.

A lightly damped structure rings for ``1/(ζω)``: a FIR kernel must hold several of these
(tens of seconds, thousands of columns) and the records must hold twice as many lags. The
kernel of a linear structure is a sum of decaying modes, ``H[p] = Σ_j R_j λ_j^(p−1)`` for
``p ≥ 1`` (and ``H[0] = D``): with its poles ``λ_j`` known, the residues are linear in the
data and few (``n_in`` per real pole, ``2·n_in`` per complex pair, per POC), and the kernel
has every lag. Here the poles start as those of an ERA realization
(:func:`podbench.sysid.statespace.era_realization`) of the FIR kernel that ML's own lag rule
fits first (a *pilot*: ERA's Hankel matrix reads only its first lags), the stable ones
(``|λ| < 1``), and are then refined by the records' output error with the residues
eliminated (:func:`refine_poles`: variable projection); the residues are fitted by least
squares over the whole records: each input is filtered by each pole, ``x[s+1] = λ x[s] +
u[s]`` (real and imaginary parts of a complex pole as two regressors, the real block form of
the pair), and the POC histories ``v = Uᵀ y`` are regressed on these states and, with direct
feedthrough, on ``u`` itself. The realization order is the lowest whose leave-one-record-out
error (poles and residues fitted without the record left out) is within
:data:`~podbench.sysid.methods.inputs.LAG_GAIN` of the best over the even orders up to
:data:`MAX_POLE_ORDER`, then (refined) raised by :data:`POLE_STEP` while the refined poles'
leave-one-record-out error falls by that fraction. The basis is the
orthonormal-basis-function idea of system identification (Heuberger, Van den Hof & Wahlberg
2005) with the poles from the data; it is beyond the dissertation, a named variant of ML on
measured inputs (``kernel="poles"``).

The fitted model is a state space in the POC coordinates: ``A`` block diagonal (one block per
pole and input), ``B`` selecting each input's states, ``C`` the residues, ``D`` the lag-0
kernel (units: ``C`` in (output unit)/(input unit), ``D`` likewise, per sample).
"""

from __future__ import annotations

import numpy as np
import scipy  # scipy.signal: loaded on first use (SciPy's lazy submodules)

from podbench.errors import InputError
from podbench.sysid.deconvolution.lagged import solve_ls
from podbench.sysid.statespace import era_realization, realize

__all__ = ["MAX_POLE_ORDER", "REFINE_ITERATIONS", "REFINE_TOL", "REFINE_SPANS", "POLE_STEP",
           "pilot_factors",
           "stable_poles", "poles_blocks", "pole_blocks", "refine_poles", "fit_pole_basis",
           "pole_states"]

MAX_POLE_ORDER = 40
"""Largest realization order whose poles the basis tries (20 complex pairs)."""

_MAX_HANKEL_ROWS = 600
"""Rows of the pilot's Hankel matrix (``s·max(k, n_in)``), as the realization solvers'."""

REFINE_ITERATIONS = 100
"""Most Levenberg–Marquardt steps of :func:`refine_poles`."""

REFINE_TOL = 1e-6
"""Relative fall of the output error below which :func:`refine_poles` stops."""

POLE_STEP = 8
"""Order step of the refined order's search (four complex pairs)."""

REFINE_SPANS = (0.125, 0.25, 0.5, 1.0)
"""The fractions of the records :func:`refine_poles` reads in turn, from their start."""

_TINY = 1e-12
"""``|Im λ|`` below which a pole is real."""


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


def stable_poles(factors, order: int) -> np.ndarray:
    """The stable eigenvalues (``|λ| < 1``) of the order-``order`` realization of the
    pilot's Hankel factors (:func:`pilot_factors`), both members of each complex pair."""
    lam = np.linalg.eigvals(realize(*factors, order)[0])
    return lam[np.abs(lam) < 1.0]


def poles_blocks(lam: np.ndarray, n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the basis of the poles ``lam``: per input, a 1 × 1 block ``λ`` for a
    real pole and ``[[a, −b], [b, a]]`` (``λ = a + ib``, ``b > 0``; the conjugate is
    implied) for a complex pair, real poles first, ``B`` feeding each block's first
    state."""
    blocks = [np.array([[x.real]]) for x in lam if abs(x.imag) <= _TINY]
    blocks += [np.array([[x.real, -x.imag], [x.imag, x.real]]) for x in lam if x.imag > _TINY]
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


def pole_blocks(factors, order: int, n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the basis from the stable poles of the order-``order`` realization
    (:func:`stable_poles`, :func:`poles_blocks`)."""
    return poles_blocks(stable_poles(factors, order), n_in)


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


def _filter(lam, x: np.ndarray) -> np.ndarray:
    """Zero-state ``z[s+1] = λ z[s] + x[s]`` (complex when ``λ`` is)."""
    return scipy.signal.lfilter([0.0, 1.0], [1.0, -lam], x)


def _signals(lam_r, lam_c, inputs, first: int):
    """The regressors ``Φ`` of the basis (the order of :func:`poles_blocks` and
    :func:`pole_states`) and ``W``, the real and imaginary parts of each complex state's
    derivative in its pole, ``∂x/∂λ``, the state filtered by its pole once more
    (``w[s+1] = λ w[s] + x[s]``), per (input, complex pole); the records side by side."""
    Phi, W = [], []
    for u in inputs:
        rows, ders = [], []
        for ui in u:
            rows += [_filter(x, ui) for x in lam_r]
            for x in lam_c:
                z = _filter(x, ui.astype(complex))
                d = _filter(x, z)
                rows += [z.real, z.imag]
                ders += [d.real, d.imag]
        Phi.append(np.array(rows + (list(u) if first == 0 else [])))
        W.append(np.array(ders))
    return np.hstack(Phi), np.hstack(W)


def _projection(Phi, Z):
    """``(θ, G, scale, cost)``: the residues by least squares (columns scaled to unit
    norm), the Gram ``ΦΦᵀ``, the scale and the relative output error ``‖Z − θᵀΦ‖²/‖Z‖²``."""
    G = Phi @ Phi.T
    sc = np.sqrt(np.diag(G))
    sc = np.where(sc > 0, sc, 1.0)
    B = Phi @ Z.T
    th = solve_ls(G / np.outer(sc, sc), B / sc[:, None]) / sc[:, None]
    zz = float(np.sum(Z * Z))
    return th, G, sc, max(zz - float(np.sum(th * B)), 0.0) / zz


def _gauss_newton(th, G, sc, Phi, W, Z, lam_c, sigma, n_r: int, n_in: int):
    """``(JᵀJ, Jᵀr)`` of the projected output error in the parameters ``(ln σ_j, ω_j)``
    (``λ_j = e^{−σ_j + iω_j}``), Kaufman's approximation of the variable-projection
    Jacobian ``J = −P⊥ ∂(θᵀΦ)/∂p``; every product from Grams of the signals, never ``J``."""
    m = lam_c.size
    per = n_r + 2 * m
    k = Z.shape[0]
    M = np.zeros((2 * m, k, W.shape[0]))  # ∂(θᵀΦ)/∂p_c = M_c W
    for j in range(m):
        for c, dl in ((j, -sigma[j] * lam_c[j]), (m + j, 1j * lam_c[j])):
            for i in range(n_in):
                a, b = th[i * per + n_r + 2 * j], th[i * per + n_r + 2 * j + 1]
                q = 2 * (i * m + j)
                M[c, :, q] = a * dl.real + b * dl.imag
                M[c, :, q + 1] = b * dl.real - a * dl.imag
    E = np.einsum("nw,ckw->cnk", Phi @ W.T, M)  # Φ ∂ᵀ: (2m, N, k)
    F = np.stack([solve_ls(G / np.outer(sc, sc), e / sc[:, None]) / sc[:, None] for e in E])
    H = np.einsum("ckw,wv,dkv->cd", M, W @ W.T, M) - np.einsum("cnk,dnk->cd", E, F)
    g = np.einsum("ckw,kw->c", M, Z @ W.T) - np.einsum("cnk,nk->c", E, th)
    return 0.5 * (H + H.T), g


def refine_poles(lam: np.ndarray, recs, U: np.ndarray, first: int, *,
                 max_iter: int = REFINE_ITERATIONS, tol: float = REFINE_TOL):
    """The complex poles moved to minimize the records' output error, the residues
    eliminated (variable projection, Golub & Pereyra 1973; Kaufman's Jacobian) by
    Levenberg–Marquardt steps on ``(ln σ, ω)`` of each pole ``λ = e^{−σ + iω}`` (per
    sample: the poles stay stable, ``σ`` in ``[1e-9, 5]``, ``ω`` in ``(0, π)``); real poles
    are kept. The output error of a lightly damped pole is a narrow valley in ``ω``: a
    frequency error ``δω`` (rad/sample) turns the ring's phase by ``δω·n`` over ``n``
    samples, so the records are read from their start, ``n/8``, ``n/4``, ``n/2``, then ``n``
    samples (:data:`REFINE_SPANS`; each span's poles start the next), which widens the
    valley the first fits see eightfold. Each span stops when a step lowers the relative
    error by less than ``tol`` of it, or after ``max_iter`` steps.

    Returns
    -------
    lam : ndarray
        The poles (one per complex pair, ``Im λ > 0``, real ones first).
    info : dict
        ``refine_steps`` (over the spans), ``refine_error_start``, ``refine_error``
        (relative output error ``‖Z − θᵀΦ‖/‖Z‖`` of the whole training POC histories with
        the starting and the refined poles).
    """
    lam = np.asarray(lam)
    lam_r = lam[np.abs(lam.imag) <= _TINY].real
    lam_c = lam[lam.imag > _TINY]
    n = min(r.n_samples for r in recs)
    us = [np.asarray(r.u, dtype=float)[:, :n] for r in recs]
    zs = [U.T @ np.asarray(r.y, dtype=float)[:, :n] for r in recs]
    lo = np.r_[np.full(lam_c.size, np.log(1e-9)), np.full(lam_c.size, 1e-9)]
    hi = np.r_[np.full(lam_c.size, np.log(5.0)), np.full(lam_c.size, np.pi - 1e-9)]
    p = np.clip(np.r_[np.log(np.maximum(-np.log(np.abs(lam_c)), 1e-9)), np.angle(lam_c)],
                lo, hi)
    start = _span_error(p, lam_r, us, zs, first)
    steps = 0
    for frac in REFINE_SPANS if lam_c.size else ():
        cut = max(int(n * frac), 1)
        p, k = _levenberg_marquardt(p, lo, hi, lam_r, [u[:, :cut] for u in us],
                                    [z[:, :cut] for z in zs], first, max_iter, tol)
        steps += k
    m = lam_c.size
    out = np.r_[lam_r.astype(complex), np.exp(-np.exp(p[:m]) + 1j * p[m:])]
    return out, {"refine_steps": steps, "refine_error_start": float(np.sqrt(start)),
                 "refine_error": float(np.sqrt(_span_error(p, lam_r, us, zs, first)))}


def _at(p, lam_r, us, zs, first):
    """``(λ_c, Φ, W, Z, θ, G, scale, cost)`` at the parameters ``p``."""
    m = p.size // 2
    lc = np.exp(-np.exp(p[:m]) + 1j * p[m:])
    Phi, W = _signals(lam_r, lc, us, first)
    Z = np.hstack(zs)
    return (lc, Phi, W, Z, *_projection(Phi, Z))


def _span_error(p, lam_r, us, zs, first) -> float:
    return _at(p, lam_r, us, zs, first)[-1]


def _levenberg_marquardt(p, lo, hi, lam_r, us, zs, first, max_iter: int, tol: float):
    """Levenberg–Marquardt steps of :func:`refine_poles` on one span: ``(p, steps)``."""
    n_in = us[0].shape[0]
    cur = _at(p, lam_r, us, zs, first)
    mu, steps = 1e-3, 0
    while steps < max_iter:
        lc, Phi, W, Z, th, G, sc, cost = cur
        H, g = _gauss_newton(th, G, sc, Phi, W, Z, lc, np.exp(p[:lc.size]), lam_r.size, n_in)
        d = np.diag(H) + 1e-300
        while mu < 1e8:
            trial = np.clip(p + np.linalg.solve(H + mu * np.diag(d), g), lo, hi)
            new = _at(trial, lam_r, us, zs, first)
            if new[-1] < cost:
                break
            mu *= 4.0
        else:
            break
        steps += 1
        p, cur, mu = trial, new, max(mu / 3.0, 1e-9)
        if cost - new[-1] < tol * cost:
            break
    return p, steps


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


def _refined_order(recs, U, Z, full_pilot, N: int, n_in: int, first: int, top: int,
                   gain: float, cv: dict):
    """``(order, poles, info)``: the order-``N`` poles refined (:func:`refine_poles`), and
    the order raised by :data:`POLE_STEP` (up to ``top``) while the refined poles'
    leave-one-record-out error (the residues fitted without the record; the poles refined
    on every record) falls by at least ``gain`` of it: the pilot's order is chosen with
    the pilot's poles, whose higher orders a refinement can turn into modes. The errors go
    into ``cv`` as ``("refined", order)``."""

    def attempt(order):
        lam, info = refine_poles(stable_poles(full_pilot, order), recs, U, first)
        A, B = poles_blocks(lam, n_in)
        grams = _grams([pole_states(A, B, r.u, first) for r in recs], Z)
        s = _scale(grams)
        cv[("refined", order)] = float(np.mean([_fold_error(grams, j, s)
                                                for j in range(len(recs))]))
        return lam, info

    lam, info = attempt(N)
    while N + POLE_STEP <= top:
        lam2, info2 = attempt(N + POLE_STEP)
        if cv[("refined", N)] - cv[("refined", N + POLE_STEP)] < gain * cv[("refined", N)]:
            break
        N, lam, info = N + POLE_STEP, lam2, info2
    return N, lam, info


def fit_pole_basis(recs, U, pilots, full_pilot, n_in: int, first: int, *, order="auto",
                   gain: float = 0.01, refine: bool = True):
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
    refine : bool
        Move the chosen order's complex poles to the records' least output error
        (:func:`refine_poles`) before the residues are fitted; False: the pilot's poles.

    Returns
    -------
    (A, B, C, D), info, cv
        The state space in the POC coordinates, ``{"pole_order", "n_poles", "cv_error"}``
        (and :func:`refine_poles`'s ``info`` when refined), and every order's
        leave-one-record-out error.
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
    lam = stable_poles(full_pilot, N)
    info: dict = {}
    if refine:
        N, lam, info = _refined_order(recs, U, Z, full_pilot, N, n_in, first,
                                      top if len(orders) > 1 else N, gain, cv)
    A, B = poles_blocks(lam, n_in)
    grams = _grams([pole_states(A, B, r.u, first) for r in recs], Z)
    s = _scale(grams)
    th = solve_ls(sum(g[0] for g in grams) / np.outer(s, s),
                  sum(g[1] for g in grams) / s[:, None]) / s[:, None]
    ns = A.shape[0]
    C = th[:ns].T
    D = th[ns:].T if first == 0 else np.zeros((U.shape[1], n_in))
    info.update(pole_order=N, n_poles=ns // max(n_in, 1),
                cv_error=cv.get(("refined", N), cv.get(("poles", N), float("nan"))))
    return (A, B, C, D), info, cv
