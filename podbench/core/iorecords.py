"""Input/output records: measured (or simulated) inputs ``u`` and outputs ``y`` with units.

Chapter 6 of the dissertation: "in many cases, vibration tests are performed by applying base
excitations instead of loads. Acceleration, strain or stress output may be of more interest
than displacements." An :class:`IORecord` holds

* ``u`` (n_in × n): the measured inputs — a force at a point, or a base acceleration;
* ``y`` (n_out × n, or None for a target without measured outputs): the measured outputs of
  one named quantity (displacement, velocity, acceleration, strain);
* ``dt`` (s), the quantity and the unit of each side, and the channel names.

Today's :class:`~podbench.records.Record` (``W`` in in, ``F`` in lbf at the same sensors) is
the special case ``u = F`` (force, lbf), ``y = W`` (displacement, in), input channels = output
channels: :func:`from_record`.

Units: every record carries them; :data:`UNITS` lists the units podbench knows for each
quantity and their SI factor. A record is in one unit system, ``"SI"`` or ``"inch-lbf"``
(strain is dimensionless and fits both); :func:`convert` converts a record once, where the
data come in, and a study never mixes systems (:func:`check_compatible`).

Sampling: column ``j`` is at ``t_j = j·dt``, ``t_0 = 0`` (as everywhere in podbench).

Files (:func:`read_io_record`, :func:`write_io_record`): CSV and UFF 58 (layouts in
:mod:`podbench.core.iofiles`), or ``.npz`` / ``.mat`` with variables
``inputs`` (n_in × n), ``outputs`` (n_out × n; optional for a target), ``dt``,
``input_channels``, ``output_channels`` (names or station numbers), ``input_units``,
``output_units`` and optionally ``input_quantity``, ``output_quantity`` (otherwise read from
the units). The shared Painter Street files are read as they are; they carry no unit
variable (their README states m/s²), so a reader gives the units it knows explicitly
(``input_units="m/s^2"``): a record without units is refused. Every error is one line that
names the file and the variable, before any fitting.
"""

from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from podbench.core.atomic import atomic_write_bytes
from podbench.core.iofiles import IO_SUFFIXES, read_csv_vars, read_uff_vars, write_csv, write_uff
from podbench.errors import DimensionError, InputError

__all__ = ["IORecord", "UNITS", "QUANTITIES", "normalize_unit", "unit_system", "convert",
           "from_record", "read_io_record", "write_io_record", "check_compatible",
           "check_records"]

QUANTITIES = ("force", "displacement", "velocity", "acceleration", "strain", "voltage")
"""The quantities an input or output channel can measure (``voltage``: a signal such as a
shaker generator's reference, in V, a unit of both systems)."""

LBF = 4.4482216152605
"""One pound-force in newtons (exact by definition of the lbf and the standard gravity)."""
INCH = 0.0254
"""One inch in metres (exact)."""

UNITS: dict[str, dict[str, tuple[str, float]]] = {
    "force": {"N": ("SI", 1.0), "lbf": ("inch-lbf", LBF)},
    "displacement": {"m": ("SI", 1.0), "in": ("inch-lbf", INCH)},
    "velocity": {"m/s": ("SI", 1.0), "in/s": ("inch-lbf", INCH)},
    "acceleration": {"m/s^2": ("SI", 1.0), "in/s^2": ("inch-lbf", INCH)},
    "strain": {"strain": ("any", 1.0)},
    "voltage": {"V": ("any", 1.0)},
}
"""Quantity → unit → (unit system, factor to SI). ``"any"``: fits both (strain, volts)."""

_ALIASES = {"m/s2": "m/s^2", "m/s²": "m/s^2", "m s^-2": "m/s^2", "in/s2": "in/s^2",
            "in/s²": "in/s^2", "inch": "in", "inches": "in", "newton": "N", "lb": "lbf",
            "in/in": "strain", "m/m": "strain", "-": "strain", "1": "strain"}

_SYSTEM_UNIT = {(q, system): u for q, table in UNITS.items() for u, (own, _) in table.items()
                for system in (("SI", "inch-lbf") if own == "any" else (own,))}
"""(quantity, unit system) → the unit podbench converts to."""


def normalize_unit(unit, where: str = "unit") -> tuple[str, str]:
    """``(quantity, unit)`` of a unit string (aliases such as ``m/s2`` accepted).

    Raises
    ------
    InputError
        Missing or unknown unit, naming ``where``.
    """
    if unit is None or (isinstance(unit, str) and not unit.strip()):
        raise InputError(f"{where}: missing (give the unit, e.g. 'm/s^2' or 'in/s^2')")
    u = str(unit).strip()
    u = _ALIASES.get(u, _ALIASES.get(u.lower(), u))
    for quantity, table in UNITS.items():
        if u in table:
            return quantity, u
    known = ", ".join(u for t in UNITS.values() for u in t)
    raise InputError(f"{where}: unknown unit {unit!r} (known: {known})")


