"""Kernels from measured inputs to the POC histories of measured outputs (Chapter 6).

The dissertation's forced methods take the modal forces ``q = Uᵀ F`` of forces applied at the
sensors. A structure shaken at its base, instrumented with accelerometers, has inputs that
are not at the outputs (ground accelerations) and outputs that are not displacements. Then
the kernel goes from **whatever is measured as input** to the **POC histories of whatever is
measured as output** — ML's measured-input form (:class:`~podbench.sysid.methods.MultipleLoad`
with ``inputs="measured"``): with ``U`` the ``k`` leading POMs of the training outputs, the
scaled POC histories ``v = Uᵀ y`` and the measured inputs ``u``, Eq. 3.48 with ``u`` in place
of the modal forces::

    v[s] = Δt Σ_p H[p] u[s − p]     (H[p]: k × n_in),      ŷ = U v̂.

Every record adds its own equations, so records of different lengths train together.
Outputs that respond at lag 0 (accelerations to a base acceleration: direct feedthrough)
keep lag 0 (``feedthrough="auto"``: for acceleration outputs); displacement or strain outputs
start at lag 1. The kernel over the whole record is solved by a deconvolution solver
(:func:`fit_whole`); a kernel of ``L`` lags by least squares from per-record Grams
(:func:`fit_fir`, :mod:`podbench.sysid.deconvolution.lagged`), ``L`` chosen from a grid of
lag lengths by leave-one-record-out on the training records, optionally with the TC prior
(its decay and weight chosen the same way over a grid fixed in advance). Where the grid's
longest kernel is the best, the memory may be longer than the grid (a lightly damped
structure rings for 1/(ζω), seconds to tens of seconds): the kernel is lengthened by
:data:`LAG_GROWTH` while the leave-one-record-out error keeps falling (by
:data:`LAG_GAIN` of the grid's best at each step), and the TC prior's decay times scale
with the length found. With ``k = n_out`` and no prior ML equals the FIR least-squares baseline
(:class:`~podbench.sysid.methods.FIRLeastSquares`) to round-off: ``U`` is then a rotation of
the outputs.

Units: the kernel is in (output unit)/(input unit · s); training and target records must have
one unit system, one ``dt`` and the same channels (checked before any fitting, one line
naming the file and the field).
"""

from __future__ import annotations

import weakref

import numpy as np

from podbench import _compat
from podbench.core.records import Record
from podbench.errors import InputError
from podbench.sysid.deconvolution.lagged import record_grams, solve_ls

__all__ = ["LAG_GRID", "TC_GRID", "CV_FLOOR", "LAG_GROWTH", "LAG_GAIN", "MAX_LAG_COLUMNS",
           "measured_basis", "given_basis", "first_lag", "fit_fir", "fold_kernels", "fit_whole"]

LAG_GRID = (0.25, 0.5, 1.0, 1.5, 2.0)
"""Lag lengths (s) that ``n_lags="auto"`` chooses from (fixed in advance)."""
TC_GRID = tuple((tau, g) for tau in (0.1, 0.2, 0.4) for g in (1e-3, 1e-2, 1e-1))
"""(decay time τ in s, relative weight γ) of the TC prior that ``prior="tc"`` chooses from."""

LAG_GROWTH = 1.5
"""Factor by which ``n_lags="auto"`` lengthens the kernel beyond the grid (below)."""
LAG_GAIN = 0.01
"""Fall of the leave-one-record-out error a longer kernel must bring to be kept, as a
fraction of the error of the grid's longest kernel."""
MAX_LAG_COLUMNS = 2400
"""Largest kernel (lags × inputs) the lengthening tries: its Gram's solve per fold costs
seconds beyond."""

CV_FLOOR = 1e-9
"""Leave-one-record-out errors that differ by less than this (relative to the best, or
absolutely) are round-off: the simplest candidate (fewest lags, first in the grid) wins."""

_GRAMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def measured_basis(recs: list[Record], n_modes) -> tuple[np.ndarray, np.ndarray]:
    """``(U, povs)``: the ``k`` leading POMs of all training outputs side by side and their
    POVs (``k = n_modes``, default every output channel)."""
    Y = np.hstack([r.y for r in recs])
    Uall, s, _ = np.linalg.svd(Y, full_matrices=False)
    k = n_modes if n_modes is not None else recs[0].n_outputs
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not \
            1 <= k <= Uall.shape[1]:
        raise InputError(f"Parameter `n_modes`: expected an integer in 1 … "
                         f"{Uall.shape[1]}, got {k!r}")
    return Uall[:, :k], s[:k]


def given_basis(recs, basis) -> tuple[np.ndarray, np.ndarray]:
    """``(U, povs)`` of a given basis (n_out × k) and the records' energy along it."""
    U = np.asarray(basis, dtype=float)
    m = recs[0].n_outputs
    if U.ndim != 2 or U.shape[0] != m or not 1 <= U.shape[1] <= m:
        raise InputError(f"Parameter `basis`: expected an array of shape ({m}, k), k ≤ {m}, "
                         f"got shape {U.shape}")
    return U, np.linalg.norm(U.T @ np.hstack([r.y for r in recs]), axis=1)


def first_lag(feedthrough, rec: Record) -> int:
    """The first lag of the kernel: 0 with direct feedthrough (``"auto"``: for acceleration
    outputs), 1 without."""
    if feedthrough == "auto":
        return 0 if rec.output_quantity == "acceleration" else 1
    if feedthrough not in (True, False):
        raise InputError(f"Parameter `feedthrough`: expected 'auto', True or False, got "
                         f"{feedthrough!r}")
    return 0 if feedthrough else 1


def _lag_counts(n_lags, dt: float, lag_grid) -> list[int]:
    if n_lags == "auto":
        return sorted({max(1, int(round(t / dt))) for t in lag_grid})
    if isinstance(n_lags, bool) or not isinstance(n_lags, (int, np.integer)) or n_lags < 1:
        raise InputError(f"Parameter `n_lags`: expected None, 'auto' or an integer >= 1, "
                         f"got {n_lags!r}")
    return [int(n_lags)]


def _channel_grams(rec: Record, n_lags: int, first: int):
    """``A``, ``B_y`` and ``y yᵀ`` of a record in its output channels (cached per record)."""
    cache = _GRAMS.setdefault(rec, {})
    for (L, f), g in cache.items():
        if f == first and L >= n_lags:
            k = n_lags * rec.n_inputs
            return g[0][:k, :k], g[1][:k], g[2]
    if rec.y is None:
        raise InputError(f"{rec.name}: field `outputs`: a training record needs its outputs")
    A, B, _ = record_grams(rec.u, rec.y, n_lags, first)
    g = (A, B, rec.y @ rec.y.T)
    cache[(n_lags, first)] = g
    return g


def clear_grams() -> None:
    """Forget the cached per-record Grams (a study that times each method's own work)."""
    _GRAMS.clear()


def _grams_in(rec, U, n_lags, first):
    A, By, Y = _channel_grams(rec, n_lags, first)
    return A, By @ U, np.einsum("ik,ij,jk->k", U, Y, U)


def _cv_error(grams, rows, solve=solve_ls, ridge: float = 0.0) -> float:
    """Mean leave-one-record-out relative error of the outputs from the Grams alone:
    ``‖z_j − ẑ_j‖² = c_j − 2 θ·B_j + θ·A_jθ`` with ``θ`` fitted without record ``j``
    (``ridge``: ``+ ridge·mean(diag A)·I``)."""
    A = sum(g[0][:rows, :rows] for g in grams)
    B = sum(g[1][:rows] for g in grams)
    errs = []
    for Aj, Bj, cj in grams:
        Aj, Bj = Aj[:rows, :rows], Bj[:rows]
        Ak = A - Aj
        if ridge:
            Ak = Ak + ridge * float(np.trace(Ak)) / rows * np.eye(rows)
        th = solve(Ak, B - Bj)
        e2 = float(np.sum(cj) - 2 * np.sum(th * Bj) + np.sum(th * (Aj @ th)))
        errs.append(np.sqrt(max(e2, 0.0) / float(np.sum(cj))))
    return float(np.mean(errs))


