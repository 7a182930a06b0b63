"""Tikhonov-regularized structured solvers and the GCV choice of their parameter.

``"fft"``   :class:`FFTTikhonov` / :func:`fft_tikhonov`, per-frequency matrix deconvolution
            with Tikhonov regularization (circular: fast but biased by the record's
            truncation).
``"cgls"``  :class:`CGLS` / :func:`cgls_fft`, Tikhonov-regularized least squares on the exact
            system by conjugate gradients with FFT products and a circulant preconditioner;
            ``reg=0`` is plain least squares (also over-determined ML).

The Tikhonov parameter is chosen by generalized cross-validation unless given
(``reg="gcv"``, the default; :func:`gcv_regularization`).
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from podbench.errors import ConvergenceError, IllConditionedError, InputError
from podbench.sysid.deconvolution._base import Solver
from podbench.sysid.deconvolution._cg import coldot, fft_operators, pcg
from podbench.sysid.deconvolution.dense import memoized
from podbench.sysid.deconvolution.determined import StoppingRule
from podbench.sysid.deconvolution.system import ConvolutionSystem, first_sample
from podbench.sysid.params import COUNT, NON_NEGATIVE, POSITIVE, Interval, Options, check_param

__all__ = [
    "FFTTikhonov",
    "CGLS",
    "fft_tikhonov",
    "cgls_fft",
    "gcv_regularization",
    "DEFAULT_TIKHONOV_REG",
    "GCV_BOUNDS",
    "TRIAL_ITER",
]


DEFAULT_TIKHONOV_REG = "gcv"
"""Default Tikhonov parameter of :func:`fft_tikhonov` and :func:`cgls_fft`: chosen from the
data by generalized cross-validation (:func:`gcv_regularization`). A number instead is the
relative parameter ``reg`` of ``λ = reg · max_ω σ_max(Δt Ĝ(ω))`` (``max_ω σ_max`` bounds
``‖A‖₂``). Measured (docs/methods.md): the former fixed default ``1e-2`` over-smooths the
undamped LTI beam (ML prediction error 0.63 on clean data, against 0.041 for ``"ls"``; GCV
0.074); ``1e-3`` lets 0.1 % noise through as about 5 % prediction error with ``"fft"`` on
the ideal chain."""

GCV_BOUNDS = (1e-7, 1.0)
"""Search interval of :func:`gcv_regularization` for the relative parameter ``reg``. The
lower end keeps ``‖A‖₂/λ ≤ 1e7`` (the conjugate-gradient solver converges within its default
iteration limit; the dense least squares itself truncates at ``eps·σ_1``); at the upper end
every direction is damped by at least a factor 2."""


def _circulant_spectrum(Gh: np.ndarray, Yh: np.ndarray,
                        N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-frequency SVD of the circulant embedding (length ``N``) of Eq. 3.48, from the
    transforms ``Gh = Δt·rfft(G, N)`` (F, n_cases, k) and ``Yh = rfft(Y, N)`` (F, n_cases, r).

    Returns the rfft weights ``w`` (F,) (2 for frequencies standing for a conjugate pair, 1
    for 0 and N/2), the singular values ``s`` (F, q) of ``Δt Ĝ(ω)``, the squared data
    coefficients ``b2`` (F, q) along the left singular vectors (summed over the columns of
    ``Y``) and the squared data norm ``perp`` (F,) outside their span.
    """
    U, s, _ = np.linalg.svd(Gh, full_matrices=False)
    beta = np.conj(U).transpose(0, 2, 1) @ Yh
    b2 = np.sum(np.abs(beta) ** 2, axis=2)
    perp = np.maximum(np.sum(np.abs(Yh) ** 2, axis=(1, 2)) - np.sum(b2, axis=1), 0.0)
    w = np.full(Gh.shape[0], 2.0)
    w[0] = 1.0
    if N % 2 == 0:
        w[-1] = 1.0
    return w, s, b2, perp


