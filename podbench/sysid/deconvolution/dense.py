"""Dense solvers: the matrix problems of Eqs. 3.76–3.80, ``O((kn)³)`` time, ``O((kn)²)`` memory.

``"ls"``    :class:`LeastSquares` / :func:`least_squares`, minimum-norm least squares
            ``X = A⁺ B`` (Eq. 3.76) from the SVD of the convolution matrix (kept per
            process: every right-hand side on the same forces shares it).
``"tls-dt"`` :class:`TruncatedTLS` / :func:`truncated_tls`, truncated total least squares
            (Eqs. 3.78–3.80, several right-hand sides), rank by :func:`tls_rank`; refused
            above :data:`TLS_MAX_COLUMNS` columns. podbench's form: the matrix keeps Δt
            (``Δt·toeplitz(q)``), so its cut depends on Δt and the units (``scale=True``
            equilibrates the columns). The ``rcond`` rule solves through the discarded
            eigenvectors of ``[A | B]ᵀ[A | B]`` (:func:`_tls_gram`). Formerly ``"tls"``.
``"tls-appendix"`` :class:`AppendixTLS` / :func:`appendix_tls`, the dissertation's TLS: the
            appendix's ``tlsdeconv`` (raw force samples, no Δt, ``σ_1/σ_i <= tol``, one
            right-hand side at a time; ``tol`` 1000 or ``"snr"``), through the eigenvalues of
            ``XᵀX`` (:mod:`~podbench.sysid.deconvolution.bordered`).
``"tls-balanced"`` :class:`BalancedTLS`, the same with the force blocks and ``y``
            equilibrated: the same answer in any units.

The solver objects of these four keep their last :data:`MEMO_SIZE` answers per process
(exact bytes of the system and the options as the key): a repeated solve returns the first
answer bit for bit.
"""

from __future__ import annotations

import hashlib
import warnings
from collections import OrderedDict

import numpy as np
import scipy.linalg
import scipy.sparse.linalg

from podbench.core.validation import as_finite_array, check_positive, condition_number
from podbench.errors import DimensionError, InputError, PodbenchWarning
from podbench.sysid.deconvolution._base import (
    Solver,
    SolverResult,
    checked_solution,
    full_info,
    relative_residual,
)
from podbench.sysid.deconvolution.bordered import (
    border,
    bordered_tls,
    convolution_svd,
    gram_eigh,
)
from podbench.sysid.deconvolution.snr import system_snr
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
    "AppendixTLS",
    "BalancedTLS",
    "appendix_tls",
    "DEFAULT_APPENDIX_TOL",
    "SNR_TOL",
    "SNR_TOL_MAX",
    "snr_tol",
]

TLS_MAX_COLUMNS = 4096
"""Largest number of columns of ``[A | B]`` that :func:`truncated_tls` accepts by default:
an SVD of that size grows as the cube of the columns, with peak memory about seven matrices
of that size (times measured in docs/noise.md). Beyond the limit it raises
:class:`InputError` suggesting a structured solver; ``max_columns=`` overrides it."""

DEFAULT_TLS_RCOND = 1e-3
"""Default relative singular-value cut of :func:`truncated_tls`: the MATLAB's ``tol = 1000``
(keep ``σ_1/σ_i ≤ 1000``) made a parameter."""


GRAM_MIN_RCOND = 1e-4
"""Smallest ``rcond`` for which :func:`truncated_tls` takes its fast path through the
eigenvalues of ``[A | B]ᵀ[A | B]`` (their absolute error, about ``ε λ_1 (M + r)``, stays
far below the cut ``rcond² λ_1``); below it the SVD (:func:`_tls_svd`)."""

TLS_MIN_DEN = 1e-8
"""Smallest TLS denominator ``λ_min(V22 V22ᵀ)`` — the weight of the discarded right singular
vectors on the right-hand sides, ``= λ_min(I − V21 V21ᵀ)`` over the kept ones — at which
:func:`truncated_tls` solves: below it the rank is lowered, one kept direction at a time,
until the denominator reaches it (the non-generic TLS problem; see
:func:`_nongeneric_rank`). ``X = −V12 V22ᵀ(V22 V22ᵀ)⁻¹`` divides by it, and it is
computed with an absolute error of about ``ε`` (the kept form's ``1 − Σ V21²``), so at or
above ``1e-8`` the round-off in ``X`` stays near ``ε/1e-8 ≈ 2e-8`` (relative), two digits
below the sixth that the tables write. A denominator that vanishes in exact arithmetic
comes out at ``1e-36…1e-15``; every other one met in the committed studies is above
``3e-6`` (``docs/noise.md``, *Choices of a direct solve*)."""

