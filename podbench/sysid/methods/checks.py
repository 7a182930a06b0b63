"""Input checks of the methods' arrays (one wording for the record and the array forms)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError

__all__ = ["check_snapshots", "check_datasets", "check_profile", "check_profiles",
           "check_forces", "check_force", "check_new_force", "check_dt"]


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
    _check_count(xs, n_sets, name, "profiles")
    return [check_profile(x, m, f"{name}[{j}]") for j, x in enumerate(xs)]


def check_forces(Fs, Ws, name: str = "F") -> list[np.ndarray]:
    """One force matrix per data set, each of the shape of its snapshot matrix."""
    if isinstance(Fs, np.ndarray) and Fs.ndim == 2:
        raise DimensionError(
            f"Parameter `{name}`: expected a sequence of (m, n) force matrices, got a single "
            f"2-D array of shape {Fs.shape}; wrap it in a list"
        )
    _check_count(Fs, len(Ws), name, "force matrices")
    pairs = enumerate(zip(Fs, Ws, strict=True))
    return [check_force(F, W, f"{name}[{j}]") for j, (F, W) in pairs]


def _check_count(xs, n_sets: int, name: str, what: str) -> None:
    """``xs`` is a sequence of ``n_sets`` items, one per data set."""
    try:
        count = len(xs)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected a sequence of {what}") from None
    if count != n_sets:
        raise DimensionError(
            f"Parameter `{name}`: expected {n_sets} {what} (one per data set), got {count}"
        )


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
