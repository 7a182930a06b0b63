"""Dense solvers: form ``A`` (the reference, ``O((kn)³)`` time, ``O((kn)²)`` memory).

``"ls"``    :class:`LeastSquares` / :func:`least_squares`, minimum-norm least squares
            ``X = A⁺ B`` (Eq. 3.76) by an SVD-based LAPACK driver.
``"tls"``   :class:`TruncatedTLS` / :func:`truncated_tls`, truncated total least squares
            (Eqs. 3.78–3.80, several right-hand sides), rank by :func:`tls_rank`; refused
            above :data:`TLS_MAX_COLUMNS` columns.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg

from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError, PodbenchWarning
from podbench.sysid.deconvolution._base import (
    Solver,
    SolverResult,
    checked_solution,
    full_info,
    relative_residual,
)
from podbench.sysid.deconvolution.system import DENSE_MAX_BYTES, ConvolutionSystem
from podbench.sysid.params import COUNT, FRACTION, POSITIVE, Boolean, Interval, Options

__all__ = [
    "DenseSolver",
    "LeastSquares",
    "TruncatedTLS",
    "least_squares",
    "truncated_tls",
    "tls_rank",
    "TLS_MAX_COLUMNS",
    "DEFAULT_TLS_RCOND",
]

TLS_MAX_COLUMNS = 4096
"""Largest number of columns of ``[A | B]`` that :func:`truncated_tls` accepts by default.

