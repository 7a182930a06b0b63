"""Plain result containers.

Sampling convention (used everywhere in podbench): sample ``j`` is at ``t_j = j·dt`` for
``j = 0 … n-1``; column 0 of every snapshot matrix is the initial state ``t_0 = 0``.
A snapshot matrix ``W`` has one row per sensor and one column per sample (Eq. 2.1); the
force matrix ``F`` (Eq. 3.37) is sampled at the same sensors and times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.core.records import Record, as_record, is_record
from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError

__all__ = ["Record", "Response", "as_record", "displacement_norm", "is_record",
           "norm_percent_error"]


def displacement_norm(W: np.ndarray) -> np.ndarray:
    """Eq. 4.1: ``‖w[t_i]‖₂`` for every column of ``W`` (inches), shape (n,)."""
    return np.linalg.norm(np.asarray(W, dtype=float), axis=0)


def norm_percent_error(W_true: np.ndarray, W_pred: np.ndarray) -> np.ndarray:
    """Eq. 4.2: percent error of the displacement norm at every sample, shape (n,).

    ``100·|‖w_FE‖ − ‖w_pred‖| / ‖w_FE‖``; where ``‖w_FE[t_i]‖ = 0`` (e.g. the first sample
    of a forced response that starts at rest) the value is NaN, not Inf.
    """
    a = displacement_norm(W_true)
    b = displacement_norm(W_pred)
    with np.errstate(divide="ignore", invalid="ignore"):
        pe = 100.0 * np.abs(a - b) / a
    pe[a == 0] = np.nan
    return pe


def _check_sampling(t: np.ndarray, dt: float) -> None:
    """Check the sampling convention ``t_j = j·dt`` (``t_0 = 0``) to a relative tolerance
    ``1e-9·n`` (roundoff of a sum of n steps is far smaller; a wrong ``dt`` is far larger)."""
    n = t.size
    if n == 0:
        return
    ideal = np.arange(n) * dt
    tol = 1e-9 * n * dt * np.maximum(np.arange(n), 1)
    bad = np.flatnonzero(np.abs(t - ideal) > tol)
    if bad.size:
        j = int(bad[0])
        raise InputError(
            f"Parameter `t`: expected t_j = j·dt with t_0 = 0 (dt = {dt:g} s), got "
            f"t[{j}] = {t[j]:.9g} s instead of {ideal[j]:.9g} s"
        )


@dataclass(frozen=True, eq=False, init=False)
class Response(Record):
    """A simulated (or measured) response: a :class:`~podbench.core.records.Record` in the
    dissertation's form (displacements ``W`` in in, forces ``F`` in lbf at the same sensors)
    with its sample times and provenance.

    Attributes
    ----------
    t : (n,) ndarray
        Sample times ``t_j = j·dt`` (s), ``t_0 = 0``; checked to a relative ``1e-9·n``.
    W : (n_sensors, n) ndarray
        Displacements at the sensors (in, or rad for rotational sensors).
    F : (n_sensors, n) ndarray
        Applied force sampled at the sensors (lbf).
    w0, v0 : (n_sensors,) ndarray
        Initial displacement (in) and velocity (in/s) at the sensors.
    dt : float
        Time step (s), positive and finite.
    q, qd : (n_dofs, n) ndarray or None
        Full DOF displacement and velocity histories when the engine provides them.
    structure, engine, label : str
        Provenance (``label`` is also the record's ``name``).
    """

    t: np.ndarray = None  # type: ignore[assignment]  # a field here, Record's property there
    q: np.ndarray | None
    qd: np.ndarray | None
    structure: str
    engine: str
    label: str

    def __init__(self, t=None, W=None, F=None, w0=None, v0=None, dt=None, q=None, qd=None,
                 structure: str = "", engine: str = "", label: str = "", **fields):
        if fields:  # dataclasses.replace passes the record's own fields (u, y, ...)
            fields.setdefault("name", label or "response")
            for key, value in (("y", W), ("u", F)):  # replace(response, W=...) renames
                if value is not None:
                    fields[key] = value
            Record.__init__(self, dt=dt, w0=w0, v0=v0, **fields)
        else:
            W = as_finite_array(W, "W", ndim=2)
            F = as_finite_array(F, "F", ndim=2)
            if F.shape != W.shape:
                raise DimensionError(f"Response: F has shape {F.shape}, W has shape {W.shape}")
            for name, a in (("w0", w0), ("v0", v0)):
                a = as_finite_array(a, name, ndim=1)
                if a.shape[0] != W.shape[0]:
                    raise DimensionError(
                        f"Response: `{name}` has {a.shape[0]} entries, W has {W.shape[0]} rows"
                    )
            dt = check_positive(dt, "dt")
            Record.__init__(self, W=W, F=F, w0=w0, v0=v0, dt=dt, name=label or "response")
        t = as_finite_array(t, "t", ndim=1)
        if t.shape[0] != self.W.shape[1]:
            raise DimensionError(f"Response: {t.shape[0]} times but W has {self.W.shape[1]} "
                                 "columns")
        _check_sampling(t, float(self.dt))
        for key, value in (("t", t), ("q", q), ("qd", qd), ("structure", structure),
                           ("engine", engine), ("label", label)):
            object.__setattr__(self, key, value)

    def displacement_norm(self) -> np.ndarray:
        """Eq. 4.1 at every sample (in)."""
        return displacement_norm(self.W)

    def to_pandas(self):
        """A long-format DataFrame with columns ``t, sensor, w, f``."""
        import pandas as pd

        n_s, n = self.W.shape
        return pd.DataFrame(
            {
                "t": np.tile(self.t, n_s),
                "sensor": np.repeat(np.arange(n_s), n),
                "w": self.W.ravel(),
                "f": self.F.ravel(),
            }
        )

    def plot(self, ax=None, **kwargs):
        """Plot the displacement norm (Eq. 4.1) against time in ms; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.plot(1e3 * self.t, self.displacement_norm(), label=self.label or None, **kwargs)
        ax.set_xlabel("Time, ms")
        ax.set_ylabel("Displacement norm, in")
        return ax

