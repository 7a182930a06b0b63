"""Base class and shared input checks of the POD-based identification methods.

The methods follow the scikit-learn estimator contract:

* ``__init__`` takes keyword-only hyperparameters and stores them unchanged;
* ``fit(...)`` validates hyperparameters and data and returns ``self``;
* learned state ends in an underscore (``modes_``, ``povs_``, ``pocs_``, ``kernel_`` …);
* ``predict(...)`` returns the predicted ``(m, n)`` displacement matrix and raises
  :class:`~podbench.errors.NotFittedError` before ``fit``.

Methods see only NumPy arrays (snapshot matrices ``m × n``, force matrices at the same
sensors and times, initial profiles, Δt); they know nothing of how the data were produced.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence

import numpy as np

from .._validation import as_finite_array, check_choice, check_positive
from ..deconvolution import available_solvers
from ..errors import DimensionError, InputError, NotFittedError
from ..pod import check_orthonormal, n_modes_for_energy, numerical_rank, snapshot_svd

__all__ = ["PODMethod"]


class PODMethod:
    """Base class of the POD-based identification methods (POVR, MDS, SL, ML, MR).

    Subclasses define ``__init__`` with keyword-only hyperparameters, ``fit`` and
    ``predict``. The base class provides :meth:`get_params`, :meth:`set_params`, a
    ``repr`` listing the hyperparameters and the fitted-state check.
    """

    #: Short name used in tables (e.g. "POVR").
    abbreviation = ""

    # ------------------------------------------------------------------ parameters
    @classmethod
    def _param_names(cls) -> list[str]:
        sig = inspect.signature(cls.__init__)
        return [p.name for p in sig.parameters.values() if p.kind == p.KEYWORD_ONLY]

    def get_params(self) -> dict:
        """Hyperparameters as given to the constructor."""
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params) -> PODMethod:
        """Set hyperparameters (validated at the next ``fit``); returns ``self``.

        Raises
        ------
        TypeError
            An unknown hyperparameter name.
        """
        valid = self._param_names()
        for name, value in params.items():
            if name not in valid:
                raise TypeError(
                    f"{type(self).__name__}.set_params: unknown parameter {name!r} "
                    f"(valid: {', '.join(valid)})"
                )
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    # ------------------------------------------------------------------ fitted state
    def _check_is_fitted(self) -> None:
        if not hasattr(self, "modes_"):
            raise NotFittedError(
                f"This {type(self).__name__} instance is not fitted yet; call `fit` before "
                "`predict`"
            )

    @property
    def n_sensors_(self) -> int:
        """Number of sensors ``m`` seen in ``fit``."""
        self._check_is_fitted()
        return self.modes_.shape[0]


# ---------------------------------------------------------------------- checks
def check_snapshots(W, name: str = "W") -> np.ndarray:
    """A finite 2-D snapshot matrix with at least one sensor and one sample."""
    W = as_finite_array(W, name, ndim=2)
    if W.shape[0] == 0 or W.shape[1] == 0:
        raise DimensionError(f"Parameter `{name}`: empty snapshot matrix, shape {W.shape}")
    return W


def check_datasets(Ws, name: str = "W") -> list[np.ndarray]:
    """A non-empty sequence of snapshot matrices of one shape (a 3-D array also works)."""
    if isinstance(Ws, np.ndarray) and Ws.ndim == 2:
        raise DimensionError(
            f"Parameter `{name}`: expected a sequence of (m, n) snapshot matrices (one per "
            f"data set), got a single 2-D array of shape {Ws.shape}; wrap it in a list"
        )
    if not isinstance(Ws, (Sequence, np.ndarray)) or isinstance(Ws, str):
        raise InputError(
            f"Parameter `{name}`: expected a sequence of snapshot matrices, got {type(Ws)}"
        )
    if len(Ws) == 0:
        raise InputError(f"Parameter `{name}`: no data set given")
    out = [check_snapshots(W, f"{name}[{j}]") for j, W in enumerate(Ws)]
    for j, W in enumerate(out[1:], start=1):
        if W.shape != out[0].shape:
            raise DimensionError(
                f"Parameter `{name}[{j}]`: shape {W.shape} differs from `{name}[0]` "
                f"{out[0].shape}; all data sets need the same sensors and sample count"
            )
    return out


def check_profile(x, m: int, name: str) -> np.ndarray:
    """A finite initial profile with one entry per sensor, shape (m,)."""
    x = as_finite_array(x, name)
    if x.ndim == 2 and 1 in x.shape:
        x = x.ravel()
    if x.shape != (m,):
        raise DimensionError(
            f"Parameter `{name}`: expected shape ({m},) (one value per sensor), got {x.shape}"
        )
    return x


def check_profiles(xs, n_sets: int, m: int, name: str) -> list[np.ndarray]:
    """One initial profile per data set (a sequence, or a 2-D array with one profile per row)."""
    if isinstance(xs, np.ndarray) and xs.ndim == 1:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_sets} profiles (one per data set), got a single "
            f"1-D array of shape {xs.shape}"
        )
    try:
        count = len(xs)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected a sequence of profiles") from None
    if count != n_sets:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_sets} profiles (one per data set), got {count}"
        )
    return [check_profile(x, m, f"{name}[{j}]") for j, x in enumerate(xs)]


def check_forces(Fs, Ws, name: str = "F") -> list[np.ndarray]:
    """One force matrix per data set, each of the shape of its snapshot matrix."""
    if isinstance(Fs, np.ndarray) and Fs.ndim == 2:
        raise DimensionError(
            f"Parameter `{name}`: expected a sequence of (m, n) force matrices, got a single "
            f"2-D array of shape {Fs.shape}; wrap it in a list"
        )
    try:
        count = len(Fs)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected a sequence of force matrices") from None
    if count != len(Ws):
        raise DimensionError(
            f"Parameter `{name}`: expected {len(Ws)} force matrices (one per data set), "
            f"got {count}"
        )
    pairs = enumerate(zip(Fs, Ws, strict=True))
    return [check_force(F, W, f"{name}[{j}]") for j, (F, W) in pairs]


def check_force(F, W: np.ndarray, name: str = "F") -> np.ndarray:
    """A finite force matrix of the shape of its snapshot matrix ``W``."""
    F = as_finite_array(F, name, ndim=2)
    if F.shape != W.shape:
        raise DimensionError(
            f"Parameter `{name}`: force matrix shape {F.shape} differs from the snapshot "
            f"matrix shape {W.shape} (forces are sampled at the same sensors and times)"
        )
    return F


def check_new_force(F, m: int, n: int, name: str = "F") -> np.ndarray:
    """A new force matrix with ``m`` rows and at most ``n`` samples."""
    F = as_finite_array(F, name, ndim=2)
    if F.shape[0] != m or not 1 <= F.shape[1] <= n:
        raise DimensionError(
            f"Parameter `{name}`: expected shape ({m}, n') with 1 <= n' <= {n} (the kernel was "
            f"identified from {n} samples), got {F.shape}"
        )
    return F


def check_dt(dt) -> float:
    """Δt > 0 (s)."""
    if dt is None:
        raise InputError("Parameter `dt`: the sampling interval (s) is required")
    return check_positive(dt, "dt")


def check_n_modes(n_modes) -> int | None:
    if n_modes is None:
        return None
    return check_positive(n_modes, "n_modes", integer=True)


def check_energy(energy) -> float:
    energy = check_positive(energy, "energy")
    if energy > 1:
        raise InputError(f"Parameter `energy`: must be in (0, 1], got {energy!r}")
    return energy


def check_tol(tol, name: str = "tol") -> float:
    tol = check_positive(tol, name)
    if tol >= 1:
        raise InputError(f"Parameter `{name}`: must be in (0, 1), got {tol!r}")
    return tol


def check_max_cond(max_cond) -> float:
    max_cond = check_positive(max_cond, "max_cond")
    if max_cond < 1:
        raise InputError(f"Parameter `max_cond`: must be >= 1, got {max_cond!r}")
    return max_cond


def check_solver(solver, solver_options) -> dict:
    """Known solver name; options as a dict (validated by the solver itself)."""
    if not isinstance(solver, str):
        raise InputError(f"Parameter `solver`: expected a name, got {solver!r}")
    check_choice(solver, "solver", available_solvers())
    if solver_options is None:
        return {}
    if not isinstance(solver_options, dict):
        raise InputError(
            f"Parameter `solver_options`: expected a dict of keyword options, got "
            f"{type(solver_options).__name__}"
        )
    return dict(solver_options)


def select_basis(W: np.ndarray, n_modes, basis, *, energy: float | None = None):
    """The ``(m, k)`` basis a method works in, with the POVs and POCs of ``W`` in it.

    Parameters
    ----------
    W : (m, n) ndarray
        First (or only) data set.
    n_modes : int or None
        Requested ``k``. ``None``: ``basis.shape[1]`` if a basis is given, else the
        smallest ``k`` capturing ``energy`` (Eq. 2.3, σ-based); if ``energy`` is also None
        the caller must pass ``n_modes``.
    basis : (m, k) array_like or None
        Orthonormal basis replacing the POMs of ``W``.

    Returns
    -------
    U : (m, k) ndarray
    povs : (k,) ndarray
        POVs of ``W`` (with a basis: the norms ``‖u_iᵀ W‖``).
    pocs : (n, k) ndarray
        POC histories of ``W`` (with a basis: ``Wᵀu_i / ‖u_iᵀ W‖``, not orthogonal in
        general; a zero history stays zero).
    """
    m = W.shape[0]
    if basis is not None:
        U = check_orthonormal(basis, "basis", n_rows=m)
        if n_modes is not None and n_modes != U.shape[1]:
            raise InputError(
                f"Parameter `n_modes`: {n_modes} differs from the {U.shape[1]} columns of "
                "`basis` (give one or make them agree)"
            )
        Vh = U.T @ W
        povs = np.linalg.norm(Vh, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            pocs = np.where(povs[:, None] > 0, Vh / povs[:, None], 0.0).T
        return U, povs, pocs
    full = snapshot_svd(W)
    rank = numerical_rank(full.povs, W.shape)
    if n_modes is None:
        if energy is None:
            raise InputError("Parameter `n_modes`: required")
        n_modes = n_modes_for_energy(full.povs, energy, kind="sigma")
    if n_modes > rank:
        raise InputError(
            f"Parameter `n_modes`: {n_modes} modes requested but the data set has numerical "
            f"rank {rank} (shape {W.shape}); use at most {rank} modes"
        )
    return full.modes[:, :n_modes], full.povs[:n_modes], full.pocs[:, :n_modes]


def modal_share_too_small(a: np.ndarray, scale: float, tol: float) -> np.ndarray:
    """Boolean mask of ``|a_i| <= tol·scale`` (a divisor too small to use)."""
    return np.abs(a) <= tol * scale


def as_int_list(idx) -> str:
    """'1, 3' from a boolean mask or indices (1-based, for messages)."""
    idx = np.flatnonzero(idx) if np.asarray(idx).dtype == bool else np.asarray(idx)
    return ", ".join(str(int(i) + 1) for i in idx)
