"""The one preconditioned conjugate-gradient core of the structured solvers (``"cgls"``,
``"stls"`` through it, ``"kernel"``) and the FFT products with the convolution operator.

Both solve regularized normal equations ``(AᵀA + Λ) X = AᵀB`` column by column (``Λ`` a
scalar ``λ²`` or one ``γ_l`` per column), every column of ``B`` at once; a column stops when
its residual falls to ``tol`` times its initial norm.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.fft

__all__ = ["fft_operators", "coldot", "pcg"]


def fft_operators(Gh: np.ndarray, N: int, n: int):
    """``(A, At, GhT)``: the products with the (block) convolution operator and its
    transpose by FFTs of length ``N`` from its transform ``Gh`` (``(F, n_cases, k)``);
    ``A``: ``(n, k, r) → (n, n_cases, r)``, ``At``: ``(Aᵀz)[p] = Σ_{s≥p} Ĝ[s−p]ᵀ z[s]``;
    ``GhT`` the transform of ``G[s]ᵀ`` (no conjugate)."""
    GhT = np.ascontiguousarray(Gh.transpose(0, 2, 1))

    def A(X):
        return scipy.fft.irfft(Gh @ scipy.fft.rfft(X, N, axis=0), N, axis=0)[:n]

    def At(Z):
        return scipy.fft.irfft(GhT @ scipy.fft.rfft(Z[::-1], N, axis=0), N, axis=0)[:n][::-1]

    return A, At, GhT


def coldot(X: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """Column inner products ``Σ X·Z`` over the first two axes (one per column of ``B``)."""
    return np.sum(X * Z, axis=(0, 1))


Operator = Callable[[np.ndarray], np.ndarray]


def pcg(normal: Operator, precond: Operator, X: np.ndarray, R: np.ndarray, stop: np.ndarray,
        limit: int):
    """Preconditioned conjugate gradients on ``normal(X) = rhs`` for every column.

    Parameters
    ----------
    normal, precond : callable
        The (symmetric positive definite) operator and the preconditioner, ``(n, k, r)``
        arrays in and out.
    X, R : (n, k, r) ndarray
        Start and its residual ``rhs − normal(X)`` (both updated in place).
    stop : (r,) ndarray
        A column is done when ``‖R‖² <= stop``.
    limit : int
        Iteration limit.

    Returns
    -------
    X, R : ndarray
    iterations : int
    active : (r,) bool ndarray
        The columns not converged (all False on convergence).
    """
    Z = precond(R)
    P = Z.copy()
    rho = coldot(R, Z)
    active = coldot(R, R) > stop
    it = 0
    while np.any(active) and it < limit:
        Qp = normal(P)
        pq = coldot(P, Qp)
        alpha = np.where(active, rho / np.where(active & (pq > 0), pq, 1.0), 0.0)
        X += alpha * P
        R -= alpha * Qp
        Z = precond(R)
        rho_new = coldot(R, Z)
        beta = np.where(active, rho_new / np.where(rho != 0, rho, 1.0), 0.0)
        P = np.where(active, Z + beta * P, 0.0)
        rho = np.where(active, rho_new, rho)
        active = active & (coldot(R, R) > stop)
        it += 1
    return X, R, it, active