def _simplest(scored):
    """The first candidate whose error is within :data:`CV_FLOOR` of the smallest."""
    best = min(e for _, e in scored)
    return next(c for c, e in scored if e <= best + CV_FLOOR * max(1.0, best))


def _fixed_tc(prior) -> bool:
    """``prior`` is a given TC prior ``(τ s, γ)``, both finite and > 0."""
    if isinstance(prior, str) or not isinstance(prior, (tuple, list)) or len(prior) != 2:
        return False
    try:
        vals = [float(v) for v in prior]
    except (TypeError, ValueError):
        return False
    return all(np.isfinite(v) and v > 0 for v in vals)


def _tc_weights(n_lags: int, dt: float, tau: float) -> np.ndarray:
    """``g`` of the TC prior's factor ``R_K[p, q] = g[q]`` for ``q ≥ p`` (:func:`_tc_factor`):
    ``g[q] = sqrt(λ^q − λ^(q+1))``, ``sqrt(λ^(L−1))`` last, ``λ = exp(−Δt/τ)``."""
    lam = float(np.exp(-dt / tau))
    w = lam ** np.arange(n_lags)
    return np.sqrt(np.append(w[:-1] - w[1:], w[-1]))


def _tc_factor(n_lags: int, n_in: int, dt: float, tau: float) -> np.ndarray:
    """``R`` with ``R Rᵀ = P`` (the TC prior, :func:`tc_prior`): ``K = λ^max(p,q)`` factors
    as ``R_K[p, q] = sqrt(λ^q − λ^(q+1))`` for ``q ≥ p`` (``sqrt(λ^(L−1))`` in the last
    column), ``λ = exp(−Δt/τ)``."""
    g = _tc_weights(n_lags, dt, tau)
    return np.kron(np.triu(np.ones((n_lags, n_lags))) * g[None, :], np.eye(n_in))


def _whiten(grams, g: np.ndarray, n_in: int):
    """The Grams in the prior's coordinates ``θ = R φ`` (``R = R_K ⊗ I``, ``R_K[p, q] =
    g[q]`` for ``q ≥ p``): ``RᵀAR``, ``RᵀB``, ``c``. ``X R`` sums the lag blocks of ``X``
    up to each lag and weights it by ``g``, so both products are cumulative sums
    (``O(L²)``, not a dense ``O(L³)`` product)."""
    L = g.size
    out = []
    for A, B, c in grams:
        A4 = A.reshape(L, n_in, L, n_in)
        M = np.cumsum(np.cumsum(A4, axis=2), axis=0) * (g[:, None, None, None]
                                                        * g[None, None, :, None])
        M = M.reshape(L * n_in, L * n_in)
        RB = (np.cumsum(B.reshape(L, n_in, -1), axis=0) * g[:, None, None]).reshape(B.shape)
        out.append((0.5 * (M + M.T), RB, c))
    return out


def _choose_lags(recs, U, Ls: list[int], first: int, cv: dict):
    """``(L, grams)``: the lag count (the simplest within :data:`CV_FLOOR` of the best
    leave-one-record-out error when ``Ls`` has several) and the records' Grams of ``max(Ls)``
    lags; the errors go into ``cv``."""
    n_in = recs[0].n_inputs
    grams = [_grams_in(r, U, max(Ls), first) for r in recs]
    if len(Ls) == 1:
        return Ls[0], grams
    if len(recs) < 2:
        raise InputError("Parameter `n_lags`: 'auto' chooses by leave-one-record-out "
                         "and needs at least 2 training records; give an integer")
    for L in Ls:
        cv[("lags", L)] = _cv_error(grams, L * n_in)
    best = _simplest([(x, cv[("lags", x)]) for x in Ls])
    if best == max(Ls):  # the longest is best: the memory may be longer than the grid
        best, grams = _lengthen(recs, U, best, first, cv, grams)
    return best, grams


