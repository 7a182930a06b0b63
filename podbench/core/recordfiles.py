"""Record files: one reader and one writer per format (``.npz``, ``.mat``, CSV, UFF 58).

:func:`read_record` reads a :class:`~podbench.core.records.Record` from a file in either of
the two layouts podbench users have, whatever the format; :func:`write_record` writes one.

The displacement/force layout (the dissertation's record: ``W`` in in, ``F`` in lbf at the
same sensors, ``dt`` s, optional ``w0``, ``v0`` and sensor positions, in)
    ``.npz`` / ``.mat``: arrays ``W``, ``F``, ``dt``, optional ``w0``, ``v0``,
    ``sensor_positions``, ``sensors`` (labels). A free response (an initial condition, no
    load) holds no ``F``. CSV: a header ``t,w:<sensor>,...,f:<sensor>,...`` (time in s,
    uniform from 0; every ``f:`` sensor has a ``w:`` column; a sensor without an ``f:``
    column has no load cell, its force is zero). UFF 58: one dataset per channel named
    ``w:<sensor>`` / ``f:<sensor>`` (ID line 1), or by its data type (8 displacement, 13
    force) and response node. Without ``w0``/``v0`` a forced record starts from rest at
    its first sample (``w0 = W[:, 0]``, ``v0 = 0``).
The input/output layout (measured inputs ``u`` and outputs ``y`` with units)
    ``.npz`` / ``.mat``: ``inputs`` (n_in × n), ``outputs`` (n_out × n; optional for a
    target), ``dt``, ``input_channels``, ``output_channels``, ``input_units``,
    ``output_units`` and optionally ``input_quantity``, ``output_quantity``. CSV and UFF 58:
    :mod:`podbench.core.iofiles` (columns ``u:<channel> [unit]``, ``y:<channel> [unit]``).
    A file without unit variables (the shared Painter Street records) is read with the units
    its reader declares (``input_units="m/s^2"``); a record without units is refused.

A file's layout is read from its variables (``inputs``/``outputs`` or ``W``/``F``), its CSV
header or its UFF channel names. ``.npz`` files are read with ``allow_pickle=False``: no
pickles; a MATLAB v7.3 (HDF5) file is refused (re-save with ``-v7``). Every error is one line
that names the file and the variable, before any fitting.
"""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from podbench import _compat
from podbench.core.atomic import atomic_write_bytes, atomic_write_text
from podbench.core.iofiles import (
    io_layout_of_header,
    io_layout_of_sets,
    pyuff_module,
    read_csv_vars,
    read_uff58,
    read_uff_vars,
    uniform_dt,
    write_csv,
    write_uff,
    write_uff_sets,
)
from podbench.core.records import Record, convert
from podbench.core.units import normalize_unit
from podbench.errors import InputError

__all__ = ["FORMATS", "format_of", "read_record", "write_record", "record_bytes"]

FORMATS = {".npz": "npz", ".mat": "mat", ".csv": "csv", ".uff": "uff", ".unv": "uff"}
"""File suffix → format."""
_OPTIONAL = ("w0", "v0", "sensor_positions")
_UFF_TYPES = {8: "w", 13: "f"}  # UFF specific data types: displacement, excitation force


