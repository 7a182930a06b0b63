"""Discrete convolution, convolution matrices and deconvolution solvers (§3.3, §3.5).

Convolution convention (Eq. 3.39, with the Δt factor kept; the dissertation's MATLAB drops
it, so its identified kernel is Δt times podbench's, with identical predictions)::

    v[s] = Δt Σ_{p=0}^{s} c[p] q[s−p],   s = 0 … n−1,

with sample ``j`` at ``t_j = j·Δt`` (index 0 is ``t = 0``). In matrix form ``v = Q̌ c`` with
the lower-triangular Toeplitz convolution matrix ``Q̌ = Δt·toeplitz(q)`` (Eq. 3.40).

Solvers
-------
A deconvolution solves ``A X ≈ B`` for ``X`` (``A`` is ``N × M``, usually square; ``B`` is
``N × r``). Solvers are looked up by name in a small registry so that structured or FFT
solvers can be added later without touching the methods::

    solve(A, B, solver="tls", rcond=1e-3)
    register_solver("mine", my_function)   # my_function(A, B, **options) -> X

Built in:

``"ls"``  :func:`least_squares`, the minimum-norm least-squares solution ``X = A⁺ B``
          (Eq. 3.76) computed by an SVD-based LAPACK driver; the dense reference.
``"tls"`` :func:`truncated_tls`, truncated total least squares (Eqs. 3.78–3.80, generalized
          to several right-hand sides), rank chosen by :func:`tls_rank`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence

import numpy as np
import scipy.linalg
import scipy.signal

from ._validation import as_finite_array, check_positive
from .errors import (
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
    "register_solver",
    "get_solver",
    "available_solvers",
    "DEFAULT_TLS_RCOND",
]

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
    return dt * scipy.signal.fftconvolve(c, q, mode="full", axes=-1)[..., :n]


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

    Returns
    -------
    (M,) or (M, r) ndarray
        All zeros (with a :class:`PodbenchWarning`) if no singular value is kept.
    """
    A, B, vector = _as_system(A, B)
    M, r = A.shape[1], B.shape[1]
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


# ----------------------------------------------------------------------- registry
_SOLVERS: dict[str, Callable[..., np.ndarray]] = {
    "ls": least_squares,
    "tls": truncated_tls,
}


def register_solver(name: str, func: Callable[..., np.ndarray], *, replace: bool = False):
    """Register a deconvolution solver ``func(A, B, **options) -> X`` under ``name``.

    ``A`` is ``(N, M)``, ``B`` is ``(N, r)``, ``X`` must be ``(M, r)``. Raises
    :class:`InputError` if the name is taken and ``replace`` is false.
    """
    if not isinstance(name, str) or not name:
        raise InputError(f"Parameter `name`: expected a non-empty string, got {name!r}")
    if not callable(func):
        raise InputError(f"Parameter `func`: expected a callable, got {func!r}")
    if name in _SOLVERS and not replace:
        raise InputError(f"Solver {name!r} is already registered (pass replace=True)")
    _SOLVERS[name] = func


def available_solvers() -> tuple[str, ...]:
    """Names of the registered deconvolution solvers."""
    return tuple(_SOLVERS)


def get_solver(name: str) -> Callable[..., np.ndarray]:
    """The solver registered under ``name`` (:class:`UnknownNameError` if none)."""
    try:
        return _SOLVERS[name]
    except (KeyError, TypeError):
        raise UnknownNameError(
            f"Parameter `solver`: unknown solver {name!r}; available: "
            f"{', '.join(map(repr, _SOLVERS))}"
        ) from None


def solve(A, B, solver: str = "ls", **options) -> np.ndarray:
    """Solve ``A X ≈ B`` with the named solver (``options`` are passed to it).

    Parameters
    ----------
    A : (N, M) array_like
    B : (N,) or (N, r) array_like
    solver : str
        A name from :func:`available_solvers` (``"ls"``, ``"tls"``, …).

    Returns
    -------
    (M,) or (M, r) ndarray
    """
    func = get_solver(solver)
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
