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

from .._validation import as_finite_array, check_choice, check_positive
from ..errors import DimensionError, InputError
from .structure import Structure

__all__ = ["chain"]


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


def chain(
    n: int,
    *,
    masses=1.0,
    springs=1.0,
    mass_coupling: float = 0.0,
    boundary: str = "fixed-free",
    rayleigh: tuple[float, float] | None = None,
    dashpots: Sequence[tuple] = (),
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

    Returns
    -------
    Structure
        ``C`` is None when neither ``rayleigh`` nor ``dashpots`` is given.
    """
    n = check_positive(n, "n", integer=True)
    check_choice(boundary, "boundary", ("fixed-free", "fixed-fixed"))
    m = _per_item(masses, "masses", n, f"one per mass, n = {n}")
    n_springs = n if boundary == "fixed-free" else n + 1
    k = _per_item(springs, "springs", n_springs, f"{boundary} chain of n = {n} needs {n_springs}")
    mu = float(as_finite_array(mass_coupling, "mass_coupling", ndim=0))
    if not abs(mu) < 0.5:
        raise InputError(f"Parameter `mass_coupling`: |μ| must be below 0.5 to keep M "
                         f"positive definite, got {mu!r}")

    K = np.zeros((n, n))
    K[0, 0] += k[0]
    for i in range(1, n):
        K[i - 1, i - 1] += k[i]
        K[i, i] += k[i]
        K[i - 1, i] -= k[i]
        K[i, i - 1] -= k[i]
    if boundary == "fixed-fixed":
        K[n - 1, n - 1] += k[n]
    sq = np.sqrt(m)
    M = np.diag(m)
    if mu and n > 1:
        off = mu * sq[:-1] * sq[1:]
        M += np.diag(off, 1) + np.diag(off, -1)

    C = None
    if rayleigh is not None:
        try:
            alpha, beta = rayleigh
        except (TypeError, ValueError):
            raise InputError(f"Parameter `rayleigh`: expected (alpha, beta), got {rayleigh!r}"
                             ) from None
        alpha = check_positive(alpha, "rayleigh alpha", allow_zero=True)
        beta = check_positive(beta, "rayleigh beta", allow_zero=True)
        C = alpha * M + beta * K
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
        C = np.zeros((n, n)) if C is None else C
        i = dofs[0]
        C[i, i] += c
        if len(dofs) == 2:
            j = dofs[1]
            C[j, j] += c
            C[i, j] -= c
            C[j, i] -= c

    return Structure(
        name=name, M=sp.csr_matrix(M), K=sp.csr_matrix(K),
        C=None if C is None else sp.csr_matrix(C), sensor_dofs=np.arange(n),
        sensor_positions=np.arange(1.0, n + 1.0), sensor_labels=tuple(f"mass{i}" for i in
                                                                     range(n)),
        dof_labels=tuple(f"mass{i}" for i in range(n)), description=description,
        source=source,
        metadata={"masses": m, "springs": k, "mass_coupling": mu, "boundary": boundary,
                  "rayleigh": rayleigh, "dashpots": [tuple(d) for d in dashpots]},
    )