def unit_system(*units: str) -> str:
    """The unit system of units (``"SI"``, ``"inch-lbf"`` or ``"any"`` for strain only).

    Raises InputError for a mix of systems."""
    systems = {UNITS[normalize_unit(u)[0]][normalize_unit(u)[1]][0] for u in units} - {"any"}
    if len(systems) > 1:
        raise InputError(f"units {', '.join(units)} mix unit systems "
                         f"({', '.join(sorted(systems))}); convert where the data come in")
    return systems.pop() if systems else "any"


def _channels(value, count: int, where: str) -> tuple[str, ...]:
    if value is None:
        return tuple(str(i) for i in range(count))
    names = tuple(str(v).strip() for v in np.atleast_1d(np.asarray(value)).ravel())
    if len(names) != count:
        raise DimensionError(f"{where}: {len(names)} names for {count} channels")
    if len(set(names)) != len(names):
        raise InputError(f"{where}: repeated channel names {list(names)}")
    return names


def _finite(a, where: str) -> np.ndarray:
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


@dataclass(frozen=True, eq=False)
class IORecord:
    """One test: inputs ``u`` and outputs ``y`` with their quantities, units and channels.

    Attributes
    ----------
    u : (n_in, n) ndarray
        Measured inputs, column ``j`` at ``t_j = j·dt``.
    y : (n_out, n) ndarray or None
        Measured outputs at the same times (None: a target to predict, nothing to compare).
    dt : float
        Sampling interval (s).
    input_units, output_units : str
        Units of ``u`` and ``y`` (:data:`UNITS`); the quantities follow from them unless
        given.
    input_channels, output_channels : tuple of str
        Channel names (default ``"0", "1", …``).
    input_quantity, output_quantity : str
        :data:`QUANTITIES` (default: the quantity of the unit).
    name : str
        Where the record came from (a file name), used in messages.
    """

    u: np.ndarray
    y: np.ndarray | None
    dt: float
    input_units: str | None = None
    output_units: str | None = None
    input_channels: tuple[str, ...] | None = None
    output_channels: tuple[str, ...] | None = None
    input_quantity: str | None = None
    output_quantity: str | None = None
    name: str = "record"

    def __post_init__(self):
        nm = self.name
        u = _finite(self.u, f"{nm}: field `inputs`")
        object.__setattr__(self, "u", u)
        if self.y is not None:
            y = _finite(self.y, f"{nm}: field `outputs`")
            if y.shape[1] != u.shape[1]:
                raise DimensionError(f"{nm}: field `outputs`: {y.shape[1]} samples, the inputs "
                                     f"have {u.shape[1]}")
            object.__setattr__(self, "y", y)
        try:
            dt = float(np.asarray(self.dt, dtype=float).reshape(()))
        except (TypeError, ValueError):
            raise InputError(f"{nm}: field `dt`: expected one number (s), got "
                             f"{self.dt!r}") from None
        if not (np.isfinite(dt) and dt > 0):
            raise InputError(f"{nm}: field `dt`: expected a positive finite interval (s), got "
                             f"{dt!r}")
        object.__setattr__(self, "dt", dt)
        if u.shape[1] < 2:
            raise InputError(f"{nm}: field `inputs`: {u.shape[1]} sample(s), expected at least 2")
        for side, count in (("input", u.shape[0]),
                            ("output", None if self.y is None else self.y.shape[0])):
            unit = getattr(self, f"{side}_units")
            q, unit = normalize_unit(unit, f"{nm}: field `{side}_units`")
            given = getattr(self, f"{side}_quantity")
            if given is not None and given != q:
                raise InputError(f"{nm}: field `{side}_quantity`: {given!r} does not match the "
                                 f"unit {unit!r} (a {q})")
            object.__setattr__(self, f"{side}_units", unit)
            object.__setattr__(self, f"{side}_quantity", q)
            if count is None:
                chans = getattr(self, f"{side}_channels")
                object.__setattr__(self, f"{side}_channels",
                                   None if chans is None else tuple(str(c) for c in chans))
            else:
                object.__setattr__(self, f"{side}_channels",
                                   _channels(getattr(self, f"{side}_channels"), count,
                                             f"{nm}: field `{side}_channels`"))
        unit_system_of(self)

    @property
    def n_samples(self) -> int:
        return self.u.shape[1]

    @property
    def n_inputs(self) -> int:
        return self.u.shape[0]

    @property
    def n_outputs(self) -> int | None:
        return None if self.y is None else self.y.shape[0]

    @property
    def t(self) -> np.ndarray:
        return np.arange(self.n_samples) * self.dt

    @property
    def units(self) -> str:
        """The unit system (``"SI"``, ``"inch-lbf"``; ``"any"`` when only strain)."""
        return unit_system_of(self)

    # the Record view (W, F) for code that reads today's records
    @property
    def W(self) -> np.ndarray | None:
        return self.y

    @property
    def F(self) -> np.ndarray | None:
        return self.u if self.collocated else None

    @property
    def collocated(self) -> bool:
        """Whether the inputs are forces at the output channels (today's W/F record)."""
        return (self.input_quantity == "force" and self.output_channels is not None
                and self.input_channels == self.output_channels)