def _embedding(G: np.ndarray, pad) -> tuple[int, int, int]:
    """Validate ``pad`` (>= 1) and return ``(d, m, N)``: the leading zero force samples ``d``,
    the samples ``m = n − d`` after the shift and the transform length ``N ≥ pad·m``."""
    pad = _check_pad(pad)
    d = first_sample(G, 0.0)
    m = G.shape[0] - d
    return d, m, scipy.fft.next_fast_len(max(int(np.ceil(pad * m)), 1), real=True)


PAD: list = [Interval("number", 1)]
REG_POSITIVE: list = [Options("gcv"), POSITIVE]
"""``reg`` of ``"fft"``: ``"gcv"`` or a number > 0."""
REG_NON_NEGATIVE: list = [Options("gcv"), NON_NEGATIVE]
"""``reg`` of ``"cgls"`` and ``"stls"``: ``"gcv"`` or a number >= 0 (0: least squares)."""


def _check_pad(pad) -> float:
    return check_param(pad, "pad", PAD)


def _gcv_function(w, s, b2, perp, N: int, n_cases: int):
    """``V(reg)`` of :func:`gcv_regularization` for the spectrum of :func:`_circulant_spectrum`."""
    smax = float(s.max())
    total_perp = float(np.sum(w * perp))
    n_data = N * n_cases

    def V(reg: float) -> float:
        lam2 = (reg * smax) ** 2
        phi = s**2 / (s**2 + lam2)  # Tikhonov filter factors
        rss = (float(np.sum(w[:, None] * (1.0 - phi) ** 2 * b2)) + total_perp) / N
        dof = n_data - float(np.sum(w[:, None] * phi))
        return rss / dof**2 if dof > 0 else np.inf

    return V