def format_of(path) -> str:
    """The format of ``path`` from its suffix (:data:`FORMATS`)."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"{path}: unknown record format {suffix!r}; expected one of "
                         f"{', '.join(sorted(FORMATS))}")
    return FORMATS[suffix]


def _fail(path, var: str, message: str) -> NoReturn:
    raise InputError(f"{path}: variable `{var}`: {message}")


# ------------------------------------------------------------------ variables of a file
def _npz_vars(path) -> dict:
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except ValueError as exc:  # object arrays need pickles: refused
        raise InputError(f"{path}: not a plain .npz ({exc}); podbench reads no pickles") from None
    except EOFError:  # np.load of an empty file
        raise InputError(f"{path}: empty file (0 bytes): not a .npz archive") from None
    except (OSError, zipfile.BadZipFile) as exc:
        raise InputError(f"{path}: cannot read as .npz ({exc})") from None


def _mat_vars(path) -> dict:
    import scipy.io

    try:
        raw = scipy.io.loadmat(path)
    except NotImplementedError:
        raise InputError(f"{path}: a MATLAB v7.3 (HDF5) file, which scipy cannot read; re-save "
                         "it with `save(..., '-v7')`") from None
    except (OSError, ValueError, TypeError, scipy.io.matlab.MatReadError) as exc:
        what = "empty file (0 bytes)" if Path(path).stat().st_size == 0 else str(exc)
        raise InputError(f"{path}: cannot read as a MATLAB file ({what})") from None
    return {k: v for k, v in raw.items() if not k.startswith("__")}


def _labels(raw) -> list[str] | None:
    if raw is None:
        return None
    return [str(s).strip() for s in np.atleast_1d(raw).ravel()]


# ------------------------------------------------------------ displacement/force layout
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


def _build_wf(path, vars_: dict, sensors=None) -> Record:
    """The dissertation's record of a displacement/force file's variables."""
    for name in ("W", "dt"):
        if name not in vars_:
            have = ", ".join(sorted(vars_)) or "nothing"
            _fail(path, name, f"missing (the file has: {have})")
    W = _array(path, "W", vars_["W"], 2)
    F = None
    if "F" in vars_:
        F = _array(path, "F", vars_["F"], 2)
        if F.shape != W.shape:
            _fail(path, "F", f"shape {F.shape} differs from W's {W.shape} (forces are sampled "
                             "at the same sensors and times)")
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
    if sensors is not None and len(set(sensors)) != len(sensors):
        _fail(path, "sensors", f"repeated labels {list(sensors)}")
    return Record(W=W, F=F, dt=dt, output_channels=None if sensors is None else tuple(sensors),
                  input_channels=None if sensors is None or F is None else tuple(sensors),
                  name=Path(path).name, **extra)


def _wf_channels(path, names: list[str], columns: dict) -> dict:
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


def _read_wf_csv(path, rows: list) -> Record:
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
    try:
        dt = uniform_dt(cols["t"])
    except ValueError as exc:
        _fail(path, "t", str(exc))
    ch = _wf_channels(path, head[1:], cols)
    return _build_wf(path, {"W": ch["W"], "F": ch["F"], "dt": dt}, ch["sensors"])


def _read_wf_uff(path, sets: list) -> Record:
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
    ch = _wf_channels(path, names, cols)
    return _build_wf(path, {"W": ch["W"], "F": ch["F"], "dt": dts[0]}, ch["sensors"])


# ------------------------------------------------------------------ input/output layout
def _scalar_str(v) -> str | None:
    if v is None:
        return None
    a = np.asarray(v)
    if a.size != 1:
        return None
    return str(a.reshape(())).strip()


def _build_io(path: Path, v: dict, *, input_units, output_units, require_outputs: bool,
              default_output_units) -> Record:
    """The record of an input/output file's variables (units declared by the reader for a
    file without them; the file's own must agree)."""
    name = path.name
    have = ", ".join(sorted(k for k, x in v.items() if x is not None)) or "nothing"
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
        if not units[side] and format_of(path) == "csv":  # the unit is in the header
            col = "u" if side == "input" else "y"
            raise InputError(f"{name}: the {side} columns carry no unit; write it in the "
                             f"header (`{col}:<channel> [m/s^2]`) or declare it (e.g. "
                             f"--{side}-units m/s^2)")
        if not units[side]:
            raise InputError(f"{name}: variable `{side}_units`: missing (the file has: {have});"
                             " add it to the file or declare it (e.g. --" + side
                             + "-units m/s^2)")
    return Record(u=v["inputs"], y=v.get("outputs"), dt=v["dt"],
                  input_units=units["input"], output_units=units["output"],
                  input_channels=v.get("input_channels"),
                  output_channels=v.get("output_channels"),
                  input_quantity=_scalar_str(v.get("input_quantity")),
                  output_quantity=_scalar_str(v.get("output_quantity")), name=name)


# ------------------------------------------------------------------ the reader
def _csv_rows(path) -> list:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read as UTF-8 text ({exc})") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        _fail(path, "t", "empty file (expected a header `t,w:<sensor>,...` or "
                         "`t [s],u:<channel> [unit],...`)")
    return rows


