"""A user's own matrices as a :class:`Structure`, and safe readers for matrix files.

Supported files (nothing is unpickled):

* ``.npz`` – NumPy archive (``np.savez``), read with ``allow_pickle=False``; arrays by key;
* ``.npy`` – one NumPy array, ``allow_pickle=False``;
* ``.mat`` – MATLAB v4/v5/v7 (``scipy.io.loadmat``; dense or sparse); variables by name;
* ``.mtx`` – MatrixMarket (``scipy.io.mmread``; dense or coordinate), one matrix per file.

Units are whatever the user's model uses, but podbench's loads and tables are in inch, lbf,
second: M in lbf·s²/in, C in lbf·s/in, K in lbf/in.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import DimensionError, InputError
from .structure import Structure

__all__ = ["MATRIX_SUFFIXES", "read_arrays", "read_matrix", "check_matrix", "from_matrices"]

#: File suffixes :func:`read_matrix` understands.
MATRIX_SUFFIXES = (".npz", ".npy", ".mat", ".mtx")

_DENSE_PD_LIMIT = 6000  # above this size M's definiteness is checked with a sparse solver


def read_arrays(path) -> dict:
    """All arrays of a ``.npz`` or ``.mat`` file, by name (``.mat`` headers dropped).

    Raises
    ------
    InputError
        The file cannot be read, or holds pickled objects.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise InputError(f'no such file "{path}"')
    try:
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        if suffix == ".mat":
            data = scipy.io.loadmat(path)
            return {k: v for k, v in data.items() if not k.startswith("__")}
    except Exception as exc:  # corrupt file, object arrays (pickles), wrong format
        raise InputError(f'cannot read "{path}": {type(exc).__name__}: {exc}') from None
    raise InputError(f'"{path}": expected a .npz or .mat file holding named matrices')