def _lengthen(recs, U, L: int, first: int, cv: dict, grams):
    """Kernels longer than the grid's longest (long memories, lightly damped structures):
    ``L`` grows by :data:`LAG_GROWTH` while each step lowers the leave-one-record-out error
    by at least :data:`LAG_GAIN` × the grid's longest kernel's error (a fall relative to the
    error reached would keep lengthening an exact kernel's round-off), the records hold
    twice the lags and the kernel has at most
    :data:`MAX_LAG_COLUMNS` columns; returns the last length that brought the fall and its
    Grams."""
    n_in = recs[0].n_inputs
    n_min = min(r.n_samples for r in recs)
    ref = cv[("lags", L)]
    while True:
        nxt = int(np.ceil(LAG_GROWTH * L))
        if 2 * (nxt + first) > n_min or nxt * n_in > MAX_LAG_COLUMNS:
            return L, grams
        longer = [_grams_in(r, U, nxt, first) for r in recs]
        cv[("lags", nxt)] = _cv_error(longer, nxt * n_in)
        if cv[("lags", L)] - cv[("lags", nxt)] < LAG_GAIN * ref:
            return L, grams
        L, grams = nxt, longer


def _tc_solve(grams, rows: int, L: int, n_in: int, dt: float, grid, cv: dict):
    """``(θ, τ, γ)`` of the TC prior: ``θ = R φ`` with ``R Rᵀ = P`` makes the prior a ridge
    on ``φ`` (posterior mean ``φ = (RᵀAR + γ·s·I)⁻¹ RᵀB``, ``s = trace(RᵀAR)/rows``); ``τ``,
    ``γ`` from ``grid`` by leave-one-record-out (errors into ``cv``) when it has several."""
    sub = [(g[0][:rows, :rows], g[1][:rows], g[2]) for g in grams]
    best = None
    for tau in sorted({t for t, _ in grid}):
        white = _whiten(sub, _tc_weights(L, dt, tau), n_in)
        for t2, g in grid:
            if t2 != tau:
                continue
            e = _cv_error(white, rows, ridge=g) if len(grid) > 1 else 0.0
            if len(grid) > 1:
                cv[("tc", tau, g)] = e
            if best is None or e < best[0] - CV_FLOOR * max(1.0, best[0]):
                best = (e, tau, g, white)
    _, tau, g, white = best
    R = _tc_factor(L, n_in, dt, tau)
    M = sum(w[0] for w in white)
    N = sum(w[1] for w in white)
    return R @ solve_ls(M + g * float(np.trace(M)) / rows * np.eye(rows), N), tau, g