def _read_layout(path: Path, io_kw: dict) -> Record:
    """The record of ``path``: its format from the suffix, its layout from its content."""
    fmt = format_of(path)
    if fmt in ("npz", "mat"):
        v = _npz_vars(path) if fmt == "npz" else _mat_vars(path)
        if "inputs" in v or "outputs" in v or "W" not in v and "F" not in v and \
                any(k.endswith("_units") for k in v):
            return _build_io(path, v, **io_kw)
        return _build_wf(path, v, _labels(v.pop("sensors", None)))
    if fmt == "csv":
        rows = _csv_rows(path)
        if io_layout_of_header(rows[0]):
            return _build_io(path, read_csv_vars(path), **io_kw)
        return _read_wf_csv(path, rows)
    sets = read_uff58(path, path)
    if not sets:
        _fail(path, "W", "no dataset 58 (function at a node) in the file")
    if io_layout_of_sets(sets):
        return _build_io(path, read_uff_vars(path), **io_kw)
    return _read_wf_uff(path, sets)


def read_record(path, *, input_units: str | None = None, output_units: str | None = None,
                require_outputs: bool = True, system: str | None = None,
                default_output_units: str | None = None) -> Record:
    """Read one record (format from the suffix: :data:`FORMATS`; layout from the content,
    see the module docstring).

    Parameters
    ----------
    path : path
        The file.
    input_units, output_units : str, optional
        Units of an input/output file that carries none (e.g. the shared Painter Street
        files, m/s² per their README); a file's own units must agree with them.
    require_outputs : bool
        Refuse an input/output file without outputs (False: a target to predict).
    system : {"SI", "inch-lbf"}, optional
        Convert the record on the way in.
    default_output_units : str, optional
        The output unit of a target file holding no outputs (a CSV or UFF file without
        output channels cannot state it): the training records' unit.

    Raises
    ------
    InputError
        One line naming the file and the variable: missing file or variable, wrong shape,
        NaN/Inf, a v7.3 MATLAB file, a pickled array, a malformed CSV/UFF, pyuff missing.
    """
    path = Path(path)
    format_of(path)
    if not path.is_file():
        raise InputError(f"{path}: no such record file")
    rec = _read_layout(path, dict(input_units=input_units, output_units=output_units,
                                  require_outputs=require_outputs,
                                  default_output_units=default_output_units))
    return convert(rec, system) if system else rec


# ------------------------------------------------------------------ the writer
def _dissertation_layout(record, layout: str) -> bool:
    """Whether ``record`` is written in the displacement/force layout."""
    if layout not in ("auto", "wf", "io"):
        raise InputError(f"Parameter `layout`: expected 'auto', 'wf' or 'io', got {layout!r}")
    if layout != "auto":
        return layout == "wf"
    if not isinstance(record, Record):
        return True  # an object with W, F, dt (the dissertation's record)
    return record.output_quantity == "displacement" and (record.u is None or record.collocated)


def _wf_arrays(record, labels, pos) -> dict[str, Any]:
    W = np.asarray(record.W, dtype=float)
    F = getattr(record, "F", None)
    out: dict[str, Any] = {"W": W}
    if F is not None:
        out["F"] = np.asarray(F, dtype=float)
    out.update({"dt": float(record.dt), "sensors": np.array(labels)})
    for name in ("w0", "v0"):
        if getattr(record, name, None) is not None:
            out[name] = np.asarray(getattr(record, name), dtype=float)
    if pos is not None:
        out["sensor_positions"] = np.asarray(pos, dtype=float)
    return out


def _io_arrays(rec: Record, extra: dict) -> dict[str, Any]:
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
    return arrays


def _deterministic_zip(data: bytes) -> bytes:
    """The same zip with fixed member timestamps (numpy stamps the current time)."""
    src = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for info in src.infolist():
            zi = zipfile.ZipInfo(info.filename, date_time=(1980, 1, 1, 0, 0, 0))
            zi.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(zi, src.read(info.filename))
    return out.getvalue()