Measured on the project machine (AMD EPYC, one BLAS thread): the economy SVD (``gesdd``) of a
square-ish matrix takes 4.6 s at 2000 columns, 15 s at 3000 and 41 s at 4000 (cubic growth;
about 140 s expected at ML's n = 1000, k = 6, i.e. 6006 columns), with peak memory about
seven matrices of that size (237 MB measured at 2000 × 2004). Beyond the limit it raises
:class:`InputError` suggesting a structured solver; ``max_columns=`` overrides it."""

DEFAULT_TLS_RCOND = 1e-3
"""Default relative singular-value cut of :func:`truncated_tls`: the MATLAB's ``tol = 1000``
(keep ``σ_1/σ_i ≤ 1000``) made a parameter."""


# ----------------------------------------------------------------------- matrix solvers
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


def _lstsq(A: np.ndarray, B: np.ndarray, rcond: float | None):
    """``X = A⁺ B`` by ``gelsd`` with its diagnostics (``B`` 2-D, ``rcond`` validated)."""
    X, _, rank, s = np.linalg.lstsq(A, B, rcond=rcond)
    used = float(np.finfo(float).eps * max(A.shape)) if rcond is None else rcond
    cond = float(s[0] / s[-1]) if s.size and s[-1] > 0 else float("inf")
    return X, {"rank": int(rank), "rcond": used, "condition": cond}


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
    X = _lstsq(A, B, rcond)[0]
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
    * ``rank="gap"``: keep the ``p`` before the largest gap ``σ_p/σ_{p+1}`` of the spectrum
      (``p ≤ n_unknowns``; a rule from the data, no level to choose);
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
    _check_rule(rcond, noise_level, rank)
    s = np.asarray(s, dtype=float)
    if isinstance(rank, str):
        p = _gap_rank(s, n_unknowns, rank)
    elif rank is not None:
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


def _gap_rank(s: np.ndarray, n_unknowns: int, rule: str) -> int:
    """Rank before the largest ratio ``σ_p/σ_{p+1}`` (``1 ≤ p ≤ n_unknowns``)."""
    if rule != "gap":
        raise InputError(f"Parameter `rank`: expected an integer or 'gap', got {rule!r}")
    q = min(n_unknowns, s.size - 1)
    if q < 1 or s[0] <= 0:
        return int(min(n_unknowns, s.size))
    floor = np.finfo(float).eps * s[0] * max(s.size, 1)
    ratios = np.maximum(s[:q], floor) / np.maximum(s[1:q + 1], floor)
    return int(np.argmax(ratios)) + 1


def _check_rule(rcond, noise_level, rank) -> None:
    if sum(x is not None for x in (rcond, noise_level, rank)) > 1:
        raise InputError(
            "Parameters `rcond`, `noise_level`, `rank`: give at most one truncation rule"
        )


def _tls_limit(max_columns) -> int:
    if max_columns is None:
        return TLS_MAX_COLUMNS
    return check_positive(max_columns, "max_columns", integer=True)


def _check_tls_size(N: int, M: int, r: int, limit: int) -> None:
    if M + r > limit:
        raise InputError(
            f"truncated_tls: [A | B] is {N} × {M + r}, above the dense TLS limit of "
            f"{limit} columns (an SVD of that size takes about 45 s and 1 GB here, growing "
            f"as the cube); use a structured solver ('block', exact; 'fft' or 'cgls', "
            f"Tikhonov-regularized), fewer samples or modes, or pass max_columns={M + r} to "
            "force the dense SVD"
        )


def _column_scales(A: np.ndarray) -> np.ndarray:
    """Column 2-norms of ``A`` (1 for a zero column)."""
    s = np.linalg.norm(A, axis=0)
    return np.where(s > 0, s, 1.0)


def _tls(A, B, rcond, noise_level, rank, scale=False):
    """Truncated TLS of :func:`truncated_tls` (``B`` 2-D) with its diagnostics; ``scale``
    equilibrates the columns of ``A`` and of ``B`` first (undone on ``X``)."""
    if scale:
        da, db = _column_scales(A), _column_scales(B)
        X, info = _tls(A / da, B / db, rcond, noise_level, rank)
        return X / da[:, None] * db[None, :], {**info, "scaled": True}
    M, r = A.shape[1], B.shape[1]
    Cmat = np.hstack([A, B])
    _, s, Vt = scipy.linalg.svd(Cmat, full_matrices=False, lapack_driver="gesdd")
    p = tls_rank(s, Cmat.shape, M, rcond=rcond, noise_level=noise_level, rank=rank)
    info = {
        "rank": p,
        "rank_rule": (rank if isinstance(rank, str) else "rank" if rank is not None else
                      "noise_level" if noise_level is not None else "rcond"),
        "rcond": (DEFAULT_TLS_RCOND if rcond is None else float(rcond))
        if rank is None and noise_level is None else None,
        "condition": float(s[0] / s[p - 1]) if p > 0 else None,
    }
    if p == 0:
        warnings.warn(
            "truncated_tls: no singular value above the truncation level; returning X = 0",
            PodbenchWarning,
            stacklevel=3,
        )
        X = np.zeros((M, r))
    else:
        V = Vt[:p].T  # (M + r) × p, the kept right singular vectors
        V11, V21 = V[:M], V[M:]
        G = np.eye(r) - V21 @ V21.T
        X = V11 @ V21.T @ np.linalg.pinv(G, hermitian=True)
    return X, info


def truncated_tls(
    A,
    B,
    *,
    rcond: float | None = None,
    noise_level: float | None = None,
    rank: int | str | None = None,
    max_columns: int | None = None,
    scale: bool = False,
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
    scale : bool
        Equilibrate first: divide each column of ``A`` and of ``B`` by its 2-norm, solve,
        undo (``X = D_A⁻¹ X' D_B``). TLS is not invariant to column scaling (it weighs the
        errors of every column alike); with ``scale`` a column of ``A`` multiplied by ``α``
        gives the row of ``X`` divided by ``α`` exactly. Default False (the dissertation).

    Returns
    -------
    (M,) or (M, r) ndarray
        All zeros (with a :class:`PodbenchWarning`) if no singular value is kept.
    """
    A, B, vector = _as_system(A, B)
    _check_tls_size(A.shape[0], A.shape[1], B.shape[1], _tls_limit(max_columns))
    X = _tls(A, B, rcond, noise_level, rank, scale)[0]
    return X[:, 0] if vector else X


# ----------------------------------------------------------------------- solver objects
class DenseSolver(Solver):
    """Base of the solvers that form ``A`` (:meth:`ConvolutionSystem.dense`) and solve the
    matrix problem; also usable on any matrix through :meth:`solve_matrix` (and
    :func:`~podbench.deconvolution.solve`).

    A dense solver of one's own subclasses this, keeps ``max_dense_bytes`` among its
    constructor parameters and implements ``_solve_matrix(A, B)`` (``A`` ``(N, M)``, ``B``
    ``(N, r)``, both validated) returning ``X`` ``(M, r)`` or ``(X, info)``.
    """

    structured = False
    _parameter_constraints = {"max_dense_bytes": [POSITIVE]}

    def __init__(self, *, max_dense_bytes: float = DENSE_MAX_BYTES):
        self.max_dense_bytes = max_dense_bytes

    def _solve_matrix(self, A: np.ndarray, B: np.ndarray):
        raise NotImplementedError(
            f"{type(self).__name__} does not implement _solve_matrix(A, B)")

    def _solve(self, system: ConvolutionSystem):
        A = system.dense(self.max_dense_bytes, solver=self.name)
        out = self._solve_matrix(A, system._B2)
        X, info = out if isinstance(out, tuple) else (out, {})
        X = np.asarray(X, dtype=float)
        return (X[:, 0] if system.vector and X.ndim == 2 else X), info

    def solve_matrix(self, A, B) -> SolverResult:
        """Solve ``A X ≈ B`` for a given matrix.

        Parameters
        ----------
        A : (N, M) array_like
        B : (N,) or (N, r) array_like

        Returns
        -------
        SolverResult
            ``X`` ``(M,)`` or ``(M, r)``; ``info["residual"]`` is ``‖A X − B‖_F / ‖B‖_F``.
        """
        self._validate_params()
        A, B2, vector = _as_system(A, B)
        out = self._solve_matrix(A, B2)
        X, info = out if isinstance(out, tuple) else (out, {})
        X = checked_solution(self.name, X, (A.shape[1], B2.shape[1]))
        residual = relative_residual(float(np.linalg.norm(A @ X - B2)), float(np.linalg.norm(B2)))
        return SolverResult(X=X[:, 0] if vector else X,
                            info=full_info(self.name, info, residual))


class LeastSquares(DenseSolver):
    """Minimum-norm least squares ``X = A⁺ B`` (Eq. 3.76) on the dense matrix (``"ls"``).

    Parameters
    ----------
    rcond : float, optional
        Singular values ``σ_i ≤ rcond·σ_1`` are treated as zero (default ``eps·max(N, M)``).
    max_dense_bytes : float
        Largest dense matrix formed (default :data:`DENSE_MAX_BYTES`, 2 GiB).

    Diagnostics: ``rank`` (effective rank of ``A``), ``rcond`` (the cut used),
    ``condition`` (``σ_1/σ_min`` of ``A``; ``inf`` for an exactly singular ``A``).
    """

    name = "ls"
    _parameter_constraints = {"rcond": [None, POSITIVE], "max_dense_bytes": [POSITIVE]}

    def __init__(self, *, rcond: float | None = None,
                 max_dense_bytes: float = DENSE_MAX_BYTES):
        self.rcond = rcond
        self.max_dense_bytes = max_dense_bytes

    def _solve_matrix(self, A, B):
        rcond = None if self.rcond is None else check_positive(self.rcond, "rcond")
        return _lstsq(A, B, rcond)


class TruncatedTLS(DenseSolver):
    """Truncated total least squares (Eqs. 3.77–3.80) on the dense matrix (``"tls"``).

    Parameters
    ----------
    rcond, noise_level, rank
        Truncation rule, at most one (see :func:`tls_rank`; default ``rcond=1e-3``, the
        dissertation's; ``rank="gap"`` chooses the rank from the singular-value gap).
    max_columns : int, optional
        Largest ``[A | B]`` (columns) accepted (default :data:`TLS_MAX_COLUMNS`); checked
        before ``A`` is formed.
    scale : bool
        Equilibrate the columns of ``A`` and ``B`` before the SVD and undo after (see
        :func:`truncated_tls`; default False, the dissertation's unscaled TLS).
    max_dense_bytes : float
        Largest dense matrix formed (default :data:`DENSE_MAX_BYTES`, 2 GiB).

    Diagnostics: ``rank`` (singular triplets kept, :func:`tls_rank`), ``rank_rule``,
    ``rcond`` (the cut, if that rule applied), ``condition`` (``σ_1/σ_p`` of ``[A | B]``
    over the kept ones; ``None`` if none is kept).
    """

    name = "tls"
    _parameter_constraints = {"rcond": [None, FRACTION], "noise_level": [None, POSITIVE],
                              "rank": [None, Options("gap"), Interval("integer", 0)],
                              "max_columns": [None, COUNT], "scale": [Boolean()],
                              "max_dense_bytes": [POSITIVE]}

    def __init__(self, *, rcond: float | None = None, noise_level: float | None = None,
                 rank: int | str | None = None, max_columns: int | None = None,
                 scale: bool = False, max_dense_bytes: float = DENSE_MAX_BYTES):
        self.rcond = rcond
        self.noise_level = noise_level
        self.rank = rank
        self.max_columns = max_columns
        self.scale = scale
        self.max_dense_bytes = max_dense_bytes

    def _validate_params(self) -> None:
        super()._validate_params()
        _check_rule(self.rcond, self.noise_level, self.rank)

    def _solve(self, system: ConvolutionSystem):
        N, M = system.shape
        _check_tls_size(N, M, system.n_rhs, _tls_limit(self.max_columns))  # before forming A
        return super()._solve(system)

    def _solve_matrix(self, A, B):
        _check_tls_size(A.shape[0], A.shape[1], B.shape[1], _tls_limit(self.max_columns))
        return _tls(A, B, self.rcond, self.noise_level, self.rank, bool(self.scale))
