"""Proper orthogonal decomposition of snapshot matrices (dissertation §2.3).

A snapshot matrix ``W`` (Eq. 2.1) has one row per sensor and one column per sample
(``m × n``; column 0 is ``t = 0``). Its economy singular value decomposition (Eq. 2.2)

    ``W = U Σ Vᵀ``

gives the proper orthogonal modes (POMs, columns of ``U``, ``m × r``), the proper orthogonal
values (POVs, ``σ_i``, decreasing) and the proper orthogonal coordinate (POC) histories
(columns of ``V``, ``n × r``). ``σ_i v_i`` is the *scaled* POC history ``v̂_i`` (§3.1).

Sign convention: the SVD fixes each pair ``(u_i, v_i)`` only up to a common sign. podbench
makes the entry of largest magnitude of every POM positive (ties: the first), so results do
not depend on the LAPACK build. Every identification method is invariant to these signs.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg

from podbench.core.validation import as_finite_array, check_choice, check_positive
from podbench.errors import DimensionError, InputError

__all__ = [
    "POD",
    "pod",
    "snapshot_svd",
    "method_of_snapshots",
    "energy_fractions",
    "n_modes_for_energy",
    "project",
    "projection_error",
    "numerical_rank",
    "check_orthonormal",
    "ORTHONORMAL_TOL",
]

ORTHONORMAL_TOL = 1e-8
"""Largest ``max|UᵀU − I|`` accepted by :func:`check_orthonormal`."""

_KINDS = ("sigma", "sigma2")
_METHODS = ("auto", "svd", "snapshots")


class POD(NamedTuple):
    """Result of :func:`pod`.

    Attributes
    ----------
    modes : (m, r) ndarray
        POMs ``u_i`` (orthonormal columns; units of ``W`` are carried by ``povs``).
    povs : (r,) ndarray
        POVs ``σ_i``, non-increasing, in the units of ``W`` (e.g. in).
    pocs : (n, r) ndarray
        POC histories ``v_i`` (orthonormal columns, dimensionless).
    """

    modes: np.ndarray
    povs: np.ndarray
    pocs: np.ndarray


def _fix_signs(U: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if U.shape[1] == 0:
        return U, V
    idx = np.argmax(np.abs(U), axis=0)
    signs = np.sign(U[idx, np.arange(U.shape[1])])
    signs[signs == 0] = 1.0
    return U * signs, V * signs


def _snapshots(W, n_modes) -> tuple[np.ndarray, int]:
    """The snapshot matrix checked (finite, 2-D) and the number of modes ``k`` (``n_modes``,
    at most ``min(m, n)``; default all)."""
    W = as_finite_array(W, "W", ndim=2)
    return W, _check_n_modes(n_modes, min(W.shape))


def _check_n_modes(n_modes, r_max: int):
    if n_modes is None:
        return r_max
    n_modes = check_positive(n_modes, "n_modes", integer=True)
    if n_modes > r_max:
        raise InputError(
            f"Parameter `n_modes`: {n_modes} modes requested but the snapshot matrix has only "
            f"min(m, n) = {r_max} singular values"
        )
    return n_modes


def snapshot_svd(W, n_modes: int | None = None) -> POD:
    """POD by the economy SVD of the snapshot matrix (Eq. 2.2).

    Parameters
    ----------
    W : (m, n) array_like
        Snapshot matrix (Eq. 2.1), e.g. displacements in inches.
    n_modes : int, optional
        Number of leading modes to return (default ``min(m, n)``).

    Returns
    -------
    POD
        ``modes`` (m, k), ``povs`` (k,), ``pocs`` (n, k).
    """
    W, k = _snapshots(W, n_modes)
    U, s, Vt = scipy.linalg.svd(W, full_matrices=False, lapack_driver="gesdd")
    U, V = _fix_signs(U[:, :k], Vt[:k].T)
    return POD(U, s[:k].copy(), V)


def method_of_snapshots(W, n_modes: int | None = None) -> POD:
    """POD of a tall snapshot matrix (``m ≫ n``) from the ``n × n`` correlation matrix.

    Solves the symmetric eigenproblem ``WᵀW v_i = σ_i² v_i`` and sets ``u_i = W v_i / σ_i``;
    no ``m × m`` matrix is ever formed (cost ``O(m n²)``, memory ``O(m n)``). The result
    equals the SVD's leading modes up to round-off *where the spectrum separates*: squaring
    the singular values loses precision for ``σ_i ≲ sqrt(eps)·σ_1``, so only use modes well
    above that level (a mode with ``σ_i <= sqrt(eps·n)·σ_1`` cannot be normalized and
    raises).

    Parameters
    ----------
    W : (m, n) array_like
        Snapshot matrix (Eq. 2.1).
    n_modes : int, optional
        Number of leading modes (default ``min(m, n)``).

    Returns
    -------
    POD
        ``modes`` (m, k), ``povs`` (k,), ``pocs`` (n, k).
    """
    W, k = _snapshots(W, n_modes)
    G = W.T @ W
    n = G.shape[0]
    lam, V = scipy.linalg.eigh(G, subset_by_index=(n - k, n - 1))
    lam, V = lam[::-1], V[:, ::-1]
    s = np.sqrt(np.clip(lam, 0.0, None))
    # σ² carries round-off of about eps·n·σ_1², so σ below sqrt(eps·n)·σ_1 is noise
    if k and s[-1] <= np.sqrt(np.finfo(float).eps * n) * max(s[0], np.finfo(float).tiny):
        raise InputError(
            f"Parameter `n_modes`: mode {k} has a zero proper orthogonal value at the method of "
            f"snapshots' precision (σ_{k}/σ_1 <= sqrt(eps·n)); it cannot be normalized "
            "(request fewer modes or use the SVD)"
        )
    U = (W @ V) / s
    U, V = _fix_signs(U, V)
    return POD(U, s, V)


def pod(W, n_modes: int | None = None, *, method: str = "auto") -> POD:
    """POD of a snapshot matrix.

    Parameters
    ----------
    W : (m, n) array_like
        Snapshot matrix (Eq. 2.1).
    n_modes : int, optional
        Number of leading modes (default ``min(m, n)``).
    method : {"auto", "svd", "snapshots"}
        ``"svd"``: :func:`snapshot_svd`; ``"snapshots"``: :func:`method_of_snapshots`;
        ``"auto"`` (default): the SVD unless ``m > 20 n`` (very tall matrices), where the
        method of snapshots is faster.
    """
    check_choice(method, "method", _METHODS)
    if method == "auto":
        shape = np.shape(W)
        method = "snapshots" if len(shape) == 2 and shape[0] > 20 * shape[1] else "svd"
    if method == "snapshots":
        return method_of_snapshots(W, n_modes)
    return snapshot_svd(W, n_modes)


def energy_fractions(s, kind: str = "sigma") -> np.ndarray:
    """Fraction of signal energy captured by each POM.

    Parameters
    ----------
    s : (r,) array_like
        POVs (singular values), non-negative.
    kind : {"sigma", "sigma2"}
        ``"sigma"`` (default) follows the dissertation's Eq. 2.3,
        ``ε_i = σ_i / Σ_j σ_j``; ``"sigma2"`` uses ``σ_i² / Σ_j σ_j²`` (the usual
        variance fraction of the POD literature).

    Returns
    -------
    (r,) ndarray
        Fractions summing to one.
    """
    check_choice(kind, "kind", _KINDS)
    s = as_finite_array(s, "s", ndim=1)
    if np.any(s < 0):
        raise InputError("Parameter `s`: singular values must be non-negative")
    e = s if kind == "sigma" else s**2
    total = e.sum()
    if total == 0:
        raise InputError("Parameter `s`: all singular values are zero (no signal energy)")
    return e / total


def n_modes_for_energy(s, threshold: float = 0.99, kind: str = "sigma") -> int:
    """Smallest number of leading POMs whose energy fractions sum to at least ``threshold``.

    Parameters
    ----------
    s : (r,) array_like
        POVs in non-increasing order.
    threshold : float
        Cumulative energy fraction in (0, 1] (default 0.99, as in Chapter 4).
    kind : {"sigma", "sigma2"}
        Energy measure, see :func:`energy_fractions` (default ``"sigma"``, Eq. 2.3).
    """
    threshold = check_positive(threshold, "threshold")
    if threshold > 1:
        raise InputError(f"Parameter `threshold`: must be in (0, 1], got {threshold!r}")
    cum = np.cumsum(energy_fractions(s, kind))
    # a relative slack of a few ulps so that e.g. threshold=1.0 is reachable despite round-off
    return min(int(np.searchsorted(cum, threshold - 8 * np.finfo(float).eps)) + 1, cum.size)


def numerical_rank(s, shape: tuple[int, int]) -> int:
    """Rank of a matrix from its singular values, with NumPy's default tolerance.

    ``σ_i > σ_1 · max(m, n) · eps`` (as ``numpy.linalg.matrix_rank``).
    """
    s = np.asarray(s, dtype=float)
    if s.size == 0 or s[0] == 0:
        return 0
    return int(np.count_nonzero(s > s[0] * max(shape) * np.finfo(float).eps))


def check_orthonormal(U, name: str = "basis", *, n_rows: int | None = None) -> np.ndarray:
    """Return ``U`` as a float array after checking it has orthonormal columns.

    Raises
    ------
    DimensionError
        Wrong number of rows or more columns than rows.
    InputError
        ``max|UᵀU − I| > ORTHONORMAL_TOL`` (1e-8).
    """
    U = as_finite_array(U, name, ndim=2)
    if n_rows is not None and U.shape[0] != n_rows:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_rows} rows (one per sensor), got shape {U.shape}"
        )
    if U.shape[1] == 0 or U.shape[1] > U.shape[0]:
        raise DimensionError(
            f"Parameter `{name}`: expected 1 to {U.shape[0]} columns, got shape {U.shape}"
        )
    dev = float(np.max(np.abs(U.T @ U - np.eye(U.shape[1]))))
    if dev > ORTHONORMAL_TOL:
        raise InputError(
            f"Parameter `{name}`: columns are not orthonormal (max |UᵀU − I| = {dev:.3g} > "
            f"{ORTHONORMAL_TOL:g})"
        )
    return U


def project(W, U) -> np.ndarray:
    """Coordinates of the snapshots in the basis ``U``: ``V̂ᵀ = Uᵀ W`` (Eq. 3.25).

    Parameters
    ----------
    W : (m, n) array_like
        Snapshot matrix.
    U : (m, k) array_like
        Orthonormal basis (e.g. POMs).

    Returns
    -------
    (k, n) ndarray
        Row ``i`` is the (scaled) POC history of mode ``i`` in ``W``.
    """
    W = as_finite_array(W, "W", ndim=2)
    U = as_finite_array(U, "U", ndim=2)
    if U.shape[0] != W.shape[0]:
        raise DimensionError(
            f"Parameter `U`: expected {W.shape[0]} rows to match `W` {W.shape}, got {U.shape}"
        )
    return U.T @ W


def projection_error(W, U) -> float:
    """Relative projection error ``‖W − U Uᵀ W‖_F / ‖W‖_F`` (§3.6), dimensionless.

    The floor of any method whose prediction lies in ``span(U)``. Zero if ``W`` is zero.
    """
    W = as_finite_array(W, "W", ndim=2)
    V = project(W, U)
    nw = np.linalg.norm(W)
    if nw == 0:
        return 0.0
    return float(np.linalg.norm(W - np.asarray(U, dtype=float) @ V) / nw)
