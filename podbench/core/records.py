"""Records: what an identification method sees of one test — arrays only.

:class:`Record` holds ``W, F, w0, v0, dt`` (no structure, no engine, no provenance), so the
methods of :mod:`podbench.methods` depend on nothing that produced the data. A simulated
:class:`~podbench.data.Response` is a record too (it has the same attributes), and so is any
object with those attributes: :func:`as_record` reads it.

Sampling convention (as everywhere in podbench): column ``j`` of ``W`` and ``F`` is at
``t_j = j·dt``, column 0 at ``t_0 = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError

__all__ = ["Record", "as_record", "is_record"]


class SensorSamples:
    """``n_sensors`` and ``n_samples`` of an object whose ``W`` is (sensors, samples)
    (:class:`Record` and :class:`~podbench.core.response.Response`)."""

    W: np.ndarray

    @property
    def n_samples(self) -> int:
        return self.W.shape[1]

    @property
    def n_sensors(self) -> int:
        return self.W.shape[0]


@dataclass(frozen=True, eq=False)
class Record(SensorSamples):
    """What an identification method sees of one test: arrays only (no structure, no engine).

    Every method of :mod:`podbench.methods` fits on a sequence of records and predicts from
    one (``fit(records, basis=None)``, ``predict(record)``); a :class:`Response` is a record
    too (it has the same attributes), and so is any object with attributes ``W, F, w0, v0,
    dt`` (a missing attribute counts as None).

    Attributes
    ----------
    W : (m, n) ndarray
        Displacements at the m sensors (in), column ``j`` at ``t_j = j·dt``.
    F : (m, n) ndarray or None
        Applied forces at the same sensors and times (lbf); None for a free response.
    w0, v0 : (m,) ndarray or None
        Initial displacement (in) and velocity (in/s) at the sensors.
    dt : float or None
        Sampling interval (s); required by the methods that deconvolve (SL, ML, MR).
    """

    W: np.ndarray
    F: np.ndarray | None = None
    w0: np.ndarray | None = None
    v0: np.ndarray | None = None
    dt: float | None = None

    def __post_init__(self):
        W = as_finite_array(self.W, "W", ndim=2)
        object.__setattr__(self, "W", W)
        if self.F is not None:
            F = as_finite_array(self.F, "F", ndim=2)
            if F.shape != W.shape:
                raise DimensionError(
                    f"Parameter `F`: shape {F.shape} differs from W's {W.shape} (forces are "
                    "sampled at the same sensors and times)"
                )
            object.__setattr__(self, "F", F)
        for name in ("w0", "v0"):
            a = getattr(self, name)
            if a is None:
                continue
            a = as_finite_array(a, name)
            if a.ndim == 2 and 1 in a.shape:
                a = a.ravel()
            elif a.ndim != 1:
                raise DimensionError(f"Parameter `{name}`: expected shape ({W.shape[0]},) (one "
                                     f"value per sensor), got {a.shape}")
            if a.shape[0] != W.shape[0]:
                raise DimensionError(
                    f"Parameter `{name}`: {a.shape[0]} entries, W has {W.shape[0]} rows (one "
                    "value per sensor)"
                )
            object.__setattr__(self, name, a)
        if self.dt is not None:
            object.__setattr__(self, "dt", check_positive(self.dt, "dt"))


def as_record(obj, name: str = "record") -> Record:
    """``obj`` as a :class:`Record`: a Record is returned as is; any other object with a
    ``W`` attribute (a :class:`Response`, a user's class) is read through its attributes
    ``W, F, w0, v0, dt`` (absent ones are None). Raises InputError naming ``name``."""
    if isinstance(obj, Record):
        return obj
    if not hasattr(obj, "W"):
        raise InputError(
            f"Parameter `{name}`: expected a record (an object with attributes W, F, w0, v0, "
            f"dt, e.g. podbench.Record or podbench.Response), got {type(obj).__name__}"
        )
    try:
        return Record(W=obj.W, F=getattr(obj, "F", None), w0=getattr(obj, "w0", None),
                      v0=getattr(obj, "v0", None), dt=getattr(obj, "dt", None))
    except InputError as exc:
        raise type(exc)(f"{name}: {exc}") from None


def is_record(obj) -> bool:
    """True for a Record or any object with a 2-D ``W`` attribute (a record-like object)."""
    return isinstance(obj, Record) or (hasattr(obj, "W") and np.ndim(obj.W) == 2)
