"""The dissertation's array forms of ``fit`` and ``predict``: one adapter from arrays to records.

Every method fits on records and predicts from a record
(:class:`~podbench.core.records.Record`). The forms the dissertation and its MATLAB write —

* ``POVR().fit(W, x0)``, ``MDS().fit([W1, W2, …], x0=[…])`` (``x0``: the initial displacement
  ``w0`` in in, default each response's first column, or velocity ``v0`` in in/s, by the
  method's ``excitation``), ``predict(x0_new)``;
* ``SingleLoad().fit(W, F, dt=…)``, ``MultipleLoad().fit([W…], [F…], dt=…)`` (forces in lbf
  at the sensors), ``predict(F_new)``;
* ``MixedResponse().fit([Wa, Wb, Wc], w0=[…], v0=[…], F=[…], dt=…)``,
  ``predict(w0=…, v0=…, F=…)``

— are read here, once, into records: each method declares its form (:class:`ArrayForm`),
the arrays are checked as before (``Parameter `W[1]```, ``Parameter `x0```) and turned into
the records the method then fits on, so the array form and the record form give the same
model, band included.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from podbench.core.records import Record, as_record, is_record
from podbench.errors import InputError
from podbench.sysid.methods.checks import (
    check_datasets,
    check_dt,
    check_force,
    check_forces,
    check_profile,
    check_profiles,
    check_snapshots,
)

__all__ = ["ArrayForm", "training_records", "target_record", "is_record_input"]

FIELD_WORDS = {
    "W": "the displacements W (in)",
    "F": "the force matrix F (lbf)",
    "w0": "the initial displacement w0 (in)",
    "v0": "the initial velocity v0 (in/s)",
    "dt": "the sampling interval dt (s)",
    "u": "the measured inputs u",
    "y": "the measured outputs y",
}
"""What a record field holds, for messages."""
_PROFILE_WORDS = {"w0": "the initial displacement profile w0 (in)",
                  "v0": "the initial velocity profile v0 (in/s)"}


@dataclass(frozen=True)
class ArrayForm:
    """How a method's ``fit`` and ``predict`` read arrays.

    Attributes
    ----------
    positional : tuple of str
        ``fit``'s arguments after ``W``, in order: ``"x0"`` (the initial profile of the
        method's excitation, :attr:`PODMethod.initial_field`) or ``"F"``.
    keywords : tuple of str
        ``fit``'s keyword-only arrays (``"dt"``, ``"w0"``, ``"v0"``, ``"F"``).
    sets : bool
        ``fit`` takes a sequence of data sets (True) or one (False).
    target : str or None
        What ``predict(array)`` reads the array as (``"x0"`` or ``"F"``).
    target_keywords : tuple of str
        ``predict``'s keyword arrays (MR: ``w0``, ``v0``, ``F``).
    """

    positional: tuple[str, ...] = ()
    keywords: tuple[str, ...] = ()
    sets: bool = False
    target: str | None = None
    target_keywords: tuple[str, ...] = ()


def is_record_input(data) -> bool:
    """True if ``data`` is a record or a non-empty sequence of records (the record form of
    ``fit``), False for arrays (the dissertation's array form)."""
    if is_record(data):
        return True
    return isinstance(data, (list, tuple)) and bool(data) and all(is_record(r) for r in data)


def _field(method, name: str) -> str:
    """The record field of an array argument (``x0``: the method's initial profile)."""
    return method.initial_field if name == "x0" else name


def _given(method, form: ArrayForm, args: tuple, kwargs: dict) -> dict:
    """The array arguments by name; TypeError for an argument the form does not have."""
    fname = f"{type(method).__name__}.fit"
    if len(args) > len(form.positional):
        raise TypeError(f"{fname}() takes {1 + len(form.positional)} positional argument(s) "
                        f"but {1 + len(args)} were given")
    given = dict(zip(form.positional, args, strict=False))
    for key, value in kwargs.items():
        if key in given or key not in form.positional + form.keywords:
            raise TypeError(f"{fname}() got an unexpected keyword argument {key!r}")
        given[key] = value
    return {k: v for k, v in given.items() if v is not None}


def _checked(name: str, value, Ws: list, sets: bool):
    """An array argument checked as the dissertation's form always checked it."""
    m = Ws[0].shape[0]
    if name == "dt":
        return check_dt(value)
    if name == "F":
        return check_forces(value, Ws) if sets else [check_force(value, Ws[0], "F")]
    if sets:
        return check_profiles(value, len(Ws), m, name)
    return [check_profile(value, m, name)]


def training_records(method, data, args: tuple = (), kwargs: dict | None = None):
    """The training records of ``method.fit(data, *args, **kwargs)``: ``data`` itself in the
    record form, else the records the method's :class:`ArrayForm` makes of the arrays."""
    kwargs = kwargs or {}
    if getattr(method, "composite", False) and not args and not kwargs:
        return data  # one training set per part: each part reads its own
    form: ArrayForm | None = getattr(type(method), "array_form", None)
    given = _given(method, form, args, kwargs) if form is not None else \
        _given(method, ArrayForm(), args, kwargs)
    if is_record_input(data):
        for name in given:
            where = "w0 or v0" if name == "x0" else name
            raise InputError(f"Parameter `{name}`: give it in the records (their {where}), "
                             "not beside them")
        return data
    if form is None:
        raise InputError(
            f"Parameter `records`: expected a record or a sequence of records (objects with "
            f"W, F, w0, v0, dt such as podbench.Record), got {type(data).__name__}")
    Ws = check_datasets(data) if form.sets else [check_snapshots(data)]
    arrays = {name: _checked(name, value, Ws, form.sets) for name, value in given.items()}
    fields: dict = {_field(method, name): value for name, value in arrays.items()}
    for name in method.required_fields():
        if name in fields or name == "W":
            continue
        if name == "w0":  # a displacement response starts at its first sample
            fields["w0"] = [W[:, 0] for W in Ws]
            continue
        arg = "x0" if name == getattr(method, "initial_field", None) else name
        why = f" for excitation={method.excitation!r}" if arg == "x0" else ""
        words = _PROFILE_WORDS.get(name, FIELD_WORDS.get(name, name))
        raise InputError(f"Parameter `{arg}`: {words} of every data set is required{why}")
    dt = fields.pop("dt", None)
    recs = [Record(W=W, dt=dt, **{k: v[j] for k, v in fields.items()})
            for j, W in enumerate(Ws)]
    return recs if form.sets else recs[0]


def target_record(method, record, kwargs: dict) -> Record:
    """The target of ``method.predict(record, **kwargs)`` as a record: a record as it is;
    an array as the method's :attr:`ArrayForm.target` (the new initial profile or forces);
    keyword arrays (MR's ``w0``, ``v0``, ``F``) as the fields of one record."""
    form: ArrayForm | None = getattr(type(method), "array_form", None)
    name = f"{type(method).abbreviation or type(method).__name__}.predict"
    keys = form.target_keywords if form is not None else ()
    for key in kwargs:
        if key not in keys:
            raise TypeError(f"{name}() got an unexpected keyword argument {key!r}")
    fields = {k: v for k, v in kwargs.items() if v is not None}
    if fields and record is not None:
        raise InputError(f"{name}: give a record or the keywords {', '.join(keys)}, not both")
    if record is None:
        if keys and not fields:
            raise InputError(f"{name}: give at least one of {', '.join(f'`{k}`' for k in keys)}")
        if not fields:
            raise InputError(f"Parameter `record`: {name} needs the target record")
        return Record(**fields)
    if is_record(record):
        return as_record(record, "record")
    if form is None or form.target is None or isinstance(record, (str, Sequence)) and \
            not isinstance(record, (list, tuple)):
        raise InputError(f"Parameter `record`: expected a record (podbench.Record), got "
                         f"{type(record).__name__}")
    return Record(**{_field(method, form.target): np.asarray(record, dtype=float)})
