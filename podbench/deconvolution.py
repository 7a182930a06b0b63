"""Discrete convolution, convolution matrices and deconvolution solvers (§3.3, §3.5).

Convolution convention (Eq. 3.39, with the Δt factor kept; the dissertation's MATLAB drops
it, so its identified kernel is Δt times podbench's, with identical predictions)::

    v[s] = Δt Σ_{p=0}^{s} c[p] q[s−p],   s = 0 … n−1,

with sample ``j`` at ``t_j = j·Δt`` (index 0 is ``t = 0``). In matrix form ``v = Q̌ c`` with
the lower-triangular Toeplitz convolution matrix ``Q̌ = Δt·toeplitz(q)`` (Eq. 3.40).

Solvers
-------
A deconvolution solves ``A X ≈ B`` for ``X`` where ``A`` is the (block) convolution matrix of
Eq. 3.40 / 3.48 (``n_cases·n × k·n``, lower-triangular block Toeplitz) and ``B`` the stacked
scaled POC histories. :func:`deconvolve` takes the modal forces instead of ``A``::

    deconvolve(Q_list, B, dt, solver="block")          # SL/ML/MR call this
    solve(A, B, solver="tls", rcond=1e-3)               # dense solvers on a given matrix
    register_solver("mine", f)                          # f(A, B, **options) -> X
    register_solver("mine2", g, structured=True)        # g(Q_list, B, dt, **options) -> X

Dense (form ``A``; the reference, ``O((kn)³)`` time and ``O((kn)²)`` memory):

``"ls"``    :func:`least_squares`, minimum-norm least squares ``X = A⁺ B`` (Eq. 3.76) by an
            SVD-based LAPACK driver.
``"tls"``   :func:`truncated_tls`, truncated total least squares (Eqs. 3.78–3.80, several
            right-hand sides), rank by :func:`tls_rank`; refused above
            :data:`TLS_MAX_COLUMNS` columns.

Structured (never form ``A``):

``"block"`` :func:`block_substitution`, exact block forward substitution (divide and conquer
            with FFT updates, ``O(k³ n log² n)``) after shifting past leading zero force
            samples; equals ``"ls"`` when the load cases are as many as the modes and the
            first nonzero force sample is nonsingular; refuses ill-conditioned systems.
``"fft"``   :func:`fft_tikhonov`, per-frequency matrix deconvolution with Tikhonov
            regularization (circular: fast but biased by the record's truncation).
``"cgls"``  :func:`cgls_fft`, Tikhonov-regularized least squares on the exact system by
            conjugate gradients with FFT products and a circulant preconditioner; ``reg=0``
            is plain least squares (also over-determined ML).

The Tikhonov parameter of ``"fft"`` and ``"cgls"`` is chosen by generalized
cross-validation unless given (``reg="gcv"``, the default; :func:`gcv_regularization`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence

import numpy as np
import scipy.fft
import scipy.linalg

from ._validation import as_finite_array, check_positive
from .errors import (
    ConvergenceError,
    DimensionError,
    IllConditionedError,
    InputError,
    PodbenchWarning,
    UnknownNameError,
)

__all__ = [
    "convolution_matrix",
    "block_convolution_matrix",
    "convolve",
    "convolve_kernel",
    "least_squares",
    "truncated_tls",
    "tls_rank",
    "solve",
    "deconvolve",
    "convolution_product",
    "block_substitution",
    "fft_tikhonov",
    "cgls_fft",
    "register_solver",
    "get_solver",
    "available_solvers",
    "structured_solvers",
    "DEFAULT_TLS_RCOND",
    "DEFAULT_TIKHONOV_REG",
    "GCV_BOUNDS",
    "gcv_regularization",
    "TLS_MAX_COLUMNS",
    "DENSE_MAX_BYTES",
]

TLS_MAX_COLUMNS = 4096
"""Largest number of columns of ``[A | B]`` that :func:`truncated_tls` accepts by default.