def unit_system_of(rec: IORecord) -> str:
    """The unit system of a record; InputError naming the record when it mixes systems."""
    try:
        return unit_system(str(rec.input_units), str(rec.output_units))
    except InputError as exc:
        raise InputError(f"{rec.name}: fields `input_units`, `output_units`: {exc}") from None


def convert(rec: IORecord, system: str) -> IORecord:
    """The record in ``system`` (``"SI"`` or ``"inch-lbf"``): values scaled, units renamed."""
    if system not in ("SI", "inch-lbf"):
        raise InputError(f"unit system: expected 'SI' or 'inch-lbf', got {system!r}")
    out = {}
    for side, arr in (("input", rec.u), ("output", rec.y)):
        q = getattr(rec, f"{side}_quantity")
        unit = getattr(rec, f"{side}_units")
        new = _SYSTEM_UNIT[(q, system)]
        factor = UNITS[q][unit][1] / UNITS[q][new][1]
        out[side] = (None if arr is None else arr * factor, new)
    u = out["input"][0]
    assert u is not None  # a record always has its inputs
    return replace(rec, u=u, y=out["output"][0], input_units=out["input"][1],
                   output_units=out["output"][1])


def from_record(record, name: str = "record") -> IORecord:
    """Today's record (``W`` in in, ``F`` in lbf at the same sensors) as an :class:`IORecord`."""
    if getattr(record, "F", None) is None:
        raise InputError(f"{name}: field `F`: a record without forces has no inputs")
    m = np.asarray(record.W).shape[0]
    chans = tuple(str(i) for i in range(m))
    return IORecord(u=record.F, y=record.W, dt=record.dt, input_units="lbf",
                    output_units="in", input_channels=chans, output_channels=chans, name=name)


def _scalar_str(v) -> str | None:
    if v is None:
        return None
    a = np.asarray(v)
    if a.size != 1:
        return None
    return str(a.reshape(())).strip()


def _read_vars(path: Path) -> dict:
    """The variables of a record file, whatever its format."""
    name, suffix = path.name, path.suffix.lower()
    if suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except ValueError as exc:
            raise InputError(f"{name}: not readable without pickles ({exc})") from None
        except (OSError, zipfile.BadZipFile) as exc:
            raise InputError(f"{name}: cannot read as .npz ({exc})") from None
    if suffix == ".mat":
        import scipy.io

        try:
            return {k: x for k, x in scipy.io.loadmat(path).items() if not k.startswith("__")}
        except (NotImplementedError, ValueError, OSError, TypeError) as exc:
            raise InputError(f"{name}: not a MATLAB v7 (or older) file ({exc})") from None
    if suffix == ".csv":
        return read_csv_vars(path)
    if suffix in (".uff", ".unv"):
        return read_uff_vars(path)
    raise InputError(f"{name}: unknown input/output record format {suffix!r} "
                     f"(expected one of {', '.join(IO_SUFFIXES)})")


def read_io_record(path, *, input_units: str | None = None, output_units: str | None = None,
                   require_outputs: bool = True, system: str | None = None,
                   default_output_units: str | None = None) -> IORecord:
    """Read an input/output record from ``.npz`` (``allow_pickle=False``), ``.mat``, CSV or
    UFF 58 (``.uff``/``.unv``; layouts in :mod:`podbench.core.iofiles`).

    ``input_units``/``output_units`` declare units for a file that has none (e.g. the
    shared Painter Street files, m/s² per their README); a file's own units must agree with
    them. ``system`` converts the record on the way in (``"SI"`` or ``"inch-lbf"``).
    ``default_output_units`` names the output unit of a target file holding no outputs (a
    CSV or UFF file without output channels cannot state it): the training records' unit.

    Raises
    ------
    InputError
        One line naming the file and the variable.
    """
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    v = _read_vars(path)
    have = ", ".join(sorted(v)) or "nothing"
    for key in ("inputs", "dt") + (("outputs",) if require_outputs else ()):
        if key not in v:
            raise InputError(f"{name}: variable `{key}`: missing (the file has: {have})")
    units = {}
    for side, given in (("input", input_units), ("output", output_units)):
        in_file = _scalar_str(v.get(f"{side}_units"))
        if in_file and given and normalize_unit(in_file)[1] != normalize_unit(given)[1]:
            raise InputError(f"{name}: variable `{side}_units`: {in_file!r} in the file, "
                             f"{given!r} declared")
        units[side] = in_file or given
        if side == "output" and not units[side] and "outputs" not in v:
            units[side] = default_output_units
        if not units[side]:
            raise InputError(f"{name}: variable `{side}_units`: missing (the file has: {have});"
                             " add it to the file or declare it (e.g. --" + side
                             + "-units m/s^2)")
    rec = IORecord(u=v["inputs"], y=v.get("outputs"), dt=v["dt"],
                   input_units=units["input"], output_units=units["output"],
                   input_channels=v.get("input_channels"),
                   output_channels=v.get("output_channels"),
                   input_quantity=_scalar_str(v.get("input_quantity")),
                   output_quantity=_scalar_str(v.get("output_quantity")), name=name)
    return convert(rec, system) if system else rec


