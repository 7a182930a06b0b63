"""Discrete convolution and the convolution matrices of §3.3 (Eqs. 3.39, 3.40, 3.48).

Convolution convention (Eq. 3.39, with the Δt factor kept; the dissertation's MATLAB drops
it, so its identified kernel is Δt times podbench's, with identical predictions)::

    v[s] = Δt Σ_{p=0}^{s} c[p] q[s−p],   s = 0 … n−1,

with sample ``j`` at ``t_j = j·Δt`` (index 0 is ``t = 0``). In matrix form ``v = Q̌ c`` with
the lower-triangular Toeplitz convolution matrix ``Q̌ = Δt·toeplitz(q)`` (Eq. 3.40).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.fft
import scipy.linalg

from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError

__all__ = [
    "convolution_matrix",
    "block_convolution_matrix",
    "convolve",
    "convolve_kernel",
    "convolution_product",
]


def convolution_matrix(q, dt: float) -> np.ndarray:
    """Convolution matrix of a sampled signal (Eq. 3.40).

    Parameters
    ----------
    q : (n,) array_like
        Sampled signal, e.g. a modal force (lbf), sample 0 at ``t = 0``.
    dt : float
        Sampling interval Δt (s), > 0.

    Returns
    -------
    (n, n) ndarray
        ``Δt·T`` with ``T[s, p] = q[s − p]`` for ``p ≤ s`` and 0 above the diagonal, so that
        ``convolution_matrix(q, dt) @ c`` is Eq. 3.39.
    """
    q = as_finite_array(q, "q", ndim=1)
    dt = check_positive(dt, "dt")
    if q.size == 0:
        raise InputError("Parameter `q`: empty signal")
    return dt * scipy.linalg.toeplitz(q, np.zeros_like(q))


def block_convolution_matrix(Q_list: Sequence, dt: float) -> np.ndarray:
    """Block convolution matrix of several load cases (Eq. 3.48).

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case ``j`` (row ``i`` is ``ʲq_i = u_iᵀ ʲF``, Eq. 3.47).
    dt : float
        Sampling interval Δt (s), > 0.

    Returns
    -------
    (n_cases·n, k·n) ndarray
        Block ``(j, i)`` is ``convolution_matrix(ʲq_i, dt)``. With ``C̄`` (``k·n × k``, block
        ``i`` of column ``l`` holding ``c_{li}``, Eq. 3.42) the product is the stacked scaled
        POC histories ``[V̂; ²V̂; …]`` (each ``n × k``).
    """
    dt = check_positive(dt, "dt")
    if len(Q_list) == 0:
        raise InputError("Parameter `Q_list`: no load case given")
    Qs = [as_finite_array(Q, f"Q_list[{j}]", ndim=2) for j, Q in enumerate(Q_list)]
    k, n = Qs[0].shape
    for j, Q in enumerate(Qs):
        if Q.shape != (k, n):
            raise DimensionError(
                f"Parameter `Q_list[{j}]`: expected shape {(k, n)} like `Q_list[0]`, "
                f"got {Q.shape}"
            )
    out = np.zeros((len(Qs) * n, k * n))
    for j, Q in enumerate(Qs):
        for i in range(k):
            out[j * n : (j + 1) * n, i * n : (i + 1) * n] = convolution_matrix(Q[i], dt)
    return out


def convolve(c, q, dt: float) -> np.ndarray:
    """Truncated causal convolution ``Δt Σ_p c[p] q[s−p]`` along the last axis (Eq. 3.39).

    Computed by FFT without forming a matrix; leading axes broadcast.

    Parameters
    ----------
    c : (..., n_c) array_like
        Kernel (e.g. a diagonal modal impulse response ``c_ii``), ``n_c ≥ n``.
    q : (..., n) array_like
        Signal (e.g. a modal force, lbf).
    dt : float
        Sampling interval Δt (s).

    Returns
    -------
    (..., n) ndarray
        Same number of samples as ``q``.
    """
    c = as_finite_array(c, "c")
    q = as_finite_array(q, "q")
    dt = check_positive(dt, "dt")
    if c.ndim == 0 or q.ndim == 0:
        raise DimensionError("Parameters `c`, `q`: expected arrays with a time axis")
    n = q.shape[-1]
    if c.shape[-1] < n:
        raise DimensionError(
            f"Parameter `q`: {n} samples but the kernel `c` has only {c.shape[-1]}; a "
            "kernel identified from n samples predicts at most n samples"
        )
    c = c[..., :n]
    lead = np.broadcast_shapes(c.shape[:-1], q.shape[:-1])
    c = np.broadcast_to(c, lead + (n,))
    q = np.broadcast_to(q, lead + (n,))
    if n == 1:
        return dt * c * q
    N = scipy.fft.next_fast_len(2 * n - 1, real=True)  # no wrap-around within n samples
    full = scipy.fft.irfft(scipy.fft.rfft(c, N, axis=-1) * scipy.fft.rfft(q, N, axis=-1), N,
                           axis=-1)
    return dt * full[..., :n]


def convolve_kernel(C, q, dt: float) -> np.ndarray:
    """Matrix-vector convolution ``v_l = Σ_i c_{li} * q_i`` (Eqs. 3.34, 3.36, 3.49).

    Parameters
    ----------
    C : (k_out, k_in, n_c) array_like
        Kernel ``C(t_s) = C[:, :, s]``.
    q : (k_in, n) array_like
        Modal forces.
    dt : float
        Sampling interval Δt (s).

    Returns
    -------
    (k_out, n) ndarray
    """
    C = as_finite_array(C, "C", ndim=3)
    q = as_finite_array(q, "q", ndim=2)
    if C.shape[1] != q.shape[0]:
        raise DimensionError(
            f"Parameter `q`: expected {C.shape[1]} rows to match the kernel {C.shape}, "
            f"got {q.shape}"
        )
    return convolve(C, q[None, :, :], dt).sum(axis=1)


def force_blocks(Q_list) -> np.ndarray:
    """Validate the modal forces and return ``G`` (n, n_cases, k), ``G[s, j, i] = ʲq_i[s]``."""
    if isinstance(Q_list, np.ndarray) and Q_list.ndim == 2:
        Q_list = [Q_list]
    try:
        n_cases = len(Q_list)
    except TypeError:
        raise InputError(
            f"Parameter `Q_list`: expected a sequence of (k, n) arrays, got {Q_list!r}"
        ) from None
    if n_cases == 0:
        raise InputError("Parameter `Q_list`: no load case given")
    Qs = [as_finite_array(Q, f"Q_list[{j}]", ndim=2) for j, Q in enumerate(Q_list)]
    k, n = Qs[0].shape
    if n == 0 or k == 0:
        raise DimensionError(f"Parameter `Q_list[0]`: empty modal forces, shape {(k, n)}")
    for j, Q in enumerate(Qs):
        if Q.shape != (k, n):
            raise DimensionError(
                f"Parameter `Q_list[{j}]`: expected shape {(k, n)} like `Q_list[0]`, "
                f"got {Q.shape}"
            )
    return np.ascontiguousarray(np.stack(Qs).transpose(2, 0, 1))


def block_conv(G: np.ndarray, X: np.ndarray, n_fft: int | None = None) -> np.ndarray:
    """``Σ_{p≤s} G[s−p] X[p]`` for s < len(G) (no Δt), by FFT."""
    n = G.shape[0]
    N = n_fft or scipy.fft.next_fast_len(2 * n - 1, real=True)
    Gh = scipy.fft.rfft(G, N, axis=0)
    Xh = scipy.fft.rfft(X, N, axis=0)
    return scipy.fft.irfft(Gh @ Xh, N, axis=0)[:n]


def convolution_product(Q_list, X, dt: float) -> np.ndarray:
    """``block_convolution_matrix(Q_list, dt) @ X`` without forming the matrix (FFT).

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case (lbf), as for :func:`block_convolution_matrix`.
    X : (k·n,) or (k·n, r) array_like
        Stacked kernel ``C̄`` (Eq. 3.42).
    dt : float
        Sampling interval Δt (s).

    Returns
    -------
    (n_cases·n,) or (n_cases·n, r) ndarray
        The stacked scaled POC histories of Eq. 3.48.
    """
    X = as_finite_array(X, "X")
    dt = check_positive(dt, "dt")
    G = force_blocks(Q_list)
    n, n_cases, k = G.shape
    vector = X.ndim == 1
    Xm = X[:, None] if vector else X
    if Xm.ndim != 2 or Xm.shape[0] != k * n:
        raise DimensionError(f"Parameter `X`: expected {k * n} rows (k·n), got {X.shape}")
    Xs = Xm.reshape(k, n, Xm.shape[1]).transpose(1, 0, 2)
    Y = dt * block_conv(G, Xs)  # (n, n_cases, r)
    out = Y.transpose(1, 0, 2).reshape(n_cases * n, Xm.shape[1])
    return out[:, 0] if vector else out

