"""Measured records from files: ``.npz``, MATLAB ``.mat``, CSV and Universal File Format
dataset 58 (UFF, via the optional ``pyuff``: ``pip install podbench[measured]``).

A scenario case can be a file instead of a simulation (``[cases.x] file = "data/x.npz"``,
relative to the scenario file, see :mod:`podbench.scenarios`). Every format carries the
same record: ``W`` (m×n displacements, in), ``F`` (m×n forces, lbf, on the same sensors),
``dt`` (s) and optionally ``w0``, ``v0`` (m,) and the sensor positions (m,) in inches.
Column ``j`` is at ``t_j = j·dt`` (``t_0 = 0``), as everywhere in podbench.

Layouts
-------
``.npz``
    Arrays named ``W``, ``F``, ``dt`` (a scalar), optional ``w0``, ``v0``,
    ``sensor_positions``, ``sensors`` (labels). Read with ``allow_pickle=False``: no pickles.
``.mat``
    Variables of the same names (MATLAB ``save -v7`` or older; a v7.3 HDF5 file is refused
    with a clear message: re-save it with ``-v7``).
CSV
    One header line, then one row per sample; the first column is time ``t`` (s, uniform,
    starting at 0: ``dt`` is read from it), then one column per channel named
    ``w:<sensor>`` (a displacement) or ``f:<sensor>`` (a force at that sensor); every
    ``f:`` sensor must also have a ``w:`` column. Sensors are in the order of their ``w:``
    columns; a sensor without an ``f:`` column has no load cell (its row of ``F`` is zero).
    Example: ``t,w:x1,w:x2,f:x2``.
UFF 58
    One dataset 58 per channel (function type 1, time response; abscissa start 0,
    increment ``dt``). A channel is named by its ID line 1, ``w:<sensor>`` or
    ``f:<sensor>`` as in CSV; without such a name, the ordinate's specific data type says
    which (8 displacement, 13 excitation force) and the response node names the sensor.

Without ``w0``/``v0`` the record starts from rest at its first sample: ``w0 = W[:, 0]``,
``v0 = 0`` (give them explicitly for a free response). Errors are one line naming the file
and the variable (``data/x.npz: variable `W`: missing (the file has: F, dt)``).
"""

from __future__ import annotations

import csv
import io
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from podbench.core.iofiles import pyuff_module, read_uff58, uniform_dt
from podbench.errors import InputError

__all__ = ["MeasuredRecord", "read_record", "write_record", "FORMATS", "format_of"]

FORMATS = {".npz": "npz", ".mat": "mat", ".csv": "csv", ".uff": "uff", ".unv": "uff"}
"""File suffix → format."""
_OPTIONAL = ("w0", "v0", "sensor_positions")
_UFF_TYPES = {8: "w", 13: "f"}  # UFF specific data types: displacement, excitation force


@dataclass(frozen=True, eq=False)
class MeasuredRecord:
    """One measured test: arrays only (see the module docstring for the units)."""

    W: np.ndarray
    F: np.ndarray
    dt: float
    w0: np.ndarray | None = None
    v0: np.ndarray | None = None
    sensor_positions: np.ndarray | None = None
    sensors: tuple[str, ...] | None = None
    path: str = ""

    @property
    def t(self) -> np.ndarray:
        return np.arange(self.W.shape[1]) * self.dt