def record_bytes(record, fmt: str, *, layout: str = "auto", sensors=None,
                 sensor_positions=None, deterministic: bool = False, **extra) -> bytes:
    """The bytes :func:`write_record` writes for ``record`` in the ``.npz`` or ``.mat``
    format (``deterministic``: zip members with a fixed timestamp, so that the same record
    gives the same bytes)."""
    if _dissertation_layout(record, layout):
        labels = list(sensors) if sensors is not None else (
            list(getattr(record, "sensors", None) or ())
            or [f"s{i}" for i in range(np.shape(record.W)[0])])
        pos = sensor_positions if sensor_positions is not None else getattr(
            record, "sensor_positions", None)
        arrays = _wf_arrays(record, labels, pos)
        arrays.update(extra)
    else:
        arrays = _io_arrays(record, extra)
    buf = io.BytesIO()
    if fmt == "mat":
        import scipy.io

        scipy.io.savemat(buf, arrays, do_compression=True)
        return buf.getvalue()
    np.savez_compressed(buf, **arrays)
    return _deterministic_zip(buf.getvalue()) if deterministic else buf.getvalue()


def _write_text_layout(path: Path, fmt: str, record, wf: bool, labels) -> None:
    """CSV or UFF 58 of a record (they carry the record only, no extra arrays)."""
    if not wf:
        fields: dict[str, Any] = dict(
            u=record.u, y=record.y, dt=record.dt, input_channels=record.input_channels,
            output_channels=record.output_channels, input_units=record.input_units,
            output_units=record.output_units if record.y is not None else None)
        if fmt == "csv":
            write_csv(path, **fields)
        else:
            write_uff(path, **fields, input_quantity=str(record.input_quantity),
                      output_quantity=record.output_quantity if record.y is not None else None)
        return
    W = np.asarray(record.W, dtype=float)
    F = getattr(record, "F", None)
    F = np.zeros_like(W) if F is None else np.asarray(F, dtype=float)
    dt = float(record.dt)
    loaded = [i for i in range(F.shape[0]) if np.any(F[i] != 0)]
    if fmt == "csv":
        head = ["t"] + [f"w:{s}" for s in labels] + [f"f:{labels[i]}" for i in loaded]
        data = np.vstack([np.arange(W.shape[1]) * dt, W, F[loaded]]).T
        buf = io.StringIO()
        buf.write(",".join(head) + "\n")
        for row in data:
            buf.write(",".join(repr(float(x)) for x in row) + "\n")
        atomic_write_text(path, buf.getvalue())
        return
    _write_wf_uff(path, W, F, dt, labels, loaded)


def _write_wf_uff(path: Path, W, F, dt: float, labels, loaded) -> None:
    pyuff = pyuff_module()
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
    write_uff_sets(path, sets)


def write_record(path, record, *, layout: str = "auto", sensors=None, sensor_positions=None,
                 **extra) -> Path:
    """Write ``record`` atomically in the format of the suffix of ``path``.

    ``layout``: ``"auto"`` (the displacement/force layout for the dissertation's record —
    displacements with no inputs or with forces at the sensors — the input/output layout
    otherwise), ``"wf"`` or ``"io"``. CSV and UFF carry the record only (the
    displacement/force layout: ``W``, ``F``, ``dt``); ``.npz`` and ``.mat`` carry everything,
    and ``extra`` arrays beside it. ``sensors`` (labels of the displacement/force layout)
    default to the record's output channels."""
    path = Path(path)
    fmt = format_of(path)
    wf = _dissertation_layout(record, layout)
    if fmt in ("npz", "mat"):
        atomic_write_bytes(path, record_bytes(record, fmt, layout="wf" if wf else "io",
                                              sensors=sensors,
                                              sensor_positions=sensor_positions, **extra))
        return path
    if extra:
        raise InputError(f"{path.name}: fields {', '.join(sorted(extra))}: CSV and UFF "
                         "carry the record only; write .npz for extra arrays")
    labels = list(sensors) if sensors is not None else (
        list(getattr(record, "sensors", None) or ()) or
        [f"s{i}" for i in range(np.shape(record.W)[0])]) if wf else None
    _write_text_layout(path, fmt, record, wf, labels)
    return path


def __getattr__(name: str):
    """Retired names of this module (:data:`podbench._compat.RETIRED`)."""
    return _compat.retired(__name__, name)
