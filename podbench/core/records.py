"""The record: what an identification method sees of one test — arrays with their units.

A :class:`Record` holds the inputs ``u`` (n_in × n) and the outputs ``y`` (n_out × n) of one
test, each side with its quantity (:data:`~podbench.core.units.QUANTITIES`), unit and channel
names, the sampling interval ``dt`` (s), optionally the initial displacement ``w0`` and
velocity ``v0`` at the output channels, and a ``name`` (where it came from, for messages).
A free response has no inputs; a target to predict may have no outputs.

The dissertation's record — displacements ``W`` (in) and forces ``F`` (lbf) at the same
sensors — is the case "forces at the output sensors": ``Record(W=..., F=..., dt=...)``
builds it (``y = W``, ``u = F``, input channels = output channels) and ``.W``, ``.F`` read
it back. A simulated :class:`~podbench.core.response.Response` is a Record.

Units: a record is in one unit system, ``"SI"`` or ``"inch-lbf"`` (:mod:`podbench.core.units`);
:func:`convert` converts it once, where the data come in, and :func:`check_records` refuses a
study that mixes systems, channels or ``dt`` (one line naming the record and the field).

Sampling: column ``j`` is at ``t_j = j·dt``, ``t_0 = 0`` (as everywhere in podbench).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from podbench import _compat
from podbench.core.units import (  # the unit tables, read here by older code too
    INCH,
    LBF,
    QUANTITIES,
    UNITS,
    normalize_unit,
    system_unit,
    unit_factor,
    unit_system,
)
from podbench.core.validation import as_finite_array, check_positive
from podbench.errors import DimensionError, InputError

__all__ = ["Record", "as_record", "as_records", "is_record", "convert", "check_compatible",
           "check_records", "unit_system_of", "UNITS", "QUANTITIES", "LBF", "INCH",
           "normalize_unit", "unit_system"]

_SIDES = ("input", "output")


def _finite(a, where: str) -> np.ndarray:
    """A finite 2-D (channels × samples) array; a 1-D array is one channel."""
    try:
        a = np.array(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected numbers") from None
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2:
        raise DimensionError(f"{where}: expected a 2-D array (channels × samples), got shape "
                             f"{a.shape}")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        raise InputError(f"{where}: NaN or Inf at index {tuple(int(x) for x in bad[0])} "
                         f"(channel {int(bad[0][0])}, sample {int(bad[0][1])})")
    return a


def _channel_names(value, count: int, where: str) -> tuple[str, ...]:
    if value is None:
        return tuple(str(i) for i in range(count))
    names = tuple(str(v).strip() for v in np.atleast_1d(np.asarray(value)).ravel())
    if len(names) != count:
        raise DimensionError(f"{where}: {len(names)} names for {count} channels")
    if len(set(names)) != len(names):
        raise InputError(f"{where}: repeated channel names {list(names)}")
    return names


@dataclass(frozen=True, eq=False, init=False)
class Record:
    """One test: inputs ``u`` and outputs ``y`` with their quantities, units and channels.

    Parameters
    ----------
    u : (n_in, n) array_like, optional
        Measured inputs (a force at a point, a base acceleration), column ``j`` at
        ``t_j = j·dt``; None for a free response (no inputs).
    y : (n_out, n) array_like, optional
        Measured outputs at the same times; None for a target without measured outputs.
    dt : float
        Sampling interval (s); required with ``u``/``y`` (a measured record has one), optional
        in the dissertation's form (POVR and MDS need none).
    W, F : (m, n) array_like, optional
        The dissertation's form instead of ``u``/``y``: displacements ``W`` (in) and forces
        ``F`` (lbf) at the same m sensors (``y = W``, ``u = F``, one channel name per sensor
        on both sides); ``F`` None for a free response.
    w0, v0 : (n_out,) array_like, optional
        Initial displacement and velocity at the output channels (in the outputs' length
        unit, and per second).
    input_units, output_units : str
        Units of ``u`` and ``y`` (:data:`~podbench.core.units.UNITS`; default ``"lbf"`` and
        ``"in"`` in the dissertation's form); the quantities follow from them unless given.
    input_channels, output_channels : sequence of str, optional
        Channel names (default ``"0", "1", …``).
    input_quantity, output_quantity : str, optional
        :data:`~podbench.core.units.QUANTITIES` (default: the quantity of the unit).
    sensor_positions : (n_out,) array_like, optional
        Positions of the output sensors along the structure (in), where known.
    name : str
        Where the record came from (a file name), used in messages.

    Notes
    -----
    Errors are one line naming the parameter (the dissertation's form: ``Parameter `W```) or
    the record and the field (``x.npz: field `inputs```).
    """

    u: np.ndarray | None
    y: np.ndarray | None
    dt: float | None
    w0: np.ndarray | None
    v0: np.ndarray | None
    input_quantity: str | None
    input_units: str | None
    input_channels: tuple[str, ...] | None
    output_quantity: str | None
    output_units: str | None
    output_channels: tuple[str, ...] | None
    sensor_positions: np.ndarray | None
    name: str

    def __init__(self, u=None, y=None, dt=None, *, W=None, F=None, w0=None, v0=None,
                 input_quantity=None, input_units=None, input_channels=None,
                 output_quantity=None, output_units=None, output_channels=None,
                 sensor_positions=None, name="record"):
        set_ = object.__setattr__
        set_(self, "name", str(name))
        if W is not None or F is not None or (u is None and y is None):
            if u is not None or y is not None:
                raise InputError("Record: give the dissertation's W, F or the inputs and "
                                 "outputs u, y, not both")
            u, y = self._dissertation_arrays(W, F, w0, v0)
            input_units = input_units or ("lbf" if u is not None else None)
            output_units = output_units or "in"
            if u is not None:  # forces at the output sensors: one channel name per sensor
                if output_channels is None and input_channels is None:
                    output_channels = tuple(str(i) for i in range(u.shape[0]))
                output_channels = output_channels if output_channels is not None \
                    else input_channels
                input_channels = input_channels if input_channels is not None \
                    else output_channels
        else:
            u, y = self._measured_arrays(u, y)
            dt = self._measured_dt(dt)
        set_(self, "u", u)
        set_(self, "y", y)
        if dt is not None:
            dt = check_positive(dt, "dt") if self._style == "parameter" else dt
        set_(self, "dt", dt)
        given = {"input": (input_quantity, input_units, input_channels),
                 "output": (output_quantity, output_units, output_channels)}
        for side in _SIDES:
            self._set_side(side, *given[side])
        for key, value in (("w0", w0), ("v0", v0)):
            set_(self, key, self._profile(key, value))
        set_(self, "sensor_positions", self._profile("sensor_positions", sensor_positions))
        unit_system_of(self)

    # ------------------------------------------------------------------ construction
    @property
    def _style(self) -> str:
        """How errors name a field: ``"parameter"`` (the dissertation's W/F form, a Python
        call) or ``"field"`` (a measured record, named after its file)."""
        return self.__dict__.get("_style_", "field")

    def _where(self, field: str) -> str:
        if self._style == "parameter":
            return f"Parameter `{field}`"
        return f"{self.name}: field `{field}`"

    def _dissertation_arrays(self, W, F, w0, v0):
        """``(u, y)`` of the dissertation's form, checked as :class:`Record` always has."""
        object.__setattr__(self, "_style_", "parameter")
        Wa = None if W is None else as_finite_array(W, "W", ndim=2)
        Fa = None if F is None else as_finite_array(F, "F", ndim=2)
        if Wa is not None and Fa is not None and Fa.shape != Wa.shape:
            raise DimensionError(
                f"Parameter `F`: shape {Fa.shape} differs from W's {Wa.shape} (forces are "
                "sampled at the same sensors and times)"
            )
        if Wa is None and Fa is None and w0 is None and v0 is None:
            raise InputError("Record: give the outputs (y, or the dissertation's W), the "
                             "inputs (u, or F) or an initial condition (w0, v0)")
        return Fa, Wa

    def _measured_arrays(self, u, y):
        nm = self.name
        ua = None if u is None else _finite(u, f"{nm}: field `inputs`")
        ya = None if y is None else _finite(y, f"{nm}: field `outputs`")
        if ua is not None and ya is not None and ya.shape[1] != ua.shape[1]:
            raise DimensionError(f"{nm}: field `outputs`: {ya.shape[1]} samples, the inputs "
                                 f"have {ua.shape[1]}")
        first = ua if ua is not None else ya
        key = "inputs" if ua is not None else "outputs"
        if first is not None and first.shape[1] < 2:
            raise InputError(f"{nm}: field `{key}`: {first.shape[1]} sample(s), expected at "
                             "least 2")
        return ua, ya

    def _measured_dt(self, dt) -> float:
        nm = self.name
        try:
            value = float(np.asarray(dt, dtype=float).reshape(()))
        except (TypeError, ValueError):
            raise InputError(f"{nm}: field `dt`: expected one number (s), got "
                             f"{dt!r}") from None
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{nm}: field `dt`: expected a positive finite interval (s), "
                             f"got {value!r}")
        return value

    def _set_side(self, side: str, quantity, unit, channels) -> None:
        """Quantity, unit and channel names of one side, checked against its array."""
        arr = self.u if side == "input" else self.y
        count = None if arr is None else arr.shape[0]
        if side == "output" and count is None and self.u is not None and \
                self._style == "parameter":
            count = self.u.shape[0]  # forces at the output sensors: one channel each
        if unit is None and count is None and arr is None and quantity is None:
            for key in ("quantity", "units", "channels"):
                object.__setattr__(self, f"{side}_{key}", None)
            if side == "output" and channels is not None:
                object.__setattr__(self, "output_channels", tuple(str(c) for c in channels))
            return
        q, unit = normalize_unit(unit, self._where(f"{side}_units"))
        if quantity is not None and quantity != q:
            raise InputError(f"{self._where(f'{side}_quantity')}: {quantity!r} does not match "
                             f"the unit {unit!r} (a {q})")
        object.__setattr__(self, f"{side}_units", unit)
        object.__setattr__(self, f"{side}_quantity", q)
        if count is None:
            names = None if channels is None else tuple(str(c) for c in channels)
        else:
            names = _channel_names(channels, count, self._where(f"{side}_channels"))
        object.__setattr__(self, f"{side}_channels", names)

    def _profile(self, key: str, value):
        """A per-output-channel vector (``w0``, ``v0``, ``sensor_positions``) or None."""
        if value is None:
            return None
        if self._style == "parameter":
            a = as_finite_array(value, key)
        else:
            try:
                a = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise InputError(f"{self._where(key)}: expected numbers") from None
            if not np.all(np.isfinite(a)):
                raise InputError(f"{self._where(key)}: NaN or Inf")
        if a.ndim == 2 and 1 in a.shape:
            a = a.ravel()
        m = self.n_outputs
        if a.ndim != 1:
            raise DimensionError(f"{self._where(key)}: expected shape ({m},) (one value per "
                                 f"sensor), got {a.shape}")
        if m is not None and a.shape[0] != m:
            raise DimensionError(f"{self._where(key)}: {a.shape[0]} entries, W has {m} rows "
                                 "(one value per sensor)")
        return a

    # ------------------------------------------------------------------ views
    @property
    def n_samples(self) -> int | None:
        """Samples ``n`` (None for a target that states only an initial condition)."""
        arr = self.y if self.y is not None else self.u
        return None if arr is None else arr.shape[1]

    @property
    def n_inputs(self) -> int:
        return 0 if self.u is None else self.u.shape[0]

    @property
    def n_outputs(self) -> int | None:
        if self.y is not None:
            return self.y.shape[0]
        if self.output_channels is not None:
            return len(self.output_channels)
        for key in ("w0", "v0"):
            a = self.__dict__.get(key)
            if a is not None:
                return a.shape[0]
        return None

    @property
    def n_sensors(self) -> int | None:
        """Output channels ``m`` (the dissertation's sensors)."""
        return self.n_outputs

    @property
    def t(self) -> np.ndarray:
        """Sample times ``j·dt`` (s)."""
        return np.arange(self.n_samples or 0) * (self.dt or 1.0)

    @property
    def units(self) -> str:
        """The unit system (``"SI"``, ``"inch-lbf"``; ``"any"`` when only strain)."""
        return unit_system_of(self)

    @property
    def sensors(self) -> tuple[str, ...] | None:
        """The output channel names (the dissertation's sensors)."""
        return self.output_channels

    @property
    def W(self) -> np.ndarray | None:
        """The output snapshot matrix ``y`` (Eq. 2.1): the dissertation's displacements ``W``
        (in) for a displacement record."""
        return self.y

    @property
    def F(self) -> np.ndarray | None:
        """The forces at the output sensors (``u`` of a :attr:`collocated` record), else None."""
        return self.u if self.collocated else None

    @property
    def collocated(self) -> bool:
        """Whether the inputs are forces at the output channels (the dissertation's record)."""
        return (self.u is not None and self.input_quantity == "force"
                and self.output_channels is not None
                and self.input_channels == self.output_channels)

    @property
    def free(self) -> bool:
        """Whether the record is a free response (no inputs)."""
        return self.u is None

    def replace(self, **changes) -> Record:
        """A copy with ``changes`` (``W``, ``F`` name ``y``, ``u`` as in the constructor)."""
        for old, new in (("W", "y"), ("F", "u")):
            if old in changes:
                changes[new] = changes.pop(old)
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return type(self).from_fields(**{**fields, **changes})

    @classmethod
    def from_fields(cls, **fields) -> Record:
        """The record whose dataclass fields are ``fields`` (what :meth:`replace` and a model
        file rebuild). A free response without ``dt`` is the dissertation's form (POVR and
        MDS need no sampling interval), so its outputs are read as ``W``."""
        if fields.get("u") is None and fields.get("dt") is None and fields.get("y") is not None:
            fields = {**fields, "W": fields["y"]}
            del fields["y"], fields["u"]
        return cls(**fields)


def unit_system_of(rec: Record) -> str:
    """The unit system of a record; InputError naming the record when it mixes systems."""
    units = [str(u) for u in (rec.input_units, rec.output_units) if u is not None]
    try:
        return unit_system(*units) if units else "any"
    except InputError as exc:
        raise InputError(f"{rec.name}: fields `input_units`, `output_units`: {exc}") from None


def convert(rec: Record, system: str) -> Record:
    """The record in ``system`` (``"SI"`` or ``"inch-lbf"``): values scaled, units renamed
    (the initial conditions with the outputs' length unit)."""
    if system not in ("SI", "inch-lbf"):
        raise InputError(f"unit system: expected 'SI' or 'inch-lbf', got {system!r}")
    out = {}
    for side, arr in (("input", rec.u), ("output", rec.y)):
        q = getattr(rec, f"{side}_quantity")
        unit = getattr(rec, f"{side}_units")
        if q is None:
            out[side] = (arr, unit, 1.0)
            continue
        new = system_unit(q, system)
        factor = unit_factor(q, unit, new)
        out[side] = (None if arr is None else arr * factor, new, factor)
    changes: dict = dict(u=out["input"][0], y=out["output"][0], input_units=out["input"][1],
                         output_units=out["output"][1])
    if rec.output_quantity == "displacement":
        f = out["output"][2]
        for key in ("w0", "v0"):
            if getattr(rec, key) is not None:
                changes[key] = getattr(rec, key) * f
    return dataclasses.replace(rec, **changes)


def as_record(obj, name: str = "record") -> Record:
    """``obj`` as a :class:`Record`: a Record is returned as is; any other object with a
    ``W`` attribute (a user's class) is read through its attributes ``W, F, w0, v0, dt``
    (absent ones are None). Raises InputError naming ``name``."""
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


def as_records(records, name: str = "records") -> list[Record]:
    """A record or a sequence of records as a list of :class:`Record` (each checked by
    :func:`as_record`); InputError naming ``name`` for anything else or none."""
    if isinstance(records, Record) or is_record(records):
        return [as_record(records, name)]
    try:
        recs = list(records)
    except TypeError:
        raise InputError(f"Parameter `{name}`: expected records") from None
    if not recs:
        raise InputError(f"Parameter `{name}`: no record given")
    return [as_record(r, f"{name}[{j}]") for j, r in enumerate(recs)]


def is_record(obj) -> bool:
    """True for a Record or any object with a 2-D ``W`` attribute (a record-like object)."""
    return isinstance(obj, Record) or (hasattr(obj, "W") and np.ndim(obj.W) == 2)


def _check_side(ref: Record, rec: Record, side: str) -> None:
    nm = rec.name
    a, b = getattr(ref, f"{side}_channels"), getattr(rec, f"{side}_channels")
    if a != b:
        absent = [c for c in a or () if c not in (b or ())]
        what = (f"channel(s) {', '.join(absent)} absent" if absent
                else f"{list(b or ())} instead of {list(a or ())}")
        raise InputError(f"{nm}: field `{side}_channels`: {what} (the training records "
                         f"have {list(a or ())})")
    for key in ("quantity", "units"):
        x, y = getattr(ref, f"{side}_{key}"), getattr(rec, f"{side}_{key}")
        if x != y:
            raise InputError(f"{nm}: field `{side}_{key}`: {y!r} differs from {ref.name}'s "
                             f"{x!r} (convert where the data come in)")


def check_compatible(ref: Record, rec: Record, *, role: str = "target",
                     need_outputs: bool = False, min_samples: int = 2) -> None:
    """Check ``rec`` against the reference (training) record: one line naming the file and
    the field (``dt``, channels, units, quantity, length) on the first difference."""
    nm = rec.name
    if rec.dt is not None and ref.dt is not None and \
            not np.isclose(rec.dt, ref.dt, rtol=1e-9, atol=0.0):
        raise InputError(f"{nm}: field `dt`: {rec.dt:g} s differs from {ref.name}'s "
                         f"{ref.dt:g} s")
    if (rec.u is None) != (ref.u is None):
        have = "has no inputs" if rec.u is None else "has inputs"
        raise InputError(f"{nm}: field `inputs`: the record {have}, {ref.name} "
                         f"{'does' if ref.u is not None else 'does not'} (free responses and "
                         "forced records do not mix)")
    if rec.u is not None:
        _check_side(ref, rec, "input")
    if rec.y is None:
        if need_outputs:
            raise InputError(f"{nm}: field `outputs`: missing ({role} records need "
                             "measured outputs)")
    else:
        _check_side(ref, rec, "output")
    n = rec.n_samples
    if n is not None and n < min_samples:
        key = "inputs" if rec.u is not None else "outputs"
        raise InputError(f"{nm}: field `{key}`: {n} samples, the model needs at "
                         f"least {min_samples}")


def check_records(train, targets=(), *, min_samples: int = 2,
                  targets_need_outputs: bool = False) -> None:
    """Every training record and every target against the first training record."""
    train = list(train)
    if not train:
        raise InputError("no training record given")
    ref = train[0]
    if ref.y is None:
        raise InputError(f"{ref.name}: field `outputs`: missing (training records need "
                         "measured outputs)")
    for j, rec in enumerate(train):
        check_compatible(ref, rec, role="training", need_outputs=True, min_samples=min_samples)
        if not np.any(rec.y):  # no response: every POD and kernel fit has nothing to work on
            raise InputError(f"{rec.name or f'training record {j}'}: field `outputs`: zero "
                             "throughout (a training record needs a measured response to "
                             "identify from)")
    for rec in targets:
        check_compatible(ref, rec, need_outputs=targets_need_outputs, min_samples=min_samples)


def __getattr__(name: str):
    """Retired names of this module (:data:`podbench._compat.RETIRED`)."""
    return _compat.retired(__name__, name)