def format_of(path) -> str:
    """The format of ``path`` from its suffix (:data:`FORMATS`)."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"{path}: unknown record format {suffix!r}; expected one of "
                         f"{', '.join(sorted(FORMATS))}")
    return FORMATS[suffix]


def _fail(path, var: str, message: str) -> NoReturn:
    raise InputError(f"{path}: variable `{var}`: {message}")


def _array(path, name: str, value, ndim: int) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        _fail(path, name, f"expected numbers, got {type(value).__name__}")
    if ndim == 1 and a.ndim == 2 and 1 in a.shape:
        a = a.ravel()  # MATLAB vectors come as 1×m or m×1
    if ndim == 0:
        if a.size != 1:
            _fail(path, name, f"expected one number, got shape {a.shape}")
        a = a.reshape(())
    elif a.ndim != ndim:
        _fail(path, name, f"expected a {ndim}-D array, got shape {a.shape}")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        where = tuple(int(x) for x in bad[0])
        _fail(path, name, f"NaN or Inf at index {where if where else '()'}")
    return a


def _build(path, vars_: dict, sensors=None) -> MeasuredRecord:
    for name in ("W", "F", "dt"):
        if name not in vars_:
            have = ", ".join(sorted(vars_)) or "nothing"
            _fail(path, name, f"missing (the file has: {have})")
    W = _array(path, "W", vars_["W"], 2)
    F = _array(path, "F", vars_["F"], 2)
    if F.shape != W.shape:
        _fail(path, "F", f"shape {F.shape} differs from W's {W.shape} (forces are sampled at "
                         "the same sensors and times)")
    if W.shape[1] < 2:
        _fail(path, "W", f"expected at least 2 samples (columns), got shape {W.shape}")
    dt = float(_array(path, "dt", vars_["dt"], 0))
    if dt <= 0:
        _fail(path, "dt", f"expected a positive time step, got {dt!r}")
    extra = {}
    for name in _OPTIONAL:
        if name in vars_:
            a = _array(path, name, vars_[name], 1)
            if a.shape[0] != W.shape[0]:
                _fail(path, name, f"{a.shape[0]} entries, W has {W.shape[0]} rows (one per "
                                  "sensor)")
            extra[name] = a
    if sensors is not None and len(sensors) != W.shape[0]:
        _fail(path, "sensors", f"{len(sensors)} labels, W has {W.shape[0]} rows")
    return MeasuredRecord(W=W, F=F, dt=dt, sensors=None if sensors is None else tuple(sensors),
                          path=str(path), **extra)


# ----------------------------------------------------------------------------- readers
def _read_npz(path) -> MeasuredRecord:
    try:
        with np.load(path, allow_pickle=False) as z:
            vars_ = {k: z[k] for k in z.files}
    except ValueError as exc:  # object arrays need pickles: refused
        raise InputError(f"{path}: not a plain .npz ({exc}); podbench reads no pickles") from None
    except (OSError, zipfile.BadZipFile) as exc:
        raise InputError(f"{path}: cannot read as .npz ({exc})") from None
    sensors = vars_.pop("sensors", None)
    if sensors is not None:
        sensors = [str(s) for s in np.atleast_1d(sensors)]
    return _build(path, vars_, sensors)


def _read_mat(path) -> MeasuredRecord:
    import scipy.io

    try:
        raw = scipy.io.loadmat(path)
    except NotImplementedError:
        raise InputError(f"{path}: a MATLAB v7.3 (HDF5) file, which scipy cannot read; re-save "
                         "it with `save(..., '-v7')`") from None
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"{path}: cannot read as a MATLAB file ({exc})") from None
    vars_ = {k: v for k, v in raw.items() if not k.startswith("__")}
    sensors = vars_.pop("sensors", None)
    if sensors is not None:
        sensors = [str(s).strip() for s in np.atleast_1d(sensors).ravel()]
    return _build(path, vars_, sensors)


def _channels(path, names: list[str], columns: dict) -> dict:
    """``W``, ``F``, sensors from channels named ``w:<s>`` / ``f:<s>``."""
    w = [n[2:] for n in names if n.startswith("w:")]
    f = [n[2:] for n in names if n.startswith("f:")]
    if not w:
        _fail(path, "W", "no displacement channel (`w:<sensor>`)")
    for name in names:
        if names.count(name) > 1:
            _fail(path, name, "channel listed twice")
    for label in f:
        if label not in w:
            _fail(path, f"f:{label}", "a force at a sensor without a `w:` channel")
    W = np.vstack([columns[f"w:{s}"] for s in w])
    F = np.vstack([columns[f"f:{s}"] if s in f else np.zeros(W.shape[1]) for s in w])
    return {"W": W, "F": F, "sensors": w}


def _dt_from_t(path, t: np.ndarray) -> float:
    try:
        return uniform_dt(t)
    except ValueError as exc:
        _fail(path, "t", str(exc))


def _read_csv(path) -> MeasuredRecord:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read as UTF-8 text ({exc})") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        _fail(path, "t", "empty file (expected a header `t,w:<sensor>,...`)")
    head = [h.strip() for h in rows[0]]
    if head[0] != "t":
        _fail(path, "t", f"the first column must be time `t`, got {head[0]!r}")
    for h in head[1:]:
        if not (h.startswith("w:") or h.startswith("f:")) or len(h) < 3:
            _fail(path, h, "expected a column named `w:<sensor>` or `f:<sensor>`")
    body = [r for r in rows[1:] if r]
    try:
        data = np.array([[float(x) for x in r] for r in body], dtype=float)
    except ValueError as exc:
        raise InputError(f"{path}: a value is not a number ({exc})") from None
    if data.ndim != 2 or data.shape[1] != len(head):
        raise InputError(f"{path}: every row needs {len(head)} values (one per header column)")
    cols = {h: data[:, i] for i, h in enumerate(head)}
    for h, c in cols.items():
        _array(path, h, c, 1)
    dt = _dt_from_t(path, cols["t"])
    ch = _channels(path, head[1:], cols)
    return _build(path, {"W": ch["W"], "F": ch["F"], "dt": dt}, ch["sensors"])


def _read_uff(path) -> MeasuredRecord:
    sets = read_uff58(path, path)
    if not sets:
        _fail(path, "W", "no dataset 58 (function at a node) in the file")
    names, cols, dts = [], {}, []
    for k, s in enumerate(sets):
        name = str(s.get("id1", "")).strip()
        if not (name.startswith("w:") or name.startswith("f:")):
            kind = _UFF_TYPES.get(int(s.get("ordinate_spec_data_type", 0)))
            if kind is None:
                _fail(path, f"dataset {k}", "neither named `w:<sensor>`/`f:<sensor>` (ID line "
                                            "1) nor of type displacement (8) / force (13)")
            name = f"{kind}:{int(s.get('rsp_node', k + 1))}"
        if name in cols:
            _fail(path, name, "channel listed twice")
        names.append(name)
        cols[name] = _array(path, name, np.real(np.asarray(s["data"])), 1)
        if float(s.get("abscissa_min", 0.0)) != 0.0:
            _fail(path, name, "the abscissa must start at t = 0")
        dts.append(float(s["abscissa_inc"]))
    if max(dts) - min(dts) > 1e-12 * max(dts):
        _fail(path, "dt", f"the channels have different increments {sorted(set(dts))}")
    lengths = {c.size for c in cols.values()}
    if len(lengths) > 1:
        _fail(path, "W", f"the channels have different lengths {sorted(lengths)}")
    ch = _channels(path, names, cols)
    return _build(path, {"W": ch["W"], "F": ch["F"], "dt": dts[0]}, ch["sensors"])


_READERS = {"npz": _read_npz, "mat": _read_mat, "csv": _read_csv, "uff": _read_uff}


def read_record(path) -> MeasuredRecord:
    """Read one measured record (format from the suffix: :data:`FORMATS`).

    Raises
    ------
    InputError
        One line naming the file and the variable: missing file or variable, wrong shape,
        NaN/Inf, a v7.3 MATLAB file, a pickled array, a malformed CSV/UFF, pyuff missing.
    """
    fmt = format_of(path)
    if not Path(path).is_file():
        raise InputError(f"{path}: no such record file")
    return _READERS[fmt](path)


# ----------------------------------------------------------------------------- writers
def _labels(record) -> list[str]:
    s = getattr(record, "sensors", None)
    return list(s) if s else [f"s{i}" for i in range(np.shape(record.W)[0])]


def write_record(path, record, *, sensors=None, sensor_positions=None) -> Path:
    """Write ``record`` (an object with ``W, F, dt`` and optional ``w0, v0``) to ``path`` in
    the format of its suffix. CSV and UFF carry ``W``, ``F`` and ``dt`` only (``w0``, ``v0``
    and positions are not part of their layouts); ``.npz`` and ``.mat`` carry everything.
    ``sensors`` (labels) default to ``s0, s1, …``."""
    path = Path(path)
    fmt = format_of(path)
    W = np.asarray(record.W, dtype=float)
    F = np.asarray(record.F, dtype=float)
    dt = float(record.dt)
    labels = list(sensors) if sensors is not None else _labels(record)
    pos = sensor_positions if sensor_positions is not None else getattr(
        record, "sensor_positions", None)
    if fmt in ("npz", "mat"):
        out: dict[str, Any] = {"W": W, "F": F, "dt": dt, "sensors": np.array(labels)}
        for name in ("w0", "v0"):
            if getattr(record, name, None) is not None:
                out[name] = np.asarray(getattr(record, name), dtype=float)
        if pos is not None:
            out["sensor_positions"] = np.asarray(pos, dtype=float)
        if fmt == "npz":
            with open(path, "wb") as fh:
                np.savez_compressed(fh, **out)
        else:
            import scipy.io

            scipy.io.savemat(path, out, do_compression=True)
        return path
    loaded = [i for i in range(F.shape[0]) if np.any(F[i] != 0)]
    if fmt == "csv":
        head = ["t"] + [f"w:{s}" for s in labels] + [f"f:{labels[i]}" for i in loaded]
        data = np.vstack([np.arange(W.shape[1]) * dt, W, F[loaded]]).T
        buf = io.StringIO()
        buf.write(",".join(head) + "\n")
        for row in data:
            buf.write(",".join(repr(float(x)) for x in row) + "\n")
        path.write_text(buf.getvalue(), encoding="utf-8")
        return path
    pyuff = pyuff_module()
    if path.exists():
        path.unlink()
    uff = pyuff.UFF(str(path))
    sets = []
    channels = [("w", i, W[i]) for i in range(W.shape[0])] + [("f", i, F[i]) for i in loaded]
    for kind, i, y in channels:
        sets.append(pyuff.prepare_58(
            binary=1, id1=f"{kind}:{labels[i]}", id2="podbench record", id3="", id4="", id5="",
            func_type=1, rsp_node=i + 1, rsp_dir=3, ref_node=0, ref_dir=0,
            abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt, num_pts=y.size,
            ordinate_spec_data_type=8 if kind == "w" else 13, abscissa_spec_data_type=17,
            abscissa_axis_units_lab="s", ordinate_axis_units_lab="in" if kind == "w" else "lbf",
            orddenom_spec_data_type=0, orddenom_axis_units_lab="", z_axis_spec_data_type=0,
            z_axis_axis_units_lab="", z_axis_value=0.0, ord_data_type=4, load_case_id=0,
            ver_num=0, rsp_ent_name="sensor", ref_ent_name="none",
            abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
            ordinate_len_unit_exp=0, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
            orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
            z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
            data=np.asarray(y, dtype=float), x=np.arange(y.size) * dt))
    uff.write_sets(sets, mode="add")
    return path