Measured on the project machine (AMD EPYC, one BLAS thread): the economy SVD (``gesdd``) of a
square-ish matrix takes 4.6 s at 2000 columns, 15 s at 3000 and 41 s at 4000 (cubic growth;
about 140 s expected at ML's n = 1000, k = 6, i.e. 6006 columns), with peak memory about
seven matrices of that size (237 MB measured at 2000 × 2004). Beyond the limit it raises
:class:`InputError` suggesting a structured solver; ``max_columns=`` overrides it."""

DENSE_MAX_BYTES = 2**31
"""Largest dense convolution matrix (bytes, 2 GiB) that :func:`deconvolve` builds for a dense
solver (``"ls"``, ``"tls"``); beyond it :class:`InputError` suggests a structured solver.
Pass ``max_dense_bytes=`` as a solver option to override."""

DEFAULT_TLS_RCOND = 1e-3
"""Default relative singular-value cut of :func:`truncated_tls`: the MATLAB's ``tol = 1000``
(keep ``σ_1/σ_i ≤ 1000``) made a parameter."""


# ----------------------------------------------------------------------- convolution
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


# ----------------------------------------------------------------------- solvers
def _as_system(A, B):
    A = as_finite_array(A, "A", ndim=2)
    B = as_finite_array(B, "B")
    vector = B.ndim == 1
    if vector:
        B = B[:, None]
    if B.ndim != 2:
        raise DimensionError(f"Parameter `B`: expected a 1-D or 2-D array, got shape {B.shape}")
    if B.shape[0] != A.shape[0]:
        raise DimensionError(
            f"Parameter `B`: expected {A.shape[0]} rows to match `A` {A.shape}, got {B.shape}"
        )
    return A, B, vector


def least_squares(A, B, *, rcond: float | None = None) -> np.ndarray:
    """Minimum-norm least-squares solution ``X = A⁺ B`` (Eq. 3.76).

    Uses LAPACK ``gelsd`` (SVD based), so a singular but consistent system (e.g. a
    convolution matrix whose force starts with a zero sample) is solved exactly.

    Parameters
    ----------
    A : (N, M) array_like
    B : (N,) or (N, r) array_like
    rcond : float, optional
        Singular values ``σ_i ≤ rcond·σ_1`` are treated as zero. Default
        ``eps·max(N, M)`` (NumPy's default).

    Returns
    -------
    (M,) or (M, r) ndarray
    """
    A, B, vector = _as_system(A, B)
    if rcond is not None:
        rcond = check_positive(rcond, "rcond")
    X = np.linalg.lstsq(A, B, rcond=rcond)[0]
    return X[:, 0] if vector else X


def tls_rank(
    s,
    shape: tuple[int, int],
    n_unknowns: int,
    *,
    rcond: float | None = None,
    noise_level: float | None = None,
    rank: int | None = None,
) -> int:
    """Truncation rank ``p`` of the truncated TLS (number of right singular vectors kept).

    Exactly one rule applies (giving more than one is an error):

    * ``rank=p``: keep ``p`` directly;
    * ``noise_level=s_e``: keep ``σ_i > s_e (√N + √M')``, the expected largest singular
      value of an ``N × M'`` matrix of independent noise with standard deviation ``s_e``
      (``[A | B]`` is ``N × M'``); ``s_e`` is the noise per entry of ``[A | B]``, in their
      common units. Noise confined to Toeplitz structure has a somewhat larger edge
      (about ``√log N`` times), so treat this as a lower estimate;
    * ``rcond=ρ`` (default ``ρ = 1e-3``): keep ``σ_i ≥ ρ σ_1`` (the MATLAB's condition
      number limit ``σ_1/σ_i ≤ 1000`` made a parameter).

    The result is capped at ``n_unknowns`` (at least as many directions as right-hand
    sides must be discarded) and may be 0.

    Parameters
    ----------
    s : (q,) array_like
        Singular values of ``[A | B]``, non-increasing.
    shape : (int, int)
        Shape ``(N, M')`` of ``[A | B]``.
    n_unknowns : int
        ``M``, the number of columns of ``A``.
    """
    given = [x is not None for x in (rcond, noise_level, rank)]
    if sum(given) > 1:
        raise InputError(
            "Parameters `rcond`, `noise_level`, `rank`: give at most one truncation rule"
        )
    s = np.asarray(s, dtype=float)
    if rank is not None:
        p = check_positive(rank, "rank", integer=True, allow_zero=True)
    elif noise_level is not None:
        noise_level = check_positive(noise_level, "noise_level")
        edge = noise_level * (np.sqrt(shape[0]) + np.sqrt(shape[1]))
        p = int(np.count_nonzero(s > edge))
    else:
        rcond = DEFAULT_TLS_RCOND if rcond is None else check_positive(rcond, "rcond")
        if rcond >= 1:
            raise InputError(f"Parameter `rcond`: must be below 1, got {rcond!r}")
        p = int(np.count_nonzero(s >= rcond * s[0])) if s.size and s[0] > 0 else 0
    return int(min(p, n_unknowns, s.size))


def truncated_tls(
    A,
    B,
    *,
    rcond: float | None = None,
    noise_level: float | None = None,
    rank: int | None = None,
    max_columns: int | None = None,
) -> np.ndarray:
    """Truncated total least squares solution of ``A X ≈ B`` (Eqs. 3.77–3.80).

    With the SVD ``[A | B] = U_C Σ_C V_Cᵀ`` (Eqs. 3.78–3.79), ``p`` kept singular triplets
    (:func:`tls_rank`) and ``V_C`` partitioned as ``[[V11, V12], [V21, V22]]`` (``V11`` is
    ``M × p``; ``V21`` is ``r × p``; the second column block holds the discarded vectors)::

        X = −V12 V22⁺  =  V11 V21ᵀ (I_r − V21 V21ᵀ)⁺.

    For one right-hand side this is Eq. 3.80,
    ``x = Σ_{i≤p} V_{n+1,i} V_{1:n,i} / (1 − Σ_{i≤p} V_{n+1,i}²)``. The second form (used
    here) follows from the orthogonality of ``V_C`` and needs only the kept vectors, so an
    economy SVD suffices.

    Parameters
    ----------
    A : (N, M) array_like
        Data matrix (a convolution matrix of noisy forces).
    B : (N,) or (N, r) array_like
        Observations (noisy scaled POC histories).
    rcond, noise_level, rank
        Truncation rule, see :func:`tls_rank` (default ``rcond=1e-3``).
    max_columns : int, optional
        Size limit (default :data:`TLS_MAX_COLUMNS`): a ``[A | B]`` with more columns raises
        :class:`InputError` instead of starting an SVD of cubic cost.

    Returns
    -------
    (M,) or (M, r) ndarray
        All zeros (with a :class:`PodbenchWarning`) if no singular value is kept.
    """
    A, B, vector = _as_system(A, B)
    M, r = A.shape[1], B.shape[1]
    limit = TLS_MAX_COLUMNS if max_columns is None else check_positive(
        max_columns, "max_columns", integer=True)
    if M + r > limit:
        raise InputError(
            f"truncated_tls: [A | B] is {A.shape[0]} × {M + r}, above the dense TLS limit of "
            f"{limit} columns (an SVD of that size takes about 45 s and 1 GB here, growing "
            f"as the cube); use a structured solver ('block', exact; 'fft' or 'cgls', "
            f"Tikhonov-regularized), fewer samples or modes, or pass max_columns={M + r} to "
            "force the dense SVD"
        )
    Cmat = np.hstack([A, B])
    _, s, Vt = scipy.linalg.svd(Cmat, full_matrices=False, lapack_driver="gesdd")
    p = tls_rank(s, Cmat.shape, M, rcond=rcond, noise_level=noise_level, rank=rank)
    if p == 0:
        warnings.warn(
            "truncated_tls: no singular value above the truncation level; returning X = 0",
            PodbenchWarning,
            stacklevel=2,
        )
        X = np.zeros((M, r))
    else:
        V = Vt[:p].T  # (M + r) × p, the kept right singular vectors
        V11, V21 = V[:M], V[M:]
        G = np.eye(r) - V21 @ V21.T
        X = V11 @ V21.T @ np.linalg.pinv(G, hermitian=True)
    return X[:, 0] if vector else X


# ----------------------------------------------------------------------- structured solvers
def _forces(Q_list) -> np.ndarray:
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


def _structured_system(Q_list, B, dt):
    """Validate ``(Q_list, B, dt)`` and return the block-Toeplitz form of Eq. 3.48.

    Returns ``G`` (n, n_cases, k) with ``G[s, j, i] = ʲq_i[s]`` (lbf), ``Y`` (n, n_cases, r)
    with ``Y[s, j] = B[j·n + s]``, ``dt``, whether ``B`` was a vector and ``B`` as a 2-D
    array. The system is ``Y[s] = Δt Σ_{p≤s} G[s−p] X[p]`` with ``X[p]`` (k × r) the kernel
    at lag ``p`` (``X[p, i, l] = C̄[i·n + p, l]``).
    """
    dt = check_positive(dt, "dt")
    G = _forces(Q_list)
    n, n_cases, _ = G.shape
    B = as_finite_array(B, "B")
    vector = B.ndim == 1
    if vector:
        B = B[:, None]
    if B.ndim != 2 or B.shape[0] != n_cases * n or B.shape[1] == 0:
        raise DimensionError(
            f"Parameter `B`: expected {n_cases * n} rows (n_cases·n = {n_cases}·{n}), got "
            f"shape {B.shape}"
        )
    Y = np.ascontiguousarray(B.reshape(n_cases, n, B.shape[1]).transpose(1, 0, 2))
    return G, Y, dt, vector, B


def _unstack(X: np.ndarray, vector: bool) -> np.ndarray:
    """(n, k, r) kernel samples → C̄ (k·n, r) of Eq. 3.42 (or a vector)."""
    n, k, r = X.shape
    out = np.ascontiguousarray(X.transpose(1, 0, 2)).reshape(k * n, r)
    return out[:, 0] if vector else out


def _first_sample(G: np.ndarray, zero_tol: float) -> int:
    """Number ``d`` of leading force samples treated as zero (``‖G[s]‖ <= zero_tol·max‖G‖``)."""
    norms = np.sqrt(np.sum(G.reshape(G.shape[0], -1) ** 2, axis=1))
    gmax = float(norms.max())
    if gmax == 0:
        raise IllConditionedError(
            "Parameter `Q_list`: every modal force sample is zero; nothing to deconvolve"
        )
    return int(np.flatnonzero(norms > zero_tol * gmax)[0])


def _block_conv(G: np.ndarray, X: np.ndarray, n_fft: int | None = None) -> np.ndarray:
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
    G = _forces(Q_list)
    n, n_cases, k = G.shape
    vector = X.ndim == 1
    Xm = X[:, None] if vector else X
    if Xm.ndim != 2 or Xm.shape[0] != k * n:
        raise DimensionError(f"Parameter `X`: expected {k * n} rows (k·n), got {X.shape}")
    Xs = Xm.reshape(k, n, Xm.shape[1]).transpose(1, 0, 2)
    Y = dt * _block_conv(G, Xs)  # (n, n_cases, r)
    out = Y.transpose(1, 0, 2).reshape(n_cases * n, Xm.shape[1])
    return out[:, 0] if vector else out


def _forward_substitution(G: np.ndarray, Y: np.ndarray, leaf: int) -> np.ndarray:
    """Solve ``Σ_{p≤s} G[s−p] X[p] = Y[s]`` (s = 0 … n−1) for square invertible ``G[0]``.

    Divide and conquer: solve the first half, subtract its contribution to the second half
    with one FFT convolution, solve the second half; blocks of ``leaf`` samples are solved by
    plain block forward substitution. ``O(k²r n log² n)`` operations, ``O(k(k + r) n)``
    memory. The FFT of ``G[0 : 2h]`` is shared by every node of half-length ``h``.
    """
    n, k, _ = G.shape
    r = Y.shape[2]
    n_pad = leaf
    while n_pad < n:
        n_pad *= 2
    Gp = np.zeros((n_pad, k, k))
    Gp[:n] = G
    Yp = np.zeros((n_pad, k, r))
    Yp[:n] = Y
    X = np.zeros((n_pad, k, r))
    G0inv = np.linalg.inv(G[0])
    Gflip = Gp[leaf - 1 : 0 : -1] if leaf > 1 else Gp[:0]  # G[leaf−1], …, G[1]
    spectra: dict[int, np.ndarray] = {}

    def solve_leaf(lo: int) -> None:
        for t in range(leaf):
            rhs = Yp[lo + t]
            if t:
                # Σ_{p<t} G[t−p] X[lo+p]; Gflip[leaf−1−t:] is G[t], …, G[1]
                rhs = rhs - np.einsum("pij,pjr->ir", Gflip[leaf - 1 - t :], X[lo : lo + t])
            X[lo + t] = G0inv @ rhs

    def solve_range(lo: int, length: int) -> None:
        if length == leaf:
            solve_leaf(lo)
            return
        h = length // 2
        solve_range(lo, h)
        Gh = spectra.get(h)
        if Gh is None:
            Gh = spectra[h] = scipy.fft.rfft(Gp[: 2 * h], 2 * h, axis=0)
        # conv[t] = Σ_{p<h} G[t−p] X[lo+p] without wrap-around for t in [h, 2h)
        conv = scipy.fft.irfft(Gh @ scipy.fft.rfft(X[lo : lo + h], 2 * h, axis=0), 2 * h, axis=0)
        Yp[lo + h : lo + 2 * h] -= conv[h:]
        solve_range(lo + h, h)

    solve_range(0, n_pad)
    return X[:n]


def block_substitution(
    Q_list,
    B,
    dt: float,
    *,
    zero_tol: float = 0.0,
    max_cond: float = 1e8,
    max_growth: float = 1e8,
    leaf: int = 32,
) -> np.ndarray:
    """Exact structured solve of Eq. 3.43 / 3.48 by block forward substitution (``"block"``).

    Equals the dense minimum-norm least-squares solution (``"ls"``) whenever the load cases
    are as many as the modes and the first nonzero force sample ``G[d]`` is nonsingular
    (``G[s]`` is the ``n_cases × k`` matrix of modal-force samples at ``t_s``, row ``j`` =
    load case ``j``), without forming the ``n_cases·n × k·n`` matrix.

    **Leading zero samples (the guard on the first-sample matrix).** A podbench pulse starts
    at sample 1, so ``G[0] = 0`` and the diagonal block of Eq. 3.48 is singular. If the first
    ``d`` samples are zero (exactly, or ``‖G[s]‖_F <= zero_tol·max_s ‖G[s]‖_F``), the
    equations of samples ``0 … d−1`` contain no unknown and are dropped (their data are
    left as residual, as least squares does), the others are shifted by ``d``::

        Y[d + s] = Δt Σ_{p≤s} G[d + s − p] X[p],   s = 0 … n−d−1,

    a lower-triangular block-Toeplitz system with first block ``G[d]``, solved exactly; the
    last ``d`` lags ``X[n−d … n−1]`` never meet a nonzero force sample and are set to zero,
    the minimum-norm choice. With exact zeros (``zero_tol = 0``, the default) this *is* the
    dense minimum-norm solution; ``zero_tol > 0`` also drops small leading samples (e.g. the
    noise on a force's ``t = 0`` sample), a regularization that changes the problem.

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case (lbf); one (1, n) array for SL and MR.
    B : (n_cases·n,) or (n_cases·n, r) array_like
        Stacked scaled POC histories (in).
    dt : float
        Sampling interval Δt (s).
    zero_tol : float
        Relative size below which leading force samples count as zero (default 0: exact).
    max_cond : float
        :class:`IllConditionedError` if the condition number of ``G[d]`` exceeds it
        (default 1e8), e.g. load cases that do not start on the same sample.
    max_growth : float
        :class:`IllConditionedError` if ``‖A‖·‖X‖/‖B‖`` exceeds it (default 1e8,
        ``‖A‖`` bounded by ``Δt Σ_s ‖G[s]‖_F``): forward substitution amplified the data
        by more than that (a first force sample tiny compared with later ones, e.g. noise).
    leaf : int
        Samples per directly substituted block (default 32; affects speed only).

    Returns
    -------
    (k·n,) or (k·n, r) ndarray
        ``C̄`` (Eq. 3.42), as :func:`least_squares` on the dense matrix would return.
    """
    G, Y, dt, vector, _ = _structured_system(Q_list, B, dt)
    zero_tol = check_positive(zero_tol, "zero_tol", allow_zero=True)
    max_cond = check_positive(max_cond, "max_cond")
    max_growth = check_positive(max_growth, "max_growth")
    leaf = check_positive(leaf, "leaf", integer=True)
    n, n_cases, k = G.shape
    if n_cases != k:
        raise InputError(
            f"solver 'block': {n_cases} load case(s) for {k} mode(s); block forward "
            "substitution needs a square first-sample matrix (as many load cases as modes). "
            "Use 'cgls' (Tikhonov or plain least squares with FFT products) or 'ls' for "
            "an over-determined system"
        )
    d = _first_sample(G, zero_tol)
    sv = np.linalg.svd(G[d], compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
    if not cond <= max_cond:
        raise IllConditionedError(
            f"solver 'block': the first nonzero force-sample matrix G[{d}] (modal forces of "
            f"every load case at t = {d}·Δt) has condition number {cond:.3g} > max_cond = "
            f"{max_cond:g}; the load cases must start on the same sample with independent "
            "first samples. Use 'ls' (minimum-norm least squares) or a regularized solver "
            "('fft', 'cgls')"
        )
    r = Y.shape[2]
    X = np.zeros((n, k, r))
    with np.errstate(all="ignore"):
        X[: n - d] = _forward_substitution(G[d:], Y[d:], leaf) / dt
        norm_a = dt * float(np.sum(np.sqrt(np.sum(G.reshape(n, -1) ** 2, axis=1))))
        norm_y = float(np.linalg.norm(Y[d:]))
        norm_x = float(np.linalg.norm(X))
        growth = norm_a * norm_x / norm_y if norm_y > 0 else (0.0 if norm_x == 0 else np.inf)
    if not (np.isfinite(growth) and growth <= max_growth):
        ratio = sv[-1] / np.sqrt(np.max(np.sum(G.reshape(n, -1) ** 2, axis=1)))
        how = f"by {growth:.3g}" if np.isfinite(growth) else "until it overflowed"
        raise IllConditionedError(
            f"solver 'block': forward substitution amplified the data {how} "
            f"(‖A‖‖X‖/‖B‖ > max_growth = {max_growth:g}): the triangular system is "
            f"ill-conditioned (smallest singular value of the first force sample G[{d}] is "
            f"{ratio:.3g} of the largest sample). With noisy forces use a regularized solver "
            "('fft' or 'cgls', Tikhonov; 'tls') or zero_tol to "
            "skip near-zero leading samples"
        )
    return _unstack(X, vector)


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


def _circulant_spectrum(Gh: np.ndarray, Yh: np.ndarray, N: int):
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
    pad = check_positive(pad, "pad")
    if pad < 1:
        raise InputError(f"Parameter `pad`: must be >= 1, got {pad!r}")
    d = _first_sample(G, 0.0)
    m = G.shape[0] - d
    return d, m, scipy.fft.next_fast_len(max(int(np.ceil(pad * m)), 1), real=True)


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
    G, Y, dt, _, _ = _structured_system(Q_list, B, dt)
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


def _tikhonov_reg(reg, allow_zero: bool):
    """Validate ``reg``: ``"gcv"`` or a number (> 0, or >= 0 if ``allow_zero``)."""
    if isinstance(reg, str):
        if reg != "gcv":
            raise InputError(f"Parameter `reg`: expected a number or \"gcv\", got {reg!r}")
        return reg
    return check_positive(reg, "reg", allow_zero=allow_zero)


def _spectral_norm(Gh: np.ndarray) -> float:
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
    G, Y, dt, vector, _ = _structured_system(Q_list, B, dt)
    reg = _tikhonov_reg(reg, allow_zero=False)
    n, _, k = G.shape
    r = Y.shape[2]
    d, m, N = _embedding(G, pad)
    Gh = dt * scipy.fft.rfft(G[d:], N, axis=0)  # (F, n_cases, k)
    Yh = scipy.fft.rfft(Y[d:], N, axis=0)  # (F, n_cases, r)
    if reg == "gcv":
        reg = _gcv_minimize(*_circulant_spectrum(Gh, Yh, N), N, G.shape[1])
    lam2 = (reg * _spectral_norm(Gh)) ** 2
    GH = np.conj(Gh).transpose(0, 2, 1)
    Xh = np.linalg.solve(GH @ Gh + lam2 * np.eye(k), GH @ Yh)
    X = np.zeros((n, k, r))
    X[:m] = scipy.fft.irfft(Xh, N, axis=0)[:m]
    return _unstack(X, vector)


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
    G, Y, dt, vector, _ = _structured_system(Q_list, B, dt)
    reg = _tikhonov_reg(reg, allow_zero=True)
    tol = check_positive(tol, "tol")
    n, n_cases, k = G.shape
    r = Y.shape[2]
    max_iter = 1000 if max_iter is None else check_positive(max_iter, "max_iter", integer=True)
    # shift past leading zero samples (their equations and the last d lags drop out exactly;
    # without the shift the preconditioner would fill the last lags' null space)
    d = _first_sample(G, 0.0)
    n_full = n
    G, Y, n = G[d:], Y[d:], n - d
    N = scipy.fft.next_fast_len(2 * n - 1, real=True)
    Gh = dt * scipy.fft.rfft(G, N, axis=0)  # (F, n_cases, k)
    GhT = np.ascontiguousarray(Gh.transpose(0, 2, 1))  # transform of G[s]ᵀ (no conjugate)
    GhH_Gh = GhT.conj() @ Gh
    smax = _spectral_norm(Gh)

    def A(X):  # (n, k, r) → (n, n_cases, r)
        return scipy.fft.irfft(Gh @ scipy.fft.rfft(X, N, axis=0), N, axis=0)[:n]

    def At(Z):  # (n, n_cases, r) → (n, k, r); (Aᵀz)[p] = Δt Σ_{s≥p} G[s−p]ᵀ z[s]
        return scipy.fft.irfft(GhT @ scipy.fft.rfft(Z[::-1], N, axis=0), N, axis=0)[:n][::-1]

    def colnorm2(X):
        return np.sum(X * X, axis=(0, 1))

    def coldot(X, Z):
        return np.sum(X * Z, axis=(0, 1))

    AtY = At(Y)

    def solve(reg_value: float, X0=None, limit: int = max_iter):
        """CGLS for one λ (warm start ``X0``, at most ``limit`` iterations); returns ``X`` or
        raises ConvergenceError."""
        limit = min(limit, max_iter)
        lam2 = (reg_value * smax) ** 2
        # preconditioner: the same Tikhonov operator for the circulant embedding of A,
        # inverted per frequency (it differs from AᵀA + λ²I by a term of the rank of the
        # force's support)
        mu2 = lam2 if lam2 > 0 else (1e-6 * smax) ** 2
        Minv = np.linalg.inv(GhH_Gh + mu2 * np.eye(k))  # (F, k, k) Hermitian

        def precond(Z):
            return scipy.fft.irfft(Minv @ scipy.fft.rfft(Z, N, axis=0), N, axis=0)[:n]

        if X0 is None:
            X = np.zeros((n, k, r))
            R = AtY.copy()  # residual of the regularized normal equations
        else:
            X = X0.copy()
            R = AtY - At(A(X)) - lam2 * X
        Z = precond(R)
        P = Z.copy()
        rho = coldot(R, Z)
        r0 = colnorm2(AtY)
        stop = (tol**2) * r0
        active = colnorm2(R) > stop
        it = 0
        while np.any(active):
            if it == limit:
                rel = float(np.sqrt(np.max(colnorm2(R)[active] / r0[active])))
                raise ConvergenceError(
                    f"solver 'cgls': no convergence in {limit} iterations (relative "
                    f"normal-equation residual {rel:.3g} > tol = {tol:g}, reg = "
                    f"{reg_value:.3g}); the system is ill-conditioned: use 'block' (exact) or "
                    "a larger reg"
                )
            Qp = At(A(P)) + lam2 * P
            pq = coldot(P, Qp)
            alpha = np.where(active, rho / np.where(pq > 0, pq, 1.0), 0.0)
            X += alpha * P
            R -= alpha * Qp
            Z = precond(R)
            rho_new = coldot(R, Z)
            beta = np.where(active, rho_new / np.where(rho != 0, rho, 1.0), 0.0)
            P = np.where(active, Z + beta * P, 0.0)
            rho = np.where(active, rho_new, rho)
            active = active & (colnorm2(R) > stop)
            it += 1
        return X

    if reg == "gcv":
        spectrum = _circulant_spectrum(Gh, scipy.fft.rfft(Y, N, axis=0), N)
        X = _gcv_exact(solve, lambda X: float(np.sum((Y - A(X)) ** 2)), *spectrum, N, n_cases,
                       n, min(TRIAL_ITER, max_iter))
    else:
        X = solve(reg)
    return _unstack(np.concatenate([X, np.zeros((n_full - n, k, r))]), vector)


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
    flat within half a decade of the optimum. Returns its solution ``X``."""
    lo, hi = GCV_BOUNDS
    smax = float(s.max())
    n_data = n * n_cases

    def trace(reg):
        phi = s**2 / (s**2 + (reg * smax) ** 2)
        return n / N * float(np.sum(w[:, None] * phi))

    cache: dict[float, tuple[float, np.ndarray]] = {}

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
    return min(cache.values(), key=lambda c: c[0])[1]


# ----------------------------------------------------------------------- registry
_SOLVERS: dict[str, Callable[..., np.ndarray]] = {
    "ls": least_squares,
    "tls": truncated_tls,
}
_STRUCTURED: dict[str, Callable[..., np.ndarray]] = {
    "block": block_substitution,
    "fft": fft_tikhonov,
    "cgls": cgls_fft,
}


def register_solver(name: str, func: Callable[..., np.ndarray], *, replace: bool = False,
                    structured: bool = False):
    """Register a deconvolution solver under ``name``.

    A dense solver (default) is ``func(A, B, **options) -> X`` with ``A`` ``(N, M)``, ``B``
    ``(N, r)`` and ``X`` ``(M, r)``. A structured solver (``structured=True``) is
    ``func(Q_list, B, dt, **options) -> X`` with the arguments of :func:`deconvolve` and the
    same result as a dense solver on ``block_convolution_matrix(Q_list, dt)``. Raises
    :class:`InputError` if the name is taken and ``replace`` is false.
    """
    if not isinstance(name, str) or not name:
        raise InputError(f"Parameter `name`: expected a non-empty string, got {name!r}")
    if not callable(func):
        raise InputError(f"Parameter `func`: expected a callable, got {func!r}")
    if (name in _SOLVERS or name in _STRUCTURED) and not replace:
        raise InputError(f"Solver {name!r} is already registered (pass replace=True)")
    _SOLVERS.pop(name, None)
    _STRUCTURED.pop(name, None)
    (_STRUCTURED if structured else _SOLVERS)[name] = func


def available_solvers() -> tuple[str, ...]:
    """Names of the registered deconvolution solvers (dense first, then structured)."""
    return tuple(_SOLVERS) + tuple(_STRUCTURED)


def structured_solvers() -> tuple[str, ...]:
    """Names of the registered structured solvers (used through :func:`deconvolve` only)."""
    return tuple(_STRUCTURED)


def get_solver(name: str) -> Callable[..., np.ndarray]:
    """The solver registered under ``name`` (:class:`UnknownNameError` if none)."""
    try:
        return _SOLVERS[name] if name in _SOLVERS else _STRUCTURED[name]
    except (KeyError, TypeError):
        raise UnknownNameError(
            f"Parameter `solver`: unknown solver {name!r}; available: "
            f"{', '.join(map(repr, available_solvers()))}"
        ) from None


def solve(A, B, solver: str = "ls", **options) -> np.ndarray:
    """Solve ``A X ≈ B`` with the named dense solver (``options`` are passed to it).

    Parameters
    ----------
    A : (N, M) array_like
    B : (N,) or (N, r) array_like
    solver : str
        A dense solver name (``"ls"``, ``"tls"``, …). Structured solvers need the Toeplitz
        form, not a matrix: use :func:`deconvolve`.

    Returns
    -------
    (M,) or (M, r) ndarray
    """
    if isinstance(solver, str) and solver in _STRUCTURED:
        raise UnknownNameError(
            f"Parameter `solver`: unknown solver {solver!r} for a dense matrix (it is a "
            f"structured solver: use deconvolve(Q_list, B, dt, solver={solver!r})); dense "
            f"solvers: {', '.join(map(repr, _SOLVERS))}"
        )
    func = _SOLVERS.get(solver) if isinstance(solver, str) else None
    if func is None:
        get_solver(solver)  # raises UnknownNameError
    X = func(A, B, **options)
    X = np.asarray(X, dtype=float)
    expected = (np.shape(A)[1],) + tuple(np.shape(B)[1:])
    if X.shape != expected:
        raise DimensionError(
            f"Solver {solver!r} returned shape {X.shape}, expected {expected}"
        )
    if not np.all(np.isfinite(X)):
        raise IllConditionedError(f"Solver {solver!r} returned NaN or Inf")
    return X


def deconvolve(Q_list, B, dt: float, solver: str = "ls", **options) -> np.ndarray:
    """Solve the (block) convolution system of Eq. 3.43 / 3.48 with the named solver.

    ``B ≈ block_convolution_matrix(Q_list, dt) @ X`` for the stacked kernel ``X = C̄``
    (Eq. 3.42). Dense solvers (``"ls"``, ``"tls"``) form the matrix (refused above
    ``max_dense_bytes``, default :data:`DENSE_MAX_BYTES`) and call :func:`solve`; structured
    solvers (``"block"``, ``"fft"``, ``"cgls"``) work on the modal forces directly and never
    form it.

    Parameters
    ----------
    Q_list : sequence of (k, n) array_like
        Modal forces of each load case (lbf); for a scalar deconvolution (SL, MR) one
        ``(1, n)`` array.
    B : (n_cases·n,) or (n_cases·n, r) array_like
        Stacked scaled POC histories (in): rows ``j·n … j·n+n−1`` are load case ``j``.
    dt : float
        Sampling interval Δt (s).
    solver : str
        Name from :func:`available_solvers`.
    **options
        Solver options; dense solvers also take ``max_dense_bytes``.

    Returns
    -------
    (k·n,) or (k·n, r) ndarray
        ``C̄``: row ``i·n + p`` holds the lag-``p`` kernel ``c_li[p]`` for every column ``l``
        (in/(lbf·s)).
    """
    func = get_solver(solver)
    G, Y, dt, vector, B2 = _structured_system(Q_list, B, dt)
    n, n_cases, k = G.shape
    Qs = [G[:, j, :].T for j in range(n_cases)]
    if solver in _SOLVERS:
        limit = check_positive(options.pop("max_dense_bytes", DENSE_MAX_BYTES),
                               "max_dense_bytes")
        size = 8.0 * (n_cases * n) * (k * n)
        if size > limit:
            raise InputError(
                f"solver {solver!r}: the dense convolution matrix would be {n_cases * n} × "
                f"{k * n} ({size / 2**30:.3g} GiB > max_dense_bytes = {limit / 2**30:.3g} "
                "GiB; its pseudo-inverse costs O((k·n)³)); use a structured solver: 'block' "
                "(exact), 'fft' or 'cgls' (Tikhonov-regularized)"
            )
        return solve(block_convolution_matrix(Qs, dt), B2[:, 0] if vector else B2, solver,
                     **options)
    X = np.asarray(func(Qs, B2[:, 0] if vector else B2, dt, **options), dtype=float)
    expected = (k * n,) + (() if vector else (B2.shape[1],))
    if X.shape != expected:
        raise DimensionError(f"Solver {solver!r} returned shape {X.shape}, expected {expected}")
    if not np.all(np.isfinite(X)):
        raise IllConditionedError(f"Solver {solver!r} returned NaN or Inf")
    return X