def write_io_record(path, rec: IORecord, **extra) -> None:
    """Write ``rec`` atomically in the format of the suffix: ``.npz`` (the layout
    :func:`read_io_record` reads; ``extra`` arrays are added), ``.mat`` (the same
    variables), CSV or UFF 58 (:mod:`podbench.core.iofiles`; ``extra`` is refused there)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in IO_SUFFIXES:
        raise InputError(f"{path.name}: unknown input/output record format {suffix!r} "
                         f"(expected one of {', '.join(IO_SUFFIXES)})")
    fields: dict[str, Any] = dict(u=rec.u, y=rec.y, dt=rec.dt,
                                  input_channels=rec.input_channels,
                                  output_channels=rec.output_channels,
                                  input_units=rec.input_units,
                                  output_units=rec.output_units if rec.y is not None else None)
    if suffix in (".csv", ".uff", ".unv"):
        if extra:
            raise InputError(f"{path.name}: fields {', '.join(sorted(extra))}: CSV and UFF "
                             "carry the record only; write .npz for extra arrays")
        if suffix == ".csv":
            write_csv(path, **fields)
        else:
            write_uff(path, **fields, input_quantity=str(rec.input_quantity),
                      output_quantity=rec.output_quantity if rec.y is not None else None)
        return
    arrays = {"inputs": rec.u, "dt": np.float64(rec.dt),
              "input_channels": np.array(rec.input_channels),
              "input_units": np.array(rec.input_units),
              "input_quantity": np.array(rec.input_quantity),
              "output_units": np.array(rec.output_units),
              "output_quantity": np.array(rec.output_quantity)}
    if rec.y is not None:
        arrays["outputs"] = rec.y
    if rec.output_channels is not None:
        arrays["output_channels"] = np.array(rec.output_channels)
    arrays.update(extra)
    buf = io.BytesIO()
    if suffix == ".mat":
        import scipy.io

        scipy.io.savemat(buf, arrays, do_compression=True)
    else:
        np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def check_compatible(ref: IORecord, rec: IORecord, *, role: str = "target",
                     need_outputs: bool = False, min_samples: int = 2) -> None:
    """Check ``rec`` against the reference (training) record: one line naming the file and
    the field (``dt``, channels, units, quantity, length) on the first difference."""
    nm = rec.name
    if not np.isclose(rec.dt, ref.dt, rtol=1e-9, atol=0.0):
        raise InputError(f"{nm}: field `dt`: {rec.dt:g} s differs from {ref.name}'s "
                         f"{ref.dt:g} s")
    for side in ("input", "output"):
        if side == "output" and rec.y is None:
            if need_outputs:
                raise InputError(f"{nm}: field `outputs`: missing ({role} records need "
                                 "measured outputs)")
            continue
        a, b = getattr(ref, f"{side}_channels"), getattr(rec, f"{side}_channels")
        if a != b:
            absent = [c for c in a if c not in b]
            what = (f"channel(s) {', '.join(absent)} absent" if absent
                    else f"{list(b)} instead of {list(a)}")
            raise InputError(f"{nm}: field `{side}_channels`: {what} (the training records "
                             f"have {list(a)})")
        for key in ("quantity", "units"):
            x, y = getattr(ref, f"{side}_{key}"), getattr(rec, f"{side}_{key}")
            if x != y:
                raise InputError(f"{nm}: field `{side}_{key}`: {y!r} differs from {ref.name}'s "
                                 f"{x!r} (convert where the data come in)")
    if rec.n_samples < min_samples:
        raise InputError(f"{nm}: field `inputs`: {rec.n_samples} samples, the model needs at "
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
    for rec in train:
        check_compatible(ref, rec, role="training", need_outputs=True, min_samples=min_samples)
    for rec in targets:
        check_compatible(ref, rec, need_outputs=targets_need_outputs, min_samples=min_samples)