TLS_CUT_TIE = 1e-10
"""Singular values of ``[A | B]`` within ``TLS_CUT_TIE·σ_1`` below the ``rcond`` cut count as
at the cut, hence kept: a tie broken one way by every CPU and by both
:func:`_tls_gram` and :func:`_tls_svd` (their singular values agree to about ``1e-12 σ_1``;
an SVD's own round-off is ``~ε σ_1``); the closest singular value to the cut in the
committed studies' systems lies hundreds of times the band from it (docs/noise.md)."""


def _cut_level(rcond: float, s1: float) -> float:
    """The ``rcond`` rule's level with its tie band: keep ``σ ≥ (rcond − TLS_CUT_TIE)·σ_1``."""
    return (rcond - TLS_CUT_TIE) * s1


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
    cond = condition_number(s)
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
      number limit ``σ_1/σ_i ≤ 1000`` made a parameter); a ``σ_i`` within
      :data:`TLS_CUT_TIE` ``σ_1`` below the cut is a tie and kept.

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
        p = int(np.count_nonzero(s >= _cut_level(rcond, s[0]))) if s.size and s[0] > 0 else 0
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
    equilibrates the columns of ``A`` and of ``B`` first (undone on ``X``).

    The ``rcond`` rule (the default) takes the fast path :func:`_tls_gram`; the other rules
    read the whole spectrum and take the reference :func:`_tls_svd`."""
    if scale:
        da, db = _column_scales(A), _column_scales(B)
        X, info = _tls(A / da, B / db, rcond, noise_level, rank)
        return X / da[:, None] * db[None, :], {**info, "scaled": True}
    if rank is None and noise_level is None and (rcond is None or rcond >= GRAM_MIN_RCOND):
        out = _tls_gram(A, B, rcond)
        if out is not None:
            return out
    return _tls_svd(A, B, rcond, noise_level, rank)


def _tls_info(p: int, rank, noise_level, rcond, condition) -> dict:
    return {
        "rank": p,
        "rank_rule": (rank if isinstance(rank, str) else "rank" if rank is not None else
                      "noise_level" if noise_level is not None else "rcond"),
        "rcond": (DEFAULT_TLS_RCOND if rcond is None else float(rcond))
        if rank is None and noise_level is None else None,
        "condition": condition,
    }


def _tls_from_discarded(Vd: np.ndarray, M: int, r: int) -> np.ndarray:
    """``X = −V12 V22ᵀ (V22 V22ᵀ)⁺`` from the discarded right singular vectors ``Vd``
    (``(M + r) × d``): by the orthogonality of ``V_C`` it equals the kept vectors' form
    ``V11 V21ᵀ (I − V21 V21ᵀ)⁺`` of :func:`truncated_tls`."""
    V12, V22 = Vd[:M], Vd[M:]
    return -(V12 @ V22.T) @ np.linalg.pinv(V22 @ V22.T, hermitian=True)


def _warn_no_kept() -> None:
    warnings.warn(
        "truncated_tls: no singular value above the truncation level; returning X = 0",
        PodbenchWarning,
        stacklevel=5,
    )


def _nongeneric_rank(V21: np.ndarray, p: int) -> int:
    """The largest rank ``p' ≤ p`` whose TLS denominator ``λ_min(I − V21 V21ᵀ)`` (over the
    first ``p'`` kept right singular vectors; ``V21`` their right-hand-side rows) is at
    least :data:`TLS_MIN_DEN`.

    Where the discarded directions carry no weight on the right-hand sides (``V22 = 0``:
    ``B`` has a component outside the range of ``A`` that no discarded direction of
    ``[A | B]`` reaches, e.g. a singular ``A`` whose null direction is what the cut
    discards), the truncated TLS solution does not exist (Van Huffel & Vandewalle 1991,
    *The Total Least Squares Problem*, §3.4, the non-generic problem) and the computed
    ``X`` is round-off divided by round-off (on the beam_forced_noise sweep it moved between
    CPUs and under a 1e-12 perturbation of the records: docs/noise.md). Their
    remedy, the non-generic TLS solution, discards the next smallest direction as well
    (``X = −V12 V22ᵀ(V22 V22ᵀ)⁻¹`` over the enlarged set, whose zero columns of ``V22`` add
    nothing), which the data determine. ``p' = 0`` (``X = 0``) when no rank
    reaches the level (``B`` orthogonal to every direction of ``A``)."""
    r = V21.shape[0]
    while p > 0:
        Vk = V21[:, :p]
        if float(np.linalg.eigvalsh(np.eye(r) - Vk @ Vk.T)[0]) >= TLS_MIN_DEN:
            break
        p -= 1
    return p


def _tls_svd(A, B, rcond, noise_level, rank):
    """The reference truncated TLS: the economy SVD of ``[A | B]`` (``gesdd``) and the kept
    right singular vectors (any truncation rule of :func:`tls_rank`, then
    :func:`_nongeneric_rank`)."""
    M, r = A.shape[1], B.shape[1]
    Cmat = np.hstack([A, B])
    _, s, Vt = scipy.linalg.svd(Cmat, full_matrices=False, lapack_driver="gesdd")
    p0 = tls_rank(s, Cmat.shape, M, rcond=rcond, noise_level=noise_level, rank=rank)
    p = _nongeneric_rank(Vt[:p0, M:].T, p0)
    info = _tls_info(p, rank, noise_level, rcond, float(s[0] / s[p - 1]) if p > 0 else None)
    if p == 0:
        if p0 == 0:
            _warn_no_kept()
        else:
            warnings.warn(
                f"truncated_tls: the TLS denominator is below {TLS_MIN_DEN:g} at every rank "
                "(the right-hand sides have no weight on any direction of A that the data "
                "determine); returning X = 0", PodbenchWarning, stacklevel=4)
        return np.zeros((M, r)), info
    V = Vt[:p].T  # (M + r) × p, the kept right singular vectors
    V11, V21 = V[:M], V[M:]
    G = np.eye(r) - V21 @ V21.T
    return V11 @ V21.T @ np.linalg.pinv(G, hermitian=True), info


def _tls_gram(A, B, rcond):
    """Truncated TLS with the ``rcond`` rule from the *discarded* directions only.

    The kept ``σ_i ≥ ρ σ_1`` of ``C = [A | B]`` are the eigenvalues ``λ_i = σ_i² ≥ ρ² λ_1``
    of ``CᵀC``; on the Chapter 5 systems the discarded are a few percent of ``M + r``, so a
    Lanczos ``λ_1`` and one LAPACK ``syevr`` on ``(−∞, 16ρ²λ_1)`` (one tridiagonalization,
    the eigenvectors of that interval only: ``σ < 4ρσ_1``) replace the SVD with both
    singular-vector sets (about 4 times faster at 2050 columns, ``benchmarks/dense_tls.py``).
    The eigenvectors of ``CᵀC`` resolve directions to ``ε λ_1/gap``, too coarse where
    singular values crowd at the cut; a Rayleigh–Ritz step on ``C`` itself (the SVD of the
    small ``C V``, ``V`` the vectors of that interval) separates them as the SVD of ``C``
    does, leaving the interval's edge at ``4ρσ_1`` (far from the cut) as the only ``λ``-level
    error. Rank, ``condition = σ_1/σ_p`` and ``X`` as :func:`_tls_svd` (to about ``1e-10``
    relative on the Chapter 5 systems, ``tests/sysid/test_dense_fast.py``); returns None
    where the interval misses the cut's neighbours or the TLS denominator is below
    :data:`TLS_MIN_DEN` (the caller then takes the SVD, which lowers the rank:
    :func:`_nongeneric_rank`)."""
    rc = DEFAULT_TLS_RCOND if rcond is None else check_positive(rcond, "rcond")
    if rc >= 1:
        raise InputError(f"Parameter `rcond`: must be below 1, got {rc!r}")
    M, r = A.shape[1], B.shape[1]
    C = np.hstack([A, B])
    n1 = C.shape[1]
    G = C.T @ C
    lam1 = _largest_eigenvalue(G)
    if not lam1 > 0:
        _warn_no_kept()
        return np.zeros((M, r)), _tls_info(0, None, None, rcond, None)
    cut = _cut_level(rc, np.sqrt(lam1))
    thr = cut * cut
    w, V = scipy.linalg.eigh(G, subset_by_value=(-np.inf, 16.0 * thr), driver="evr")
    need = min(max(int(np.count_nonzero(w < thr)), n1 - M) + 1, n1)
    if V.shape[1] < need:  # the cap at M reaches past the interval
        w, V = scipy.linalg.eigh(G, subset_by_index=(0, need - 1), driver="evr")
    Vr, s = _ritz(C, V)  # refined: s descending, Vr's columns in that order
    m = s.size
    d = max(int(np.count_nonzero(s < cut)), n1 - M)
    if d >= m and d < n1:
        return None
    p = n1 - d
    V22 = Vr[M:, m - d:]
    if float(np.linalg.eigvalsh(V22 @ V22.T)[0]) < TLS_MIN_DEN:
        return None
    condition = float(np.sqrt(lam1) / s[m - d - 1]) if p > 0 else None
    return (_tls_from_discarded(Vr[:, m - d:], M, r),
            _tls_info(p, None, None, rcond, condition))


def _ritz(C: np.ndarray, V: np.ndarray):
    """Rayleigh–Ritz of ``C`` on the orthonormal columns ``V``: ``(V W, s)`` with ``s`` the
    singular values of ``C V`` (descending, zeros appended where ``C V`` has fewer rows than
    columns) and ``W`` their right singular vectors."""
    Z = C @ V
    m = V.shape[1]
    R = np.linalg.qr(Z, mode="r") if Z.shape[0] > m else Z
    _, s, Wt = scipy.linalg.svd(R, full_matrices=True, lapack_driver="gesvd")
    s = np.concatenate([s, np.zeros(m - s.size)])
    return V @ Wt.T, s


def _largest_eigenvalue(G: np.ndarray) -> float:
    """``λ_1`` of the symmetric ``G``: all eigenvalues when small, else Lanczos."""
    n1 = G.shape[0]
    if not np.any(G):
        return 0.0
    if n1 <= 64:
        return float(scipy.linalg.eigvalsh(G)[-1])
    try:
        return float(scipy.sparse.linalg.eigsh(G, k=1, which="LA", v0=np.ones(n1), tol=0.0,
                                               return_eigenvectors=False)[0])
    except scipy.sparse.linalg.ArpackError:  # no convergence: all eigenvalues
        return float(scipy.linalg.eigvalsh(G)[-1])


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
MEMO_SIZE = 16
"""Solutions that the built-in dense solvers and ``"cgls"`` keep per process (least recently
used first out). A study solves the same system with the same solver more than once (a
method and its coupled twin in the same basis, ``"auto"``'s exact solve on clean records, a
band's refits): the memo returns the first answer, bit for bit, instead of a second
``O((kn)³)`` factorization (or conjugate-gradient solve)."""

_MEMO: OrderedDict = OrderedDict()


def _memo_key(solver, system: ConvolutionSystem) -> tuple:
    """Exact identity of (solver class, hyper-parameters, system): a SHA-256 of the force
    and response samples' bytes with their shapes, Δt and the vector flag."""
    h = hashlib.sha256()
    for arr in (system.G, system.Y):
        h.update(repr((arr.shape, arr.dtype.str)).encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    params = repr(sorted(solver.get_params(deep=False).items()))
    return (type(solver).__qualname__, params, h.hexdigest(), float(system.dt).hex(),
            bool(system.vector))


def memoized(solver, system: ConvolutionSystem, compute):
    """``compute(system)`` → ``(X, info)``, or the answer kept from the same solve in this
    process (:data:`MEMO_SIZE`; keyed by :func:`_memo_key`), a copy, bit for bit, with the
    first solve's warnings issued again. For deterministic solvers only."""
    key = _memo_key(solver, system)
    hit = _MEMO.get(key)
    if hit is None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            X, info = compute(system)
        hit = (np.array(X, dtype=float), dict(info), list(caught))
        _MEMO[key] = hit
        while len(_MEMO) > MEMO_SIZE:
            _MEMO.popitem(last=False)
    else:
        _MEMO.move_to_end(key)
    for w in hit[2]:  # the first solve's warnings, every time
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return hit[0].copy(), dict(hit[1])


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
        if type(self) not in _MEMO_CLASSES:
            return self._solve_dense(system)
        return memoized(self, system, self._solve_dense)

    def _solve_dense(self, system: ConvolutionSystem):
        """Form ``A`` and solve (:meth:`_solve` without the memo)."""
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

    Notes
    -----
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

    def _solve_dense(self, system: ConvolutionSystem):
        """``X = A⁺ B`` from the SVD of the convolution matrix, kept per process
        (:func:`~podbench.sysid.deconvolution.bordered.convolution_svd`: every system on the
        same forces shares it); the cut and diagnostics of ``gelsd``'s (:func:`_lstsq`)."""
        system.check_dense(self.max_dense_bytes, solver=self.name)
        rcond = None if self.rcond is None else check_positive(self.rcond, "rcond")
        U, s, Vt = convolution_svd(system.G)
        s = s * system.dt  # A = Δt·X
        used = float(np.finfo(float).eps * max(system.shape)) if rcond is None else rcond
        keep = s > used * s[0] if s.size and s[0] > 0 else np.zeros(s.size, dtype=bool)
        X = Vt[keep].T @ ((U[:, keep].T @ system._B2) / s[keep][:, None])
        info = {"rank": int(np.count_nonzero(keep)), "rcond": used,
                "condition": condition_number(s)}
        return (X[:, 0] if system.vector else X), info


class TruncatedTLS(DenseSolver):
    """Truncated total least squares (Eqs. 3.77–3.80) on the dense matrix (``"tls-dt"``).

    podbench's form, not the appendix's: the matrix keeps Δt (``Δt·toeplitz(q)``) and the
    right-hand sides are solved together, so its cut ``σ_i ≥ rcond·σ_1`` depends on Δt and
    on the units of forces and responses (``scale=True`` equilibrates every column first,
    which removes both). The dissertation's TLS is :class:`AppendixTLS`
    (``"tls-appendix"``), the unit-free one :class:`BalancedTLS` (``"tls-balanced"``).
    Formerly named ``"tls"`` (:data:`~podbench.sysid.deconvolution._api.RENAMED`).

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

    Notes
    -----
    Diagnostics: ``rank`` (singular triplets kept, :func:`tls_rank`), ``rank_rule``,
    ``rcond`` (the cut, if that rule applied), ``condition`` (``σ_1/σ_p`` of ``[A | B]``
    over the kept ones; ``None`` if none is kept).
    """

    name = "tls-dt"
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


# ------------------------------------------------------------- the dissertation's TLS
DEFAULT_APPENDIX_TOL = 1000.0
"""``tol`` of the appendix's ``tlsdeconv``: keep the directions with ``σ_1/σ_i <= tol``
("tol = 1000; %based on SNR of data")."""

SNR_TOL = "snr"
"""``tol`` of :class:`AppendixTLS` set from the data, the appendix's "based on SNR of data"
automated: ``tol`` = the amplitude SNR of the modal forces of ``X``
(:func:`~podbench.sysid.deconvolution.snr.system_snr`), within
[1, :data:`SNR_TOL_MAX`]."""

SNR_TOL_MAX = 1e4
"""Largest ``tol`` the SNR rule gives (80 dB): the fourth differences of
:func:`~podbench.sysid.deconvolution.snr.noise_std` resolve noise from the signal of a
response to about that ratio (the clean Chapter 5 records read 4×10³–5×10⁴), and a clean
force, exactly zero between its pulses, reads as infinite; a larger ``tol`` would keep the
round-off directions of a numerically singular ``X``."""


def snr_tol(system: ConvolutionSystem, column: int = 0) -> float:
    """``tol`` by the SNR rule (:data:`SNR_TOL`) for one right-hand side of ``system``."""
    return float(min(max(system_snr(system, column), 1.0), SNR_TOL_MAX))


def _appendix_discarded(C: np.ndarray, tol: float):
    """The right singular vectors of ``C`` that ``tlsdeconv`` does *not* keep, and the count
    ``r`` it keeps: ``(V_d, r)``.

    ``tlsdeconv`` keeps ``σ_i`` with ``σ_1/σ_i <= tol`` (``i <= nrow``); ``Σ_{kept}`` of the
    last row of ``V`` and its products equal ``1 −`` / minus those over the discarded
    vectors (``V`` is orthogonal). They are the eigenvectors of ``CᵀC`` with eigenvalue
    ``< σ_1²/tol²`` (``σ_1²`` by Lanczos, then one LAPACK ``syevr`` on that interval): one
    tridiagonalization instead of a full SVD, the subspace the SVD's to about
    ``ε σ_1²/gap`` (``tests/sysid/test_appendix_tls.py`` compares with the full SVD). The
    path of :func:`appendix_tls` on a given matrix; a convolution system takes
    :mod:`~podbench.sysid.deconvolution.bordered`.
    """
    n1 = C.shape[1]
    G = C.T @ C
    lam1 = _largest_eigenvalue(G)
    if not lam1 > 0:
        return np.eye(n1), 0
    thr = lam1 / (tol * tol)
    _, Vd = scipy.linalg.eigh(G, subset_by_value=(-np.inf, thr), driver="evr")
    r = min(n1 - Vd.shape[1], C.shape[0])
    return Vd, r


def appendix_tls(X, y, *, tol: float = DEFAULT_APPENDIX_TOL) -> np.ndarray:
    """The appendix's ``tlsdeconv(y, X)`` (Eqs. 3.78–3.80 as the MATLAB computes them).

    ``C = [X y]``, ``[U,S,V] = svd(C)``, ``r`` = the number of ``i <= nrow`` with
    ``S(1,1)/S(i,i) <= tol``, then with ``n = length(V) − 1``::

        h = Σ_{i<=r} V(n+1,i) V(1:n,i) / (1 − Σ_{i<=r} V(n+1,i)²)

    ``X`` is used as given: the appendix passes ``form_conv_mat(q)``, the convolution matrix
    of the raw modal-force samples (no Δt). One right-hand side (``y`` a vector, as
    ``n = length(V) − 1`` requires); :class:`AppendixTLS` applies it column by column.

    Parameters
    ----------
    X : (N, M) array_like
    y : (N,) array_like
    tol : float
        Largest ``σ_1/σ_i`` kept (default 1000, the appendix's), > 1.

    Returns
    -------
    (M,) ndarray
        All zeros (with a :class:`PodbenchWarning`) if no direction is kept or ``den = 0``.
    """
    X, B, vector = _as_system(X, y)
    if not vector:
        raise DimensionError(f"Parameter `y`: expected a vector, got shape {B.shape}")
    tol = _check_tol(tol)
    return _appendix_solve(X, B[:, 0], tol)[0]


def _check_tol(tol) -> float:
    tol = check_positive(tol, "tol")
    if tol < 1:
        raise InputError(f"Parameter `tol`: must be at least 1 (a ratio σ_1/σ_i), got {tol!r}")
    return float(tol)


def _appendix_solve(X: np.ndarray, y: np.ndarray, tol: float):
    M = X.shape[1]
    C = np.hstack([X, y[:, None]])
    Vd, r = _appendix_discarded(C, tol)
    # kept: num = Σ V(n+1,i) V(1:n,i) = −Σ_disc …, den = 1 − Σ V(n+1,i)² = Σ_disc V(n+1,i)²
    num = -(Vd[:M] @ Vd[M])
    den = float(Vd[M] @ Vd[M])
    info = {"rank": r, "tls_den": den}
    if r == 0 or den == 0.0:
        _warn_nothing_kept()
        return np.zeros(M), info
    return num / den, info


def _warn_nothing_kept() -> None:
    warnings.warn("appendix TLS: no direction kept (or 1 − ΣV² = 0); returning h = 0",
                  PodbenchWarning, stacklevel=5)


def _block_weights(A: np.ndarray, n_blocks: int) -> np.ndarray:
    """One weight per column of ``A``: ``1/‖A_b‖_F`` of its block of ``M/n_blocks``
    consecutive columns (1 for a zero block)."""
    M = A.shape[1]
    w = np.ones(M)
    size = M // n_blocks
    for b in range(n_blocks):
        nb = float(np.linalg.norm(A[:, b * size:(b + 1) * size]))
        w[b * size:(b + 1) * size] = 1.0 / nb if nb > 0 else 1.0
    return w


class AppendixTLS(DenseSolver):
    """The dissertation's TLS: the appendix's ``tlsdeconv`` (Eqs. 3.78–3.80), ``"tls-appendix"``.

    Chapter 5's solver (§5: "the total least squares method is applied to perform the
    deconvolution of the data"). Per right-hand side ``y`` (a POC history; ML's columns one
    at a time, as ``tlsdeconv(y, X)`` takes one vector: ``n = length(V) − 1``), the SVD of
    ``C = [X y]`` with ``X`` the convolution matrix of the **raw** modal-force samples
    (``form_conv_mat(q)``, no Δt; block matrix of Eq. 3.48 for ML), the directions with
    ``σ_1/σ_i <= tol`` kept and ``h`` from the last row of ``V``
    (:func:`appendix_tls`). The MATLAB's kernel is Δt times podbench's (Eq. 3.39 keeps Δt),
    so the solution is returned divided by Δt; predictions are the MATLAB's.

    ``tol``: the appendix's ``tol = 1000; %based on SNR of data`` (the default), or
    ``"snr"``: the rule the comment asks for, "automated, not specified like it is now":
    ``tol`` = the amplitude SNR of the forces in ``X``, estimated from the samples
    (:func:`snr_tol`; 1000 is 60 dB), one value per right-hand side.

    The cut depends on units: ``σ_1/σ_i`` of ``[X y]`` changes when the forces or the
    responses change units (lbf → N, in → mm). ``column_scale=ρ`` forms ``[ρ X | y]``
    (and returns ``ρ h``): the same data in other units (ρ = force factor / response
    factor, e.g. ρ = 4.448/0.0254 = 175.1 for newton and metre against lbf and inch).
    ``balance=True`` removes the units: every modal force's block of columns and ``y`` are
    divided by their Frobenius norms before the SVD (the diagonal column weighting ``T`` the
    text names in §3.5, "‖D[E | r]T‖_F"), undone after; the answer is then the same in any
    units and at any Δt (podbench's recommended noisy-data TLS, ``"tls-balanced"``).

    Parameters
    ----------
    tol : float or "snr"
        Largest ``σ_1/σ_i`` kept (default 1000, the appendix's ``tol``; at least 1), or
        ``"snr"`` (above).
    column_scale : float
        ``ρ`` above (default 1: the data's own units); ignored with ``balance``.
    balance : bool
        Equilibrate the force blocks and ``y`` (default False: the appendix).
    max_columns, max_dense_bytes
        Size limits as :class:`TruncatedTLS`.

    Notes
    -----
    Diagnostics: ``rank`` (directions kept; the smallest over ML's columns) and
    ``rank_max``, ``rcond`` (``1/tol``, the largest over the columns), ``tls_den`` (the
    smallest ``1 − ΣV²``).
    """

    name = "tls-appendix"
    _parameter_constraints = {"tol": [Options(SNR_TOL), Interval("number", 1, None)],
                              "column_scale": [POSITIVE], "balance": [Boolean()],
                              "max_columns": [None, COUNT], "max_dense_bytes": [POSITIVE]}

    def __init__(self, *, tol: float | str = DEFAULT_APPENDIX_TOL, column_scale: float = 1.0,
                 balance: bool = False, max_columns: int | None = None,
                 max_dense_bytes: float = DENSE_MAX_BYTES):
        self.tol = tol
        self.column_scale = column_scale
        self.balance = balance
        self.max_columns = max_columns
        self.max_dense_bytes = max_dense_bytes

    def _solve(self, system: ConvolutionSystem):
        N, M = system.shape
        _check_tls_size(N, M, 1, _tls_limit(self.max_columns))  # before forming A
        return super()._solve(system)

    def _tols(self, system: ConvolutionSystem | None, n_rhs: int) -> list[float]:
        if self.tol != SNR_TOL:
            return [_check_tol(self.tol)] * n_rhs
        if system is None:
            raise InputError('Parameter `tol`: "snr" reads the modal forces of a '
                             "convolution system; give a number to solve a given matrix")
        return [snr_tol(system, col) for col in range(n_rhs)]

    def _solve_dense(self, system: ConvolutionSystem):
        """``tlsdeconv`` on every right-hand side through the eigendecomposition of ``XᵀX``
        (:mod:`~podbench.sysid.deconvolution.bordered`: the same directions and ``h`` as the
        SVD of ``[X y]``, ``X`` never formed)."""
        system.check_dense(self.max_dense_bytes, solver=self.name)
        tols = self._tols(system, system.n_rhs)
        G = system.G  # the raw modal-force samples: the appendix's form_conv_mat(q), no Δt
        n, n_cases, k = G.shape
        if self.balance:  # each force block divided by its Frobenius norm
            ramp = (n - np.arange(n))[:, None, None]  # T(q) holds q[m] in n − m rows
            norms = np.sqrt(np.sum(ramp * G * G, axis=(0, 1)))
            wb = np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 1.0)
        else:
            wb = np.full(k, float(self.column_scale))
        # a common factor of every block scales XᵀX: one eigendecomposition serves all
        common = bool(np.all(wb == wb[0]))
        mu, Q = gram_eigh(G) if common else gram_eigh(G, wb)
        mu = mu * (wb[0] * wb[0]) if common else mu
        X = np.zeros((k * n, system.n_rhs))
        infos = []
        for col in range(system.n_rhs):
            y = system._B2[:, col]
            wy = 1.0
            if self.balance:
                ny = float(np.linalg.norm(y))
                wy = 1.0 / ny if ny > 0 else 1.0
            b = border(G, y * wy, wb)
            h, r, den = bordered_tls(mu, Q, b, float((y * wy) @ (y * wy)), tols[col],
                                     n_cases * n, min_den=TLS_MIN_DEN)
            if r == 0 or den == 0.0:
                _warn_nothing_kept()
                h = np.zeros(k * n)
            X[:, col] = h * np.repeat(wb, n) / wy
            infos.append({"rank": r, "tls_den": den})
        X = X / system.dt  # the MATLAB's kernel is Δt times podbench's
        return (X[:, 0] if system.vector else X), self._info(infos, tols)

    def _info(self, infos, tols) -> dict:
        ranks = [i["rank"] for i in infos]
        return {"rank": min(ranks), "rank_max": max(ranks), "rcond": 1.0 / min(tols),
                "tls_den": min(i["tls_den"] for i in infos), "balanced": bool(self.balance),
                "column_scale": None if self.balance else float(self.column_scale)}

    def _solve_matrix(self, A, B):
        _check_tls_size(A.shape[0], A.shape[1], 1, _tls_limit(self.max_columns))
        return self._solve_raw(A, B, 1, self._tols(None, B.shape[1]))

    def _solve_raw(self, A: np.ndarray, B: np.ndarray, n_blocks: int, tols):
        """``tlsdeconv`` on a given matrix, column by column (:func:`appendix_tls`)."""
        if self.balance:
            wa = _block_weights(A, n_blocks)
            A = A * wa
        else:
            wa = np.full(A.shape[1], float(self.column_scale))
            A = A * wa if self.column_scale != 1.0 else A
        X = np.zeros((A.shape[1], B.shape[1]))
        infos = []
        for col in range(B.shape[1]):
            y = B[:, col]
            wy = 1.0
            if self.balance:
                ny = float(np.linalg.norm(y))
                wy = 1.0 / ny if ny > 0 else 1.0
            h, inf = _appendix_solve(A, y * wy, tols[col])
            X[:, col] = h * wa / wy
            infos.append(inf)
        return X, self._info(infos, tols)


class BalancedTLS(AppendixTLS):
    """The dissertation's TLS made unit-independent (``"tls-balanced"``): :class:`AppendixTLS`
    with ``balance=True`` — each modal force's block of columns of ``X`` and each ``y``
    divided by its Frobenius norm before the SVD, undone after — so that the same records in
    any units (or at any Δt) give the same prediction. podbench's recommended TLS for noisy
    data. Parameters as :class:`AppendixTLS` (``balance`` defaults to True)."""

    name = "tls-balanced"

    def __init__(self, *, tol: float | str = DEFAULT_APPENDIX_TOL, column_scale: float = 1.0,
                 balance: bool = True, max_columns: int | None = None,
                 max_dense_bytes: float = DENSE_MAX_BYTES):
        super().__init__(tol=tol, column_scale=column_scale, balance=balance,
                         max_columns=max_columns, max_dense_bytes=max_dense_bytes)


_MEMO_CLASSES = (LeastSquares, TruncatedTLS, AppendixTLS, BalancedTLS)