def read_matrix(path, key: str | None = None):
    """One matrix from a file (dense ``ndarray`` or sparse matrix).

    Parameters
    ----------
    path : path-like
        ``.npz``/``.mat`` (``key`` names the array; optional if the file holds exactly one),
        ``.npy`` or ``.mtx``.
    key : str, optional
        Array name inside a ``.npz`` or ``.mat`` file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MATRIX_SUFFIXES:
        raise InputError(
            f'"{path}": unsupported matrix file type "{suffix}" '
            f"(supported: {', '.join(MATRIX_SUFFIXES)})"
        )
    if suffix in (".npz", ".mat"):
        arrays = read_arrays(path)
        if key is None:
            if len(arrays) != 1:
                raise InputError(f'"{path}" holds {sorted(arrays)}: name the matrix to read')
            return next(iter(arrays.values()))
        if key not in arrays:
            raise InputError(f'"{path}" has no matrix "{key}" (it holds {sorted(arrays)})')
        return arrays[key]
    if not path.is_file():
        raise InputError(f'no such file "{path}"')
    try:
        if suffix == ".npy":
            return np.load(path, allow_pickle=False)
        return scipy.io.mmread(path)
    except Exception as exc:
        raise InputError(f'cannot read "{path}": {type(exc).__name__}: {exc}') from None


def check_matrix(A, label: str, *, n: int | None = None, symmetry_rtol: float = 1e-10,
                 positive_definite: bool = False) -> sp.csr_matrix:
    """Validate a structural matrix and return it as a symmetric CSR matrix.

    Checks: numeric, 2-D, square, size ``n`` (if given), finite, symmetric to
    ``max|A − Aᵀ| <= symmetry_rtol · max|A|`` (then symmetrized exactly), and positive
    definite if asked (Cholesky). ``label`` starts every message (e.g. "Parameter `M`").
    """
    if sp.issparse(A):
        A = sp.csr_matrix(A)
        if not np.issubdtype(A.dtype, np.number) or np.issubdtype(A.dtype, np.complexfloating):
            raise InputError(f"{label}: expected a real matrix, got dtype {A.dtype}")
        A = A.astype(float)
    else:
        try:
            arr = np.asarray(A)
        except Exception as exc:  # pragma: no cover - exotic objects
            raise InputError(f"{label}: not a matrix ({exc})") from None
        if arr.dtype == object or not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
            raise InputError(f"{label}: expected a real numeric matrix, got dtype {arr.dtype}")
        if arr.ndim != 2:
            raise DimensionError(f"{label}: expected a 2-D matrix, got shape {arr.shape}")
        A = sp.csr_matrix(arr.astype(float))
    if A.shape[0] != A.shape[1] or A.shape[0] == 0:
        raise DimensionError(f"{label}: expected a non-empty square matrix, got shape {A.shape}")
    if n is not None and A.shape != (n, n):
        raise DimensionError(f"{label}: expected shape {(n, n)} (the size of M), got {A.shape}")
    if A.nnz and not np.all(np.isfinite(A.data)):
        bad = int(np.size(A.data) - np.count_nonzero(np.isfinite(A.data)))
        raise InputError(f"{label}: contains {bad} NaN or Inf value(s)")
    scale = abs(A).max() if A.nnz else 0.0
    asym = abs(A - A.T).max() if A.nnz else 0.0
    if asym > symmetry_rtol * scale:
        raise InputError(
            f"{label}: not symmetric (max |A - A^T| = {asym:.3g}, max |A| = {scale:.3g}, "
            f"relative tolerance {symmetry_rtol:g})"
        )
    A = ((A + A.T) * 0.5).tocsr()
    if positive_definite:
        _check_pd(A, label)
    return A


def _check_pd(A: sp.csr_matrix, label: str) -> None:
    n = A.shape[0]
    if n <= _DENSE_PD_LIMIT:
        try:
            scipy.linalg.cholesky(A.toarray(), lower=True)
            return
        except np.linalg.LinAlgError:
            lam = scipy.linalg.eigvalsh(A.toarray(), subset_by_index=[0, 0])[0]
    else:
        lam = spla.eigsh(A, k=1, which="SA", return_eigenvectors=False, tol=1e-8)[0]
        if lam > 0:
            return
    raise InputError(f"{label}: not positive definite (smallest eigenvalue {lam:.3g})")


def from_matrices(
    *,
    name: str = "matrices",
    M,
    K,
    C=None,
    sensor_dofs="all",
    sensor_positions=None,
    sensor_labels=(),
    dof_labels=(),
    metadata=None,
    symmetry_rtol: float = 1e-10,
    description: str = "",
    source: str = "",
    where: str = "",
) -> Structure:
    """A :class:`Structure` from user-supplied matrices, after checking them.

    Parameters
    ----------
    M, K : (n, n) array_like or sparse
        Mass (lbf·s²/in, symmetric positive definite) and stiffness (lbf/in, symmetric)
        with the boundary conditions applied.
    C : (n, n) array_like or sparse, optional
        Viscous damping (lbf·s/in, symmetric).
    sensor_dofs : "all" or (n_sensors,) int array
        DOF read by each sensor; ``-1`` for a sensor on a constrained point.
    sensor_positions, sensor_labels, dof_labels, metadata
        Optional extras stored on the structure (lengths checked).
    symmetry_rtol : float
        Relative tolerance of the symmetry check.
    where : str
        Prefix of error messages (default: "Parameter `<name>`").
    """
    def lab(p):
        return f"{where} {p}".strip() if where else f"Parameter `{p}`"

    M = check_matrix(M, lab("M"), symmetry_rtol=symmetry_rtol, positive_definite=True)
    n = M.shape[0]
    K = check_matrix(K, lab("K"), n=n, symmetry_rtol=symmetry_rtol)
    if C is not None:
        C = check_matrix(C, lab("C"), n=n, symmetry_rtol=symmetry_rtol)
    if isinstance(sensor_dofs, str):
        if sensor_dofs != "all":
            raise InputError(f'{lab("sensor_dofs")}: expected "all" or a list of DOF indices, '
                             f'got "{sensor_dofs}"')
        sensor_dofs = np.arange(n)
    sd = np.asarray(sensor_dofs)
    if sd.ndim != 1 or sd.size == 0 or not np.issubdtype(sd.dtype, np.integer):
        raise InputError(f"{lab('sensor_dofs')}: expected a non-empty list of integers, "
                         f"got {sensor_dofs!r}")
    if sd.min() < -1 or sd.max() >= n:
        raise DimensionError(f"{lab('sensor_dofs')}: indices must lie in [-1, {n - 1}] "
                             f"(n = {n} DOFs), got range [{sd.min()}, {sd.max()}]")
    if len(sensor_labels) not in (0, sd.size):
        raise DimensionError(f"{lab('sensor_labels')}: expected {sd.size} labels, got "
                             f"{len(sensor_labels)}")
    if len(dof_labels) not in (0, n):
        raise DimensionError(f"{lab('dof_labels')}: expected {n} labels, got {len(dof_labels)}")
    if sensor_positions is not None:
        sensor_positions = np.asarray(sensor_positions, dtype=float)
        if sensor_positions.shape != sd.shape:
            raise DimensionError(f"{lab('sensor_positions')}: expected shape {sd.shape}, got "
                                 f"{sensor_positions.shape}")
    return Structure(
        name=name, M=M, K=K, C=C, sensor_dofs=sd.astype(np.int64),
        sensor_positions=sensor_positions, sensor_labels=tuple(map(str, sensor_labels)),
        dof_labels=tuple(map(str, dof_labels)), description=description, source=source,
        metadata=dict(metadata or {}),
    )