def gcv_regularization(Q_list, B, dt: float, *, pad: float = 2.0,
                       bounds: tuple[float, float] = GCV_BOUNDS) -> float:
    """Tikhonov parameter by generalized cross-validation (Golub, Heath & Wahba 1979).

    For the (block) convolution system of Eq. 3.43 / 3.48 after the shift past leading zero
    force samples, the relative parameter ``reg`` of ``λ = reg · max_ω σ_max(Δt Ĝ(ω))`` that
    minimizes ::

        V(λ) = ‖(I − H_λ) y‖² / (N_y − tr H_λ)²,   H_λ = A (AᵀA + λ²I)⁻¹ Aᵀ,

    with ``A`` the circulant embedding of the convolution matrix (length ``N ≥ pad·n``, the
    embedding :func:`fft_tikhonov` solves; its singular values are those of ``Δt Ĝ(ω)`` over
    the frequencies, so ``V`` costs ``O(N k² n_cases)`` per ``λ`` after one small SVD per
    frequency) and ``y`` every column of ``B`` (one ``λ`` for all columns; ``N_y`` = ``N ×
    n_cases`` data per column). GCV needs no noise level: it estimates the prediction error
    of the fit from the data by leave-one-out cross-validation made rotation-invariant. It
    assumes white noise in ``B``; noise in the forces (in ``A``) violates that, see
    docs/methods.md for what it then does on the beams.

    ``V`` is evaluated on 161 log-spaced values in ``bounds`` (default
    :data:`GCV_BOUNDS`) and refined by a bounded scalar search around the best one;
    deterministic.

    Parameters
    ----------
    Q_list, B, dt
        As :func:`block_substitution`.
    pad : float
        Embedding length as a multiple of the samples after the shift, >= 1 (default 2).
    bounds : (float, float)
        Search interval for ``reg``, ``0 < lo < hi``.

    Returns
    -------
    float
        The relative parameter ``reg`` (pass it as ``reg=`` to :func:`fft_tikhonov` or
        :func:`cgls_fft`).
    """
    system = ConvolutionSystem(Q_list, B, dt)
    G, Y, dt = system.G, system.Y, system.dt
    d, _, N = _embedding(G, pad)
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise InputError(f"Parameter `bounds`: expected two numbers, got {bounds!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"Parameter `bounds`: expected 0 < lo < hi, got {bounds!r}")
    spectrum = _circulant_spectrum(dt * scipy.fft.rfft(G[d:], N, axis=0),
                                   scipy.fft.rfft(Y[d:], N, axis=0), N)
    return _gcv_minimize(*spectrum, N, G.shape[1], lo, hi)


def _gcv_minimize(w, s, b2, perp, N, n_cases, lo=GCV_BOUNDS[0], hi=GCV_BOUNDS[1]) -> float:
    import scipy.optimize  # here: 0.2 s of import time the CLI need not pay

    V = _gcv_function(w, s, b2, perp, N, n_cases)
    grid = np.logspace(np.log10(lo), np.log10(hi), 161)
    values = np.array([V(g) for g in grid])
    if not np.any(np.isfinite(values)):
        raise IllConditionedError(
            "GCV: the fit has no residual degrees of freedom for any parameter in "
            f"[{lo:g}, {hi:g}]; give `reg` as a number"
        )
    i = int(np.nanargmin(np.where(np.isfinite(values), values, np.nan)))
    a, b = np.log10(grid[max(i - 1, 0)]), np.log10(grid[min(i + 1, len(grid) - 1)])
    res = scipy.optimize.minimize_scalar(lambda x: V(10.0**x), bounds=(a, b), method="bounded",
                                         options={"xatol": 1e-4})
    x = float(res.x) if res.success and V(10.0 ** res.x) <= values[i] else np.log10(grid[i])
    return float(10.0**x)


def tikhonov_reg(reg, allow_zero: bool):
    """Validate ``reg``: ``"gcv"`` or a number (> 0, or >= 0 if ``allow_zero``)."""
    return check_param(reg, "reg", REG_NON_NEGATIVE if allow_zero else REG_POSITIVE)


def spectral_norm(Gh: np.ndarray) -> float:
    """``max_ω σ_max(Ĝ(ω))`` of a stack of (complex) matrices."""
    if Gh.shape[1] == 1 or Gh.shape[2] == 1:
        return float(np.sqrt(np.max(np.sum(np.abs(Gh) ** 2, axis=(1, 2)))))
    return float(np.max(np.linalg.svd(Gh, compute_uv=False)[:, 0]))


def fft_tikhonov(Q_list, B, dt: float, *, reg: float | str = DEFAULT_TIKHONOV_REG,
                 pad: float = 2.0) -> np.ndarray:
    """Regularized frequency-domain deconvolution of Eq. 3.43 / 3.48 (``"fft"``).

    The dissertation's frequency-domain form ``H(jω) = Y(jω)/X(jω)`` (Eq. 3.68), made
    matrix-valued and regularized where ``X(jω)`` is small (the failure §3.5 describes).

    After dropping the leading zero force samples (as :func:`block_substitution`, exact
    zeros only), the modal forces and POC histories are zero-padded to ``N ≥ pad·n`` samples
    and transformed; per frequency the matrix equation ``Ŷ(ω) = Δt Ĝ(ω) X̂(ω)``
    (``n_cases × k`` times ``k × r``) is solved with Tikhonov regularization::

        X̂(ω) = (Ĝᴴ Ĝ + λ² I)⁻¹ Ĝᴴ Ŷ,   λ = reg · max_ω σ_max(Δt Ĝ(ω))

    (default ``reg = "gcv"``: chosen by :func:`gcv_regularization` on this same embedding),
    and the kernel is the first ``n`` samples of the inverse transform. Cost
    ``O((k² + kr) N log N + k³ N)``; no ``n × n`` matrix is formed.

    This is *not* the least-squares solution of the triangular system: the deconvolution is
    circular, so the truncation of the record at ``n`` samples (the response continues, the
    zero padding says it stops) and the regularization both bias the kernel, most near the
    end of the record. It is meant for noisy data, where the exact solvers amplify the noise;
    on clean data prefer ``"block"``. Measured accuracy: see docs/methods.md.

    Parameters
    ----------
    Q_list, B, dt
        As :func:`block_substitution`.
    reg : float or "gcv"
        Relative Tikhonov parameter, > 0, or ``"gcv"`` (default) to choose it by generalized
        cross-validation.
    pad : float
        Transform length as a multiple of the number of samples, >= 1 (default 2, no
        wrap-around of the forward convolution within the record).

    Returns
    -------
    (k·n,) or (k·n, r) ndarray
    """
    system = ConvolutionSystem(Q_list, B, dt)
    reg = tikhonov_reg(reg, allow_zero=False)
    X, _ = _fft(system, reg, pad)
    return system.stack(X)


def _fft(system: ConvolutionSystem, reg, pad):
    """:func:`fft_tikhonov` on a validated system (``reg``, ``pad`` validated): kernel samples
    ``(n, k, r)`` and the diagnostics."""
    G, Y, dt = system.G, system.Y, system.dt
    n, _, k = G.shape
    r = Y.shape[2]
    d, m, N = _embedding(G, pad)
    Gh = dt * scipy.fft.rfft(G[d:], N, axis=0)  # (F, n_cases, k)
    Yh = scipy.fft.rfft(Y[d:], N, axis=0)  # (F, n_cases, r)
    rule = "fixed"
    if reg == "gcv":
        reg = _gcv_minimize(*_circulant_spectrum(Gh, Yh, N), N, G.shape[1])
        rule = "gcv"
    lam2 = (reg * spectral_norm(Gh)) ** 2
    GH = np.conj(Gh).transpose(0, 2, 1)
    Xh = np.linalg.solve(GH @ Gh + lam2 * np.eye(k), GH @ Yh)
    X = np.zeros((n, k, r))
    X[:m] = scipy.fft.irfft(Xh, N, axis=0)[:m]
    return X, {"reg": float(reg), "reg_rule": rule, "shift": d, "n_fft": N}


def cgls_fft(
    Q_list,
    B,
    dt: float,
    *,
    reg: float | str = DEFAULT_TIKHONOV_REG,
    tol: float = 1e-10,
    max_iter: int | None = None,
) -> np.ndarray:
    """Tikhonov-regularized least squares of Eq. 3.43 / 3.48 by preconditioned conjugate
    gradients with FFT products (``"cgls"``).

    Solves ``min ‖A X − B‖_F² + λ² ‖X‖_F²`` on the *exact* triangular system (no circular
    approximation) with ``λ = reg · max_ω σ_max(Δt Ĝ(ω))`` (``max_ω σ_max`` bounds ``‖A‖₂``;
    default ``reg = "gcv"``: :func:`gcv_regularization` on the circulant embedding below, a
    model of ``A`` whose singular values approximate those of ``A``): conjugate gradients on
    the regularized normal equations ``(AᵀA + λ²I) X = AᵀB`` (CGLS), all columns of ``B`` at
    once. Every product with ``A`` or ``Aᵀ`` is an FFT (cross-)convolution, so nothing
    ``n × n`` is formed. Preconditioner: the same operator for the circulant embedding of
    ``A`` (length ``N ≥ 2n − 1``), inverted per frequency, ``(Ĝᴴ Ĝ + μ² I)⁻¹`` with
    ``μ = λ`` (or ``1e-6 · max_ω σ_max`` if ``reg = 0``). The embedding differs from ``A``
    only where the force record is cut at ``n`` samples, a term of the rank of the force's
    support, so a short pulse needs a few tens of iterations (measured 11–154 in
    docs/methods.md) whatever ``n``.

    Leading zero force samples are shifted past as in :func:`block_substitution` (exact:
    their equations hold no unknown, the last ``d`` lags are zero). ``reg = 0`` gives the
    least-squares solution of ``"ls"`` (within ``tol``) when the shifted system has full
    column rank, also for an over-determined ML (more load cases than modes), where
    ``"block"`` does not apply; with a rank-deficient system it is *a* least-squares
    solution, not necessarily the minimum-norm one (the preconditioner does not keep the
    iterates in the range of ``Aᵀ``).

    Parameters
    ----------
    Q_list, B, dt
        As :func:`block_substitution`.
    reg : float or "gcv"
        Relative Tikhonov parameter, >= 0, or ``"gcv"`` (default) to choose it by generalized
        cross-validation.
    tol : float
        Stop when ``‖Aᵀ(B − A X) − λ² X‖ <= tol · ‖Aᵀ B‖`` for every column (default 1e-10).
    max_iter : int, optional
        Iteration limit (default 1000); :class:`ConvergenceError` beyond it.

    Returns
    -------
    (k·n,) or (k·n, r) ndarray
    """
    system = ConvolutionSystem(Q_list, B, dt)
    X, _ = cgls_iterate(system, *CGLS(reg=reg, tol=tol, max_iter=max_iter)._cgls_params())
    return system.stack(X)


def cgls_iterate(system: ConvolutionSystem, reg, tol: float, max_iter: int):
    """:func:`cgls_fft` on a validated system (parameters validated): kernel samples
    ``(n, k, r)`` and the diagnostics (``iterations`` over every solve, GCV trials
    included, and ``solves``)."""
    G, Y, dt = system.G, system.Y, system.dt
    n, n_cases, k = G.shape
    r = Y.shape[2]
    # shift past leading zero samples (their equations and the last d lags drop out exactly;
    # without the shift the preconditioner would fill the last lags' null space)
    d = first_sample(G, 0.0)
    n_full = n
    G, Y, n = G[d:], Y[d:], n - d
    N = scipy.fft.next_fast_len(2 * n - 1, real=True)
    Gh = dt * scipy.fft.rfft(G, N, axis=0)  # (F, n_cases, k)
    normal = _TikhonovNormal(Gh, Y, N, n, tol, max_iter)
    if reg == "gcv":
        spectrum = _circulant_spectrum(Gh, scipy.fft.rfft(Y, N, axis=0), N)
        reg, X = _gcv_exact(normal.solve, normal.rss, *spectrum, N, n_cases, n,
                            min(TRIAL_ITER, max_iter))
        rule = "gcv"
    else:
        X = normal.solve(reg)
        rule = "fixed"
    info = {"reg": float(reg), "reg_rule": rule, "shift": d,
            "iterations": normal.iterations, "solves": normal.solves}
    return np.concatenate([X, np.zeros((n_full - n, k, r))]), info


class _TikhonovNormal:
    """The regularized normal equations ``(AᵀA + λ²I) X = AᵀY`` of the shifted system, by
    FFT products, solved by :func:`~podbench.sysid.deconvolution._cg.pcg` for one ``λ`` at a
    time (counting iterations and solves over all of them)."""

    def __init__(self, Gh: np.ndarray, Y: np.ndarray, N: int, n: int, tol: float,
                 max_iter: int):
        self.A, self.At, GhT = fft_operators(Gh, N, n)
        self.GhH_Gh = GhT.conj() @ Gh
        self.smax = spectral_norm(Gh)
        self.Y, self.N, self.n, self.tol, self.max_iter = Y, N, n, tol, max_iter
        self.AtY = self.At(Y)
        self.iterations = 0
        self.solves = 0

    def rss(self, X) -> float:
        """``‖Y − A X‖²`` (the true residual of the exact system)."""
        return float(np.sum((self.Y - self.A(X)) ** 2))

    def solve(self, reg_value: float, X0=None, limit: int | None = None) -> np.ndarray:
        """CGLS for one λ (warm start ``X0``, at most ``limit`` iterations); returns ``X`` or
        raises ConvergenceError."""
        A, At, N, n, tol = self.A, self.At, self.N, self.n, self.tol
        limit = self.max_iter if limit is None else min(limit, self.max_iter)
        lam2 = (reg_value * self.smax) ** 2
        # preconditioner: the same Tikhonov operator for the circulant embedding of A,
        # inverted per frequency (it differs from AᵀA + λ²I by a term of the rank of the
        # force's support)
        mu2 = lam2 if lam2 > 0 else (1e-6 * self.smax) ** 2
        Minv = np.linalg.inv(self.GhH_Gh + mu2 * np.eye(self.GhH_Gh.shape[1]))  # Hermitian

        def precond(Z):
            return scipy.fft.irfft(Minv @ scipy.fft.rfft(Z, N, axis=0), N, axis=0)[:n]

        if X0 is None:
            X = np.zeros(self.AtY.shape)
            R = self.AtY.copy()  # residual of the regularized normal equations
        else:
            X = X0.copy()
            R = self.AtY - At(A(X)) - lam2 * X
        r0 = coldot(self.AtY, self.AtY)
        self.solves += 1
        X, R, it, active = pcg(lambda P: At(A(P)) + lam2 * P, precond, X, R, (tol**2) * r0,
                               limit)
        self.iterations += it
        if np.any(active):
            rel = float(np.sqrt(np.max(coldot(R, R)[active] / r0[active])))
            raise ConvergenceError(
                f"solver 'cgls': no convergence in {limit} iterations (relative "
                f"normal-equation residual {rel:.3g} > tol = {tol:g}, reg = "
                f"{reg_value:.3g}); the system is ill-conditioned: use 'block' (exact) or "
                "a larger reg"
            )
        return X


TRIAL_ITER = 300
"""Iteration limit of a trial solve of the GCV search in :func:`cgls_fft` (the solve at the
circulant estimate itself has the full ``max_iter``). Measured on pulse loads: 11–154
iterations at reg = 1e-2 (docs/methods.md)."""


def _gcv_exact(solve, rss, w, s, b2, perp, N, n_cases, n, trial_iter):
    """GCV on the exact triangular system for :func:`cgls_fft`.

    ``V(λ) = ‖B − A X_λ‖² / (n·n_cases − t(λ))²`` with ``X_λ`` the conjugate-gradient
    solution of the exact system (its true residual, no circular approximation) and the
    trace ``t(λ)`` of the influence matrix from the circulant spectrum scaled to the ``n``
    equations, ``(n/N) Σ_ω Σ_i φ_i(λ)`` (Szegő's limit). Trial parameters start at the
    circulant GCV choice ``reg_c`` (:func:`gcv_regularization`, cheap; or the first
    half-decade above it whose solve converges) and move in
    half-decade steps up, then down (warm-started; a trial that does not converge within
    :data:`TRIAL_ITER` iterations ends the descent: λ that small is out of the solver's reach
    at acceptable cost), within two decades of ``reg_c`` and :data:`GCV_BOUNDS`. The best
    trial is taken, with no finer search: each trial is a solve, and the prediction error is
    flat within half a decade of the optimum. Returns its parameter and solution
    ``(reg, X)``."""
    lo, hi = GCV_BOUNDS
    smax = float(s.max())
    n_data = n * n_cases

    def trace(reg):
        phi = s**2 / (s**2 + (reg * smax) ** 2)
        return n / N * float(np.sum(w[:, None] * phi))

    cache: dict[float, tuple[float, np.ndarray]] = {}  # reg -> (V, X)

    def V(reg, X0=None):
        if reg not in cache:
            X = solve(reg, X0, trial_iter)
            dof = n_data - trace(reg)
            cache[reg] = (rss(X) / dof**2 if dof > 0 else np.inf, X)
        return cache[reg]

    reg_c = _gcv_minimize(w, s, b2, perp, N, n_cases)
    steps = 10.0 ** (0.5 * np.arange(1, 5))
    # the start: reg_c, or the first half-decade above it that converges
    start, X0 = None, None
    for g in [reg_c] + [reg_c * f for f in steps]:
        g = float(min(g, hi))
        try:
            best_v, X0 = V(g)
            start = g
            break
        except ConvergenceError:
            continue
    if start is None:
        raise ConvergenceError(
            f"solver 'cgls': GCV found no parameter between reg = {reg_c:.3g} and "
            f"{min(reg_c * steps[-1], hi):.3g} for which conjugate gradients converge in "
            f"{trial_iter} iterations; give `reg` as a number or use 'fft'"
        )
    for direction in (1.0, -1.0):  # up, then down, each until V rises
        X_prev = X0
        for f in steps:
            g = float(start * f**direction)
            if not lo <= g <= hi:
                break
            try:
                v, X_prev = V(g, X_prev)
            except ConvergenceError:
                break
            if v >= best_v:
                break
            best_v = v
    best = min(cache, key=lambda g: cache[g][0])
    return best, cache[best][1]


# ----------------------------------------------------------------------- solver objects
class FFTTikhonov(Solver):
    """Circular Tikhonov deconvolution per frequency (``"fft"``), see :func:`fft_tikhonov`.

    Parameters
    ----------
    reg : float or "gcv"
        Relative Tikhonov parameter, > 0, or ``"gcv"`` (default) to choose it by generalized
        cross-validation (:func:`gcv_regularization`).
    pad : float
        Transform length as a multiple of the samples after the shift, >= 1 (default 2).

    Notes
    -----
    Diagnostics: ``reg`` (the parameter used, the GCV choice if ``reg="gcv"``),
    ``reg_rule`` (``"gcv"`` or ``"fixed"``), ``shift`` (leading zero samples), ``n_fft``
    (transform length).
    """

    name = "fft"
    structured = True
    _parameter_constraints = {"reg": REG_POSITIVE, "pad": PAD}

    def __init__(self, *, reg: float | str = DEFAULT_TIKHONOV_REG, pad: float = 2.0):
        self.reg = reg
        self.pad = pad

    def _solve(self, system: ConvolutionSystem):
        p = self._params()
        X, info = _fft(system, p["reg"], p["pad"])
        return system.stack(X), info


class CGLS(Solver):
    """Tikhonov-regularized least squares on the exact system by preconditioned conjugate
    gradients with FFT products (``"cgls"``), see :func:`cgls_fft`.

    Parameters
    ----------
    reg : float or "gcv"
        Relative Tikhonov parameter, >= 0 (0: plain least squares), or ``"gcv"`` (default).
    tol : float
        Relative normal-equation residual at which to stop (default 1e-10).
    max_iter : int
        Iteration limit of one solve (default 1000); :class:`ConvergenceError` beyond it.

    Notes
    -----
    Diagnostics: ``reg``, ``reg_rule`` (as :class:`FFTTikhonov`), ``iterations`` (all
    conjugate-gradient iterations, those of the GCV trial solves included), ``solves``
    (solves started, one with a fixed ``reg``), ``shift``.
    """

    name = "cgls"
    stopping = StoppingRule(gain=1.7e4, power=1.0, roundoff=3.3e-6, residual_gain=7.2e6,
                            residual_power=1.0, residual_roundoff=3.4e-5)
    """Its test on the normal-equation residual, measured on Chapter 5's beams (docs/noise.md,
    *Digits of an iterative solve*): a decade of ``tol`` moves the errors by ≤ 1.9e-9 and
    the Eq. 4.2 maximum by ≤ 1.7e4·tol; the relative residual by 7.2e6·tol."""
    structured = True
    _parameter_constraints = {"reg": REG_NON_NEGATIVE, "tol": [POSITIVE],
                              "max_iter": [None, COUNT]}

    def __init__(self, *, reg: float | str = DEFAULT_TIKHONOV_REG, tol: float = 1e-10,
                 max_iter: int | None = 1000):
        self.reg = reg
        self.tol = tol
        self.max_iter = max_iter

    def _cgls_params(self) -> tuple:
        p = self._params()
        return p["reg"], p["tol"], 1000 if p["max_iter"] is None else p["max_iter"]

    def _solve(self, system: ConvolutionSystem):
        """``cgls_iterate``'s answer, kept per process like the dense solvers' (a method and
        its coupled twin in the same basis solve the same system: the same bytes again; not
        for a subclass)."""
        def compute(sy):
            return cgls_iterate(sy, *self._cgls_params())

        X, info = memoized(self, system, compute) if type(self) is CGLS else compute(system)
        return system.stack(X), info
