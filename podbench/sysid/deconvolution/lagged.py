"""Finite-impulse-response (FIR) least squares over records of different lengths, from
normal equations accumulated record by record (never the lagged design matrix).

The model of one record (``u``: ``n_in × n`` inputs, ``z``: ``r × n`` outputs, column ``s``
at ``t_s = s·Δt``, zero before ``t_0``: the record starts at rest)::

    z[s] = Δt Σ_{p ∈ lags} H[p] u[s − p],      lags = first, first+1, …, first+L−1,

``first = 0`` with direct feedthrough (an acceleration output responds at lag 0 to a base
acceleration), ``first = 1`` without. The unknown ``θ`` stacks ``Δt·H[p]ᵀ`` lag-major (row
``(p − first)·n_in + i``), so the leading ``L'·n_in`` rows are the model with ``L' < L``
lags: one Gram matrix of ``L`` lags serves every shorter lag length.

Per record :func:`record_grams` returns ``A = XᵀX`` (``L·n_in`` square), ``B = Xᵀzᵀ`` and
``c = diag(z zᵀ)`` (``X`` the lagged inputs) from running sums of input products in
``O(L·n_in²·n)`` operations; the residual of any ``θ`` on a record is
``c − 2 diag(θᵀB) + diag(θᵀAθ)``, so leave-one-record-out needs the Grams only.

Regularization: none (plain least squares), or the TC ("tuned/correlated", stable-spline)
prior of kernel-based identification, ``θ_l ~ N(0, c_l·P)`` with
``P[(p,i),(q,j)] = δ_ij λ^max(p,q)``, ``λ = exp(−Δt/τ)``; ``τ`` and the noise-to-prior ratio
``γ`` chosen by the marginal likelihood of the training records (empirical Bayes, as
podbench's ``"kernel"`` solver does it), each output's noise variance profiled out.
"""

from __future__ import annotations

import numpy as np
import scipy  # scipy.signal: loaded on first use (SciPy's lazy submodules)
import scipy.linalg

from podbench.errors import InputError

__all__ = ["record_grams", "lag_response", "solve_ls", "tc_prior", "tc_fit",
           "loeo_errors", "TC_TAUS", "TC_GAMMAS"]

TC_TAUS = (0.05, 0.1, 0.2, 0.4, 0.8)
"""Decay times τ (s) of the TC prior searched by the marginal likelihood (fixed in advance)."""
TC_GAMMAS = tuple(10.0 ** np.arange(-6.0, 2.5, 0.5))
"""Noise-to-prior ratios γ searched (relative to ``trace(PA)/(L·n_in)``; fixed in advance)."""


def record_grams(u: np.ndarray, z: np.ndarray, n_lags: int, first: int = 0):
    """``A = XᵀX``, ``B = Xᵀzᵀ``, ``c = Σ_s z[s]²`` (per output) of one record.

    Parameters
    ----------
    u : (n_in, n) ndarray
    z : (r, n) ndarray
    n_lags : int
        ``L``, lags ``first … first+L−1``.
    first : int
        0 (feedthrough) or 1.

    Returns
    -------
    A : (L·n_in, L·n_in) ndarray
    B : (L·n_in, r) ndarray
    c : (r,) ndarray
    """
    u = np.asarray(u, dtype=float)
    z = np.asarray(z, dtype=float)
    n_in, n = u.shape
    lags = first + np.arange(n_lags)
    A = _lagged_gram(u, lags).reshape(n_lags * n_in, n_lags * n_in)
    B = np.zeros((n_lags, n_in, z.shape[0]))
    for k, lag in enumerate(lags):
        if lag < n:
            B[k] = u[:, : n - lag] @ z[:, lag:].T
    return A, B.reshape(n_lags * n_in, -1), np.sum(z * z, axis=1)