def fit_fir(recs, U, *, n_lags, lag_grid, prior, feedthrough):
    """The FIR kernel ``θ`` (lag-major, :mod:`podbench.sysid.deconvolution.lagged`) in the
    coordinates ``U``, its lags and prior by the rules (module docstring); returns
    ``(θ, info, cv)``: ``info`` holds ``n_lags``, ``first_lag``, ``cv_error`` and the prior's
    choice, ``cv`` every candidate's leave-one-record-out error."""
    dt = recs[0].dt
    n_in = recs[0].n_inputs
    first = first_lag(feedthrough, recs[0])
    Ls = _lag_counts(n_lags, dt, lag_grid)
    n_min = min(r.n_samples for r in recs)
    if Ls[0] + first > n_min:
        bad = min(recs, key=lambda r: r.n_samples)
        raise InputError(f"{bad.name}: field `inputs`: {bad.n_samples} samples, the model "
                         f"needs more than {Ls[0] + first} (n_lags)")
    cv: dict = {}
    L, grams = _choose_lags(recs, U, [L for L in Ls if L + first <= n_min], first, cv)
    rows = L * n_in
    info = {"n_lags": L, "first_lag": first}
    if prior is None:
        theta = solve_ls(sum(g[0][:rows, :rows] for g in grams), sum(g[1][:rows] for g in grams))
    elif prior == "tc" or _fixed_tc(prior):
        grid = TC_GRID if prior == "tc" else (tuple(float(v) for v in prior),)
        top = max(Ls) if n_lags == "auto" else L
        if prior == "tc" and L > top:  # a lengthened kernel: the decay times scale with it
            grid = tuple((tau * L / top, g) for tau, g in grid)
        if len(grid) > 1 and len(recs) < 2:
            raise InputError("Parameter `prior`: 'tc' chooses its weight by "
                             "leave-one-record-out and needs at least 2 training records")
        theta, tau, g = _tc_solve(grams, rows, L, n_in, dt, grid, cv)
        info.update(tc_tau=tau, tc_gamma=g)
    else:
        raise InputError(f"Parameter `prior`: expected None, 'tc' or (tau_s, gamma) > 0, "
                         f"got {prior!r}")
    info["cv_error"] = min(cv.values()) if cv else float("nan")
    return theta, info, cv


def fold_kernels(recs, U, info: dict) -> list[np.ndarray]:
    """The FIR kernels ``θ_j`` of :func:`fit_fir`'s choice (``info``: lags, first lag, TC
    prior) fitted without record ``j``, one per record (leave-one-record-out folds)."""
    L, first = int(info["n_lags"]), int(info["first_lag"])
    n_in = recs[0].n_inputs
    rows = L * n_in
    grams = [_grams_in(r, U, L, first) for r in recs]
    grams = [(g[0][:rows, :rows], g[1][:rows], g[2]) for g in grams]
    tc = "tc_tau" in info
    R = _tc_factor(L, n_in, recs[0].dt, float(info["tc_tau"])) if tc else None
    g = float(info.get("tc_gamma", 0.0))
    white = (_whiten(grams, _tc_weights(L, recs[0].dt, float(info["tc_tau"])), n_in) if tc
             else grams)
    M, N = sum(w[0] for w in white), sum(w[1] for w in white)
    out = []
    for Aj, Bj, _ in white:
        Mk = M - Aj
        th = solve_ls(Mk + g * float(np.trace(Mk)) / rows * np.eye(rows), N - Bj)
        out.append(R @ th if R is not None else th)
    return out


def fit_whole(recs, U, solve, solver_name: str):
    """The kernel over the whole record (records of one length), by ``solve(Q_list, B, dt)``
    (a deconvolution solver named ``solver_name``,
    :func:`~podbench.sysid.methods.base.solve_deconvolution`) from the measured inputs;
    returns ``(θ, info)`` with ``θ`` lag-major as :func:`fit_fir`'s."""
    n = recs[0].n_samples
    for r in recs[1:]:
        if r.n_samples != n:
            raise InputError(f"{r.name}: field `inputs`: {r.n_samples} samples, "
                             f"{recs[0].name} has {n}; n_lags=None (the kernel over the "
                             "whole record) needs records of one length: set n_lags")
    B = np.vstack([(U.T @ r.y).T for r in recs])
    X, sinfo = solve([r.u for r in recs], B, recs[0].dt)
    n_in = recs[0].n_inputs
    dt = recs[0].dt
    # X rows i·n + p (input i, lag p) → θ lag-major with the Δt of the convolution
    theta = X.reshape(n_in, n, -1).transpose(1, 0, 2).reshape(n * n_in, -1) * dt
    return theta, {"n_lags": n, "first_lag": 0,
                   "solver": str(sinfo.get("solver", solver_name))}


def __getattr__(name: str):
    """Retired names of this module (:data:`podbench._compat.RETIRED`)."""
    return _compat.retired(__name__, name)
