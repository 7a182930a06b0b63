"""Spring–mass chains: small systems where the POD methods' assumptions hold or fail by design.

A chain of ``n`` masses (DOF ``i`` = displacement of mass ``i``, in) joined by springs,
grounded at the left end ("fixed-free") or at both ends ("fixed-fixed"). Optional:

* ``mass_coupling`` μ: a consistent-mass-like coupling
  ``M = D^½ (I + μ T) D^½``, ``D = diag(m)``, ``T`` the tridiagonal matrix of ones off the
  diagonal; ``|μ| < ½`` keeps M positive definite (the eigenvalues of ``I + μT`` are
  ``1 + 2μ cos(kπ/(n+1)) > 0``). μ = 1/4 is the ratio of a bar's consistent mass.
* Rayleigh damping ``C = α M + β K`` (proportional: the undamped modes diagonalize it).
* dashpots: grounded on one mass or between two masses (non-proportional in general).

With identity mass and proportional damping the chain satisfies the assumptions of the
POVR and SL methods (M ∝ I, diagonal modal damping); a non-diagonal mass and dashpots
break them (dissertation §3.6, diagonalization error).

Units: inch, lbf, second (masses lbf·s²/in, springs lbf/in, dashpots lbf·s/in).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from podbench.core.validation import as_finite_array, check_choice, check_positive
from podbench.errors import DimensionError, InputError
from podbench.structures.structure import Structure

__all__ = ["chain", "spring_count"]


def spring_count(n: int, boundary: str = "fixed-free") -> int:
    """Springs of a chain of ``n`` masses: ``n`` grounded at the left end (``"fixed-free"``),
    ``n + 1`` grounded at both ends (``"fixed-fixed"``)."""
    check_choice(boundary, "boundary", ("fixed-free", "fixed-fixed"))
    return n if boundary == "fixed-free" else n + 1


def _per_item(x, name: str, size: int, what: str) -> np.ndarray:
    arr = as_finite_array(x, name)
    if arr.ndim == 0:
        arr = np.full(size, float(arr))
    if arr.shape != (size,):
        raise DimensionError(f"Parameter `{name}`: expected a number or {size} values "
                             f"({what}), got shape {arr.shape}")
    if np.any(arr <= 0):
        raise InputError(f"Parameter `{name}`: must be positive, got {arr.tolist()}")
    return arr


def _sensor_dofs(sensors, n: int) -> np.ndarray:
    if sensors is None:
        return np.arange(n)
    arr = np.asarray(sensors)
    if arr.ndim != 1 or arr.size == 0 or not (
        np.issubdtype(arr.dtype, np.integer) and arr.dtype != np.bool_
    ):
        raise InputError(f"Parameter `sensors`: expected a non-empty list of mass indices "
                         f"(integers), got {sensors!r}")
    if arr.min() < 0 or arr.max() >= n:
        raise InputError(f"Parameter `sensors`: mass indices must lie in [0, {n - 1}], got "
                         f"range [{arr.min()}, {arr.max()}]")
    if np.unique(arr).size != arr.size:
        raise InputError("Parameter `sensors`: repeated mass indices")
    return arr.astype(np.int64)


def chain(
    n: int,
    *,
    masses=1.0,
    springs=1.0,
    mass_coupling: float = 0.0,
    boundary: str = "fixed-free",
    rayleigh: tuple[float, float] | None = None,
    dashpots: Sequence[tuple] = (),
    sensors=None,
    name: str = "chain",
    description: str = "",
    source: str = "",
) -> Structure:
    """An ``n``-DOF spring–mass chain, every mass a sensor.

    Parameters
    ----------
    n : int
        Number of masses (DOFs).
    masses : float or (n,) array_like
        Masses, lbf·s²/in.
    springs : float or array_like
        Spring stiffnesses, lbf/in: ``n`` values for "fixed-free" (spring 0 grounds mass 0,
        spring i joins masses i−1 and i), ``n + 1`` for "fixed-fixed" (spring n grounds mass
        n−1).
    mass_coupling : float
        μ in ``M = D^½ (I + μ T) D^½``, ``|μ| < 0.5``.
    boundary : {"fixed-free", "fixed-fixed"}
        Supports.
    rayleigh : (alpha, beta), optional
        Adds ``α M + β K`` to C (α in 1/s, β in s).
    dashpots : sequence of (i, c) or (i, j, c)
        Grounded dashpot on mass ``i`` or dashpot between masses ``i`` and ``j`` (0-based),
        ``c`` in lbf·s/in; added to C.
    sensors : sequence of int, optional
        Masses (0-based, increasing or not, no repeats) that are sensors; default every mass.
        A few sensors on a long chain keep ``simulate``'s recorded output small.

    Returns
    -------
    Structure
        Sparse (CSR) ``M``, ``K``, ``C``: tridiagonal, 3n − 2 stored entries at most (n for
        an uncoupled M), so a 100,000-DOF chain takes a few MB. ``C`` is None when neither
        ``rayleigh`` nor ``dashpots`` is given. Sensor ``i`` sits at ``i + 1`` in
        (``sensor_positions``).
    """
    n = check_positive(n, "n", integer=True)
    check_choice(boundary, "boundary", ("fixed-free", "fixed-fixed"))
    m = _per_item(masses, "masses", n, f"one per mass, n = {n}")
    n_springs = spring_count(n, boundary)
    k = _per_item(springs, "springs", n_springs, f"{boundary} chain of n = {n} needs {n_springs}")
    mu = float(as_finite_array(mass_coupling, "mass_coupling", ndim=0))
    if not abs(mu) < 0.5:
        raise InputError(f"Parameter `mass_coupling`: |μ| must be below 0.5 to keep M "
                         f"positive definite, got {mu!r}")

    K = _stiffness(k, n, boundary)
    M = _mass(m, mu)
    C = _rayleigh(rayleigh, M, K)
    pots = _check_dashpots(dashpots, n)
    if pots:
        C = _add_dashpots(C, pots, n)
    if C is not None:
        C = C.tocsr()
        C.eliminate_zeros()

    sensors = _sensor_dofs(sensors, n)
    return Structure(
        name=name, M=M, K=K, C=C, sensor_dofs=sensors,
        sensor_positions=sensors + 1.0, sensor_labels=tuple(f"mass{i}" for i in sensors),
        dof_labels=tuple(f"mass{i}" for i in range(n)), description=description,
        source=source,
        metadata={"masses": m, "springs": k, "mass_coupling": mu, "boundary": boundary,
                  "rayleigh": rayleigh, "dashpots": [tuple(d) for d in dashpots]},
    )


def _stiffness(k: np.ndarray, n: int, boundary: str) -> sp.csr_matrix:
    """Tridiagonal ``K``: spring ``i`` (i ≥ 1) joins masses i−1 and i, spring 0 grounds mass 0
    (and spring ``n`` grounds mass n−1 in a fixed-fixed chain)."""
    diag = k[:n].copy()
    diag[:-1] += k[1:n]
    if boundary == "fixed-fixed":
        diag[-1] += k[n]
    off = -k[1:n]
    return sp.diags([off, diag, off], [-1, 0, 1], shape=(n, n), format="csr")


def _mass(m: np.ndarray, mu: float) -> sp.csr_matrix:
    """``M = D^½ (I + μ T) D^½``, ``D = diag(m)`` (diagonal when μ = 0 or n = 1)."""
    n = m.size
    if mu and n > 1:
        sq = np.sqrt(m)
        coupling = mu * sq[:-1] * sq[1:]
        return sp.diags([coupling, m, coupling], [-1, 0, 1], shape=(n, n), format="csr")
    return sp.diags(m, 0, shape=(n, n), format="csr")


def _rayleigh(rayleigh, M: sp.csr_matrix, K: sp.csr_matrix) -> sp.csr_matrix | None:
    """``C = α M + β K`` (None without ``rayleigh``)."""
    if rayleigh is None:
        return None
    try:
        alpha, beta = rayleigh
    except (TypeError, ValueError):
        raise InputError(f"Parameter `rayleigh`: expected (alpha, beta), got {rayleigh!r}"
                         ) from None
    alpha = check_positive(alpha, "rayleigh alpha", allow_zero=True)
    beta = check_positive(beta, "rayleigh beta", allow_zero=True)
    return (alpha * M + beta * K).tocsr()


def _check_dashpots(dashpots, n: int) -> list[tuple]:
    """``(i, c)`` or ``(i, j, c)`` with ``0 <= i, j < n``, ``i != j`` and ``c >= 0``."""
    pots = []
    for d in dashpots:
        d = tuple(d)
        if len(d) not in (2, 3):
            raise InputError(f"Parameter `dashpots`: expected (i, c) or (i, j, c), got {d!r}")
        *dofs, c = d
        c = check_positive(c, "dashpot c", allow_zero=True)
        for i in dofs:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < n:
                raise InputError(f"Parameter `dashpots`: DOF {i!r} outside [0, {n - 1}]")
        if len(dofs) == 2 and dofs[0] == dofs[1]:
            raise InputError(f"Parameter `dashpots`: a dashpot joins two different masses, "
                             f"got {d!r}")
        pots.append((*(int(i) for i in dofs), c))
    return pots


def _add_dashpots(C: sp.csr_matrix | None, pots: list[tuple], n: int) -> sp.csr_matrix:
    """``C`` with the dashpots added one at a time onto the Rayleigh part, in the given order
    (as a dense ``C[i, j] += c`` would), then put in place of the entries they touch."""
    acc: dict[tuple[int, int], float] = {}

    def add(i: int, j: int, x: float) -> None:
        if (i, j) not in acc:
            acc[(i, j)] = 0.0 if C is None else float(C[i, j])
        acc[(i, j)] += x

    for *dofs, c in pots:
        i = dofs[0]
        add(i, i, c)
        if len(dofs) == 2:
            j = dofs[1]
            add(j, j, c)
            add(i, j, -c)
            add(j, i, -c)
    base = sp.coo_matrix((n, n)) if C is None else C.tocoo()
    keys = np.array(list(acc), dtype=np.int64)
    keep = ~np.isin(base.row.astype(np.int64) * n + base.col, keys[:, 0] * n + keys[:, 1])
    return sp.csr_matrix(
        (np.concatenate([base.data[keep], list(acc.values())]),
         (np.concatenate([base.row[keep], keys[:, 0]]),
          np.concatenate([base.col[keep], keys[:, 1]]))),
        shape=(n, n),
    )