def _lagged_gram(u: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """``A[p, i, q, j] = Σ_t u_i[t − lag_p] u_j[t − lag_q]`` over ``t < n`` (zero before
    the record), in ``O(L·n_in²·n)`` operations as ``L`` dot products over the record plus
    ``O(n_in²·L²)`` for the ends.

    With ``lag_p ≤ lag_q`` and ``d = q − p`` the sum is ``Σ_{s<T} u_i[s+d] u_j[s]``,
    ``T = n − lag_q``: the whole correlation at ``d`` minus its tail ``s ≥ T``; every
    ``T`` lies in the last ``lag_max`` samples, so the tails are suffix sums there.
    """
    n_in, n = u.shape
    L = lags.size
    whole = np.zeros((n_in, n_in, L))
    for d in range(min(L, n)):
        whole[:, :, d] = np.einsum("it,jt->ij", u[:, d:], u[:, : n - d])
    t0 = max(0, n - int(lags[-1]))
    K = n - t0  # the tail's samples, t0 … n − 1
    w = u[:, t0:]
    idx = np.arange(K)[None, :] + np.arange(L)[:, None]  # s + d, (L, K)
    shifted = np.where(idx < K, w[:, np.minimum(idx, K - 1)], 0.0)  # w_i[s+d], (n_in, L, K)
    prod = shifted[:, None] * w[None, :, None, :]  # (n_in_i, n_in_j, L, K)
    suffix = np.zeros((n_in, n_in, L, K + 1))
    suffix[..., :K] = np.cumsum(prod[..., ::-1], axis=3)[..., ::-1]
    p, q = np.meshgrid(np.arange(L), np.arange(L), indexing="ij")
    d = np.abs(q - p)
    T = np.clip(n - lags[np.maximum(p, q)], t0, n - d) - t0
    V = whole[:, :, d] - suffix[:, :, d, T]  # (n_in_i, n_in_j, L_p, L_q): V[i,j,p,q] for p ≤ q
    upper = (q >= p)[:, None, :, None]
    return np.where(upper, V.transpose(2, 0, 3, 1), V.transpose(3, 1, 2, 0))


FFT_LAGS = 64
"""Kernels of more lags than this are applied by FFT convolution (overlap-add), shorter
ones lag by lag (the same sum to round-off)."""


def lag_response(theta: np.ndarray, u: np.ndarray, n_in: int, first: int = 0) -> np.ndarray:
    """``z[s] = Σ_p θ_pᵀ u[s − lag_p]`` for ``θ`` of :func:`record_grams`' layout: (r, n)."""
    u = np.asarray(u, dtype=float)
    n = u.shape[1]
    L = theta.shape[0] // n_in
    th = theta.reshape(L, n_in, -1)
    z = np.zeros((th.shape[2], n))
    if first >= n:
        return z
    if L > FFT_LAGS:
        for i in range(n_in):  # z[:, first + s] += Σ_k θ[k, i] u_i[s − k]
            full = scipy.signal.oaconvolve(u[i][None, :], th[:, i, :].T, axes=1)
            z[:, first:] += full[:, : n - first]
        return z
    for k in range(L):
        lag = first + k
        if lag >= n:
            break
        z[:, lag:] += th[k].T @ u[:, : n - lag]
    return z


def solve_ls(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Least squares from the normal equations (Cholesky; minimum-norm if singular)."""
    try:
        c, low = scipy.linalg.cho_factor(A, lower=True, check_finite=False)
        X = scipy.linalg.cho_solve((c, low), B, check_finite=False)
        if np.all(np.isfinite(X)):
            return X
    except np.linalg.LinAlgError:
        pass
    return np.linalg.lstsq(A, B, rcond=None)[0]


def tc_prior(n_lags: int, n_in: int, lam: float) -> np.ndarray:
    """The TC prior ``P = K ⊗ I_{n_in}``, ``K[p, q] = λ^max(p,q)``."""
    p = np.arange(n_lags)
    return np.kron(lam ** np.maximum.outer(p, p), np.eye(n_in))


def tc_fit(A: np.ndarray, B: np.ndarray, c: np.ndarray, n_obs: int, n_in: int, dt: float,
           taus=TC_TAUS, gammas=TC_GAMMAS):
    """Kernel-regularized FIR with the TC prior, ``(τ, γ)`` by the marginal likelihood.

    ``−2 log p = Σ_l N log(σ̂_l²) + r·log det(I + RᵀAR/γ) + const`` with ``P = RRᵀ``,
    ``σ̂_l² = (c_l − b_lᵀθ_l)/N`` and ``θ = R (RᵀAR + γI)⁻¹ RᵀB`` (the posterior mean).

    Returns
    -------
    theta : (L·n_in, r) ndarray
    info : dict
        ``tau`` (s), ``gamma`` (relative), ``neg_log_likelihood``.
    """
    d = A.shape[0]
    L = d // n_in
    r = B.shape[1]
    best = None
    for tau in taus:
        lam = float(np.exp(-dt / tau))
        # P = K ⊗ I; K = λ^max(p,q) has the explicit Cholesky-like factor K = R_K R_Kᵀ with
        # R_K[p, q] = sqrt(λ^q − λ^(q+1)) for q ≥ p (last column sqrt(λ^(L−1)))
        w = lam ** np.arange(L)
        g = np.sqrt(np.append(w[:-1] - w[1:], w[-1]))
        RK = np.triu(np.ones((L, L))) * g[None, :]
        R = np.kron(RK, np.eye(n_in))
        M = R.T @ A @ R
        M = 0.5 * (M + M.T)
        s, V = np.linalg.eigh(M)
        s = np.clip(s, 0.0, None)
        scale = float(np.mean(s)) if np.mean(s) > 0 else 1.0
        W = V.T @ (R.T @ B)  # (d, r)
        for g_rel in gammas:
            gam = g_rel * scale
            quad = c - np.sum(W * W / (s + gam)[:, None], axis=0)
            quad = np.maximum(quad, 1e-300)
            nll = float(n_obs * np.sum(np.log(quad / n_obs)) + r * np.sum(np.log1p(s / gam)))
            if best is None or nll < best[0]:
                best = (nll, tau, g_rel, R, V, s, W, gam)
    assert best is not None  # the grid is never empty
    nll, tau, g_rel, R, V, s, W, gam = best
    theta = R @ (V @ (W / (s + gam)[:, None]))
    return theta, {"tau": tau, "gamma": g_rel, "neg_log_likelihood": nll}


def loeo_errors(grams, n_rows: int, solve=solve_ls) -> np.ndarray:
    """Leave-one-record-out relative errors ``‖ẑ − z‖/‖z‖`` (over all outputs) of each record,
    from the Grams alone, with the leading ``n_rows`` rows (a shorter lag length)."""
    if len(grams) < 2:
        raise InputError("leave-one-record-out needs at least 2 training records")
    k = n_rows
    A = sum(g[0][:k, :k] for g in grams)
    B = sum(g[1][:k] for g in grams)
    errs = []
    for Aj, Bj, cj in grams:
        Aj, Bj = Aj[:k, :k], Bj[:k]
        th = solve(A - Aj, B - Bj)
        e2 = float(np.sum(cj) - 2 * np.sum(th * Bj) + np.sum(th * (Aj @ th)))
        errs.append(np.sqrt(max(e2, 0.0) / float(np.sum(cj))))
    return np.array(errs)
