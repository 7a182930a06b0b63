"""CSV and UFF 58 input/output layouts of record files (:mod:`podbench.core.recordfiles`).

Both layouts carry what a :class:`~podbench.core.records.Record` of measured inputs and
outputs holds: the inputs and outputs, ``dt``, the channel names and the unit of each side.
The readers return the same variables a ``.npz`` holds (``inputs``, ``outputs``, ``dt``,
``input_channels``, ``output_channels``, ``input_units``, ``output_units``); the record is
built and checked by :func:`~podbench.core.recordfiles.read_record`.

CSV
    One header line, then one row per sample. The first column is time, ``t`` (or
    ``t [s]``), uniform from 0 (``dt`` is read from it). Then one column per channel named
    ``u:<channel> [<unit>]`` (an input) or ``y:<channel> [<unit>]`` (an output), e.g.
    ``t [s],u:ground_x [m/s^2],y:deck_x [m/s^2]``. Every input column has the same unit and
    every output column has the same unit (a record has one unit per side); a column without
    ``[unit]`` takes the unit declared to the reader. A target without measured outputs has
    only ``u:`` columns. Values are written with 17 significant digits (round trip exact).
UFF 58
    One dataset 58 (function type 1, time response; abscissa from 0 with increment ``dt``)
    per channel, in the order inputs then outputs. ID line 1 names the channel,
    ``u:<channel>`` or ``y:<channel>``; the ordinate's axis-units label holds the unit, its
    specific data type the quantity (3 strain, 8 displacement, 11 velocity, 12
    acceleration, 13 excitation force). A dataset not named ``u:``/``y:`` is an input if it
    is an excitation force (type 13) and an output otherwise, named ``<node>:<direction>``
    from its response node and direction. Needs the optional ``pyuff``
    (``pip install 'podbench[measured]'``); written as binary 58 with double-precision
    ordinates (exact), and the ASCII form is read too. The format stores ``dt`` with 6
    significant digits (its header field is E13.5): a ``dt`` that needs more is refused
    by the writer rather than silently rounded.

Errors are one line naming the file and the field (a column, a dataset, ``dt``).
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path
from typing import NoReturn

import numpy as np

from podbench.core.atomic import atomic_write_bytes, atomic_write_text
from podbench.errors import InputError

__all__ = ["IO_SUFFIXES", "read_csv_vars", "write_csv", "read_uff_vars", "write_uff",
           "is_io_layout", "io_layout_of_header", "io_layout_of_sets", "UFF_TYPES",
           "read_uff58", "pyuff_module", "uniform_dt", "write_uff_sets"]

IO_SUFFIXES = (".npz", ".mat", ".csv", ".uff", ".unv")
"""File suffixes of input/output records."""

UFF_TYPES = {"strain": 3, "displacement": 8, "velocity": 11, "acceleration": 12,
             "force": 13}
"""Quantity → UFF specific data type (record 8 of dataset 58)."""

_HEAD = re.compile(r"^(?P<side>[uy]):(?P<name>.+?)(?:\s*\[(?P<unit>[^\[\]]*)\])?$")
_SIDE = {"u": "input", "y": "output"}


def _fail(name: str, field: str, message: str) -> NoReturn:
    raise InputError(f"{name}: field `{field}`: {message}")


def uniform_dt(t: np.ndarray) -> float:
    """``dt`` (s) of a time column ``t_j = j·dt`` (uniform from 0, within 1e-6·dt); a
    ValueError saying what is wrong otherwise (the reader adds the file and field)."""
    if t.size < 2:
        raise ValueError(f"{t.size} sample(s), expected at least 2")
    dt = float(t[1] - t[0])
    ideal = np.arange(t.size) * dt
    if abs(t[0]) > 1e-9 * abs(dt) or dt <= 0 or np.max(np.abs(t - ideal)) > 1e-6 * dt:
        raise ValueError(f"expected uniform times t_j = j·dt from 0 (t[0] = {t[0]:g}, "
                         f"t[1] = {t[1]:g})")
    return dt


def _dt_from_t(name: str, t: np.ndarray) -> float:
    try:
        return uniform_dt(t)
    except ValueError as exc:
        _fail(name, "t", str(exc))


def _side_unit(name: str, units: dict):
    """The one unit of a side's columns (None when no column states one)."""
    stated = [(c, u) for c, u in units.items() if u]
    for col, unit in stated[1:]:
        if unit != stated[0][1]:
            _fail(name, col, f"unit {unit!r} differs from {stated[0][0]!r}'s "
                             f"{stated[0][1]!r} (a record has one unit per side)")
    return stated[0][1] if stated else None


def _parse_header(name: str, head: list[str]):
    if not head or head[0].strip() not in ("t", "t [s]", "t[s]"):
        first = head[0] if head else ""
        _fail(name, "t", f"the first column must be time `t` (or `t [s]`), got {first!r}")
    cols: dict[str, list] = {"u": [], "y": []}
    units: dict[str, dict] = {"u": {}, "y": {}}
    for h in head[1:]:
        m = _HEAD.match(h.strip())
        if m is None or not m["name"].strip():
            raise InputError(f"{name}: field `{h}`: expected a column named `u:<channel> "
                             "[unit]` (an input) or `y:<channel> [unit]` (an output)")
        side, ch = m["side"], m["name"].strip()
        if ch in cols[side]:
            _fail(name, h, "channel listed twice")
        cols[side].append(ch)
        units[side][h] = (m["unit"] or "").strip() or None
    if not cols["u"]:
        _fail(name, "inputs", "no input column (`u:<channel> [unit]`)")
    return cols, units


def read_csv_vars(path) -> dict:
    """The variables of an input/output CSV file (layout in the module docstring)."""
    path = Path(path)
    name = path.name
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: cannot read as UTF-8 text ({exc})") from None
    rows = [r for r in csv.reader(io.StringIO(text)) if r]
    if not rows:
        _fail(name, "t", "empty file (expected a header `t,u:<channel> [unit],...`)")
    head = [h.strip() for h in rows[0]]
    cols, units = _parse_header(name, head)
    data = np.empty((len(rows) - 1, len(head)))
    for i, r in enumerate(rows[1:]):
        if len(r) != len(head):
            _fail(name, f"row {i + 2}", f"{len(r)} values, the header has {len(head)} columns")
        for j, x in enumerate(r):
            try:
                data[i, j] = float(x)
            except ValueError:
                _fail(name, head[j], f"row {i + 2}: {x.strip()!r} is not a number")
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        _fail(name, head[bad[0][1]], f"NaN or Inf in row {int(bad[0][0]) + 2}")
    n_u = len(cols["u"])
    sides = [h[0] for h in head[1:]]
    iu = [j + 1 for j, s in enumerate(sides) if s == "u"]
    iy = [j + 1 for j, s in enumerate(sides) if s == "y"]
    out = {"inputs": data[:, iu].T, "dt": _dt_from_t(name, data[:, 0]),
           "input_channels": cols["u"], "input_units": _side_unit(name, units["u"])}
    if iy:
        out.update(outputs=data[:, iy].T, output_channels=cols["y"],
                   output_units=_side_unit(name, units["y"]))
    assert len(iu) == n_u
    return out


def write_csv(path, *, u, y, dt: float, input_channels, output_channels, input_units: str,
              output_units: str | None) -> None:
    """Write an input/output record as CSV (atomically; exact: 17 significant digits)."""
    head = ["t [s]"] + [f"u:{c} [{input_units}]" for c in input_channels]
    blocks = [np.arange(np.shape(u)[1]) * float(dt), np.asarray(u, dtype=float)]
    if y is not None:
        head += [f"y:{c} [{output_units}]" for c in output_channels]
        blocks.append(np.asarray(y, dtype=float))
    data = np.vstack(blocks).T
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(head)
    for row in data:
        w.writerow([repr(float(x)) for x in row])
    atomic_write_text(path, buf.getvalue())


def pyuff_module():
    """The optional ``pyuff`` module, or one InputError naming the extra that installs it."""
    try:
        import pyuff
    except ImportError:
        raise InputError("reading or writing a UFF file needs pyuff: pip install "
                         "'podbench[measured]'") from None
    return pyuff


_UFF_QUANTITY = {v: k for k, v in UFF_TYPES.items()}


def _uff_channel(name: str, k: int, s: dict) -> tuple[str, str, str | None, str | None]:
    """(side, channel, unit label or None, quantity from the data type or None)."""
    label = f"dataset {k + 1}"
    if int(s.get("func_type", 1)) != 1:
        _fail(name, label, f"function type {s.get('func_type')}, expected 1 (time response)")
    kind = _UFF_QUANTITY.get(int(s.get("ordinate_spec_data_type", 0) or 0))
    id1 = str(s.get("id1", "")).strip()
    if id1[:2] in ("u:", "y:") and id1[2:].strip():
        side, ch = _SIDE[id1[0]], id1[2:].strip()
    else:
        side = "input" if kind == "force" else "output"
        ch = f"{int(s.get('rsp_node', k + 1))}:{int(s.get('rsp_dir', 0))}"
    unit = str(s.get("ordinate_axis_units_lab", "")).strip()
    return side, ch, (None if unit.upper() in ("", "NONE") else unit), kind


def read_uff58(path, name) -> list[dict]:
    """The datasets 58 (functions at a node) of a UFF file, in file order (an empty list if
    it has none); one InputError naming ``name`` (the file as shown) when pyuff is missing
    or cannot read the file."""
    pyuff = pyuff_module()
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # noqa: BLE001 - pyuff raises anything on a malformed file
        raise InputError(f"{name}: cannot read as UFF ({type(exc).__name__}: {exc})") from None
    sets = [sets] if isinstance(sets, dict) else list(sets)
    return [s for s in sets if s.get("type") == 58]


def _uff_sets(name: str, path: Path) -> list:
    sets = read_uff58(path, name)
    if not sets:
        _fail(name, "inputs", "no dataset 58 (function at a node) in the file")
    return sets


def read_uff_vars(path) -> dict:
    """The variables of an input/output UFF 58 file (layout in the module docstring)."""
    path = Path(path)
    name = path.name
    chans: dict[str, list] = {"input": [], "output": []}
    data: dict[str, list] = {"input": [], "output": []}
    units: dict[str, dict] = {"input": {}, "output": {}}
    quantity: dict[str, dict] = {"input": {}, "output": {}}
    dts = []
    for k, s in enumerate(_uff_sets(name, path)):
        side, ch, unit, kind = _uff_channel(name, k, s)
        label = ("u:" if side == "input" else "y:") + ch
        if ch in chans[side]:
            _fail(name, label, "channel listed twice")
        if float(s.get("abscissa_min", 0.0)) != 0.0:
            _fail(name, label, f"the abscissa starts at {s.get('abscissa_min')}, expected 0")
        chans[side].append(ch)
        data[side].append(np.real(np.asarray(s["data"], dtype=complex)).astype(float))
        units[side][label] = unit
        quantity[side][label] = kind
        dts.append(float(s["abscissa_inc"]))
    if max(dts) - min(dts) > 1e-12 * max(dts):
        _fail(name, "dt", f"the datasets have different increments {sorted(set(dts))}")
    lengths = sorted({d.size for side in data.values() for d in side})
    if len(lengths) > 1:
        _fail(name, "inputs", f"the datasets have different lengths {lengths}")
    if not chans["input"]:
        _fail(name, "inputs", "no input dataset (ID line 1 `u:<channel>`, or an excitation "
                              "force)")
    out: dict = {"dt": dts[0]}
    for side, key in (("input", "inputs"), ("output", "outputs")):
        if not chans[side]:
            continue
        out[key] = np.vstack(data[side])
        out[f"{side}_channels"] = chans[side]
        out[f"{side}_units"] = _side_unit(name, units[side])
        kinds = {q for q in quantity[side].values() if q is not None}
        if len(kinds) > 1:
            _fail(name, f"{side}_quantity", f"datasets of different quantities "
                                            f"{sorted(kinds)} (one per side)")
        if kinds:
            out[f"{side}_quantity"] = kinds.pop()
    return out


def _uff_dataset(pyuff, label: str, y: np.ndarray, dt: float, unit: str, quantity: str,
                 node: int) -> dict:
    exps = {"force": (0, 1), "strain": (0, 0)}.get(quantity, (1, 0))
    return pyuff.prepare_58(
        binary=1, id1=label, id2="podbench input/output record", id3="", id4="", id5="",
        func_type=1, rsp_node=node, rsp_dir=1, ref_node=0, ref_dir=0,
        abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt, num_pts=y.size,
        ordinate_spec_data_type=UFF_TYPES[quantity], abscissa_spec_data_type=17,
        abscissa_axis_units_lab="s", ordinate_axis_units_lab=unit,
        orddenom_spec_data_type=0, orddenom_axis_units_lab="", z_axis_spec_data_type=0,
        z_axis_axis_units_lab="", z_axis_value=0.0, ord_data_type=4, load_case_id=0,
        ver_num=0, rsp_ent_name="channel", ref_ent_name="none",
        abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
        ordinate_len_unit_exp=exps[0], ordinate_force_unit_exp=exps[1],
        ordinate_temp_unit_exp=0, orddenom_len_unit_exp=0, orddenom_force_unit_exp=0,
        orddenom_temp_unit_exp=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0,
        z_axis_temp_unit_exp=0, data=np.asarray(y, dtype=float), x=np.arange(y.size) * dt)


def write_uff(path, *, u, y, dt: float, input_channels, output_channels, input_units: str,
              output_units: str | None, input_quantity: str,
              output_quantity: str | None) -> None:
    """Write an input/output record as binary UFF 58 (one dataset per channel; atomically).

    Raises InputError when ``dt`` needs more than the 6 significant digits the format's
    E13.5 header field keeps."""
    path = Path(path)
    if float(f"{float(dt):.5e}") != float(dt):
        raise InputError(f"{path.name}: field `dt`: {float(dt)!r} s needs more than the 6 "
                         "significant digits UFF 58 stores (E13.5); write .npz or CSV")
    pyuff = pyuff_module()
    sets = [_uff_dataset(pyuff, f"u:{c}", np.asarray(r, dtype=float), dt, input_units,
                         input_quantity, k + 1) for k, (c, r) in enumerate(zip(
                             input_channels, np.atleast_2d(u), strict=True))]
    if y is not None:
        assert output_units is not None and output_quantity is not None
        sets += [_uff_dataset(pyuff, f"y:{c}", np.asarray(r, dtype=float), dt, output_units,
                              output_quantity, 1001 + k) for k, (c, r) in enumerate(zip(
                                  output_channels, np.atleast_2d(y), strict=True))]
    write_uff_sets(path, sets)


def write_uff_sets(path, sets: list) -> None:
    """Write pyuff datasets to ``path`` atomically (pyuff writes to a file name: a temporary
    one beside ``path``, then its bytes in one replace)."""
    path = Path(path)
    pyuff = pyuff_module()
    tmp = path.with_name(f".{path.name}.writing")
    if tmp.exists():
        tmp.unlink()
    try:
        pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
        atomic_write_bytes(path, tmp.read_bytes())
    finally:
        if tmp.exists():
            tmp.unlink()


def io_layout_of_header(head) -> bool:
    """Whether a CSV header names input/output columns (``u:``/``y:``) rather than the
    displacement/force layout's (``w:``/``f:``)."""
    return any(_HEAD.match(str(h).strip()) for h in list(head)[1:])


def io_layout_of_sets(sets) -> bool:
    """Whether UFF datasets 58 are in the input/output layout (``u:``/``y:`` channels, or
    unnamed channels of other quantities than displacement and force) rather than the
    displacement/force layout (``w:``/``f:``, or unnamed displacement (8) and force (13))."""
    ids = [str(s.get("id1", "")).strip()[:2] for s in sets]
    if any(i in ("u:", "y:") for i in ids):
        return True
    if any(i in ("w:", "f:") for i in ids):
        return False
    return not all(int(s.get("ordinate_spec_data_type", 0) or 0) in (8, 13) for s in sets)


def is_io_layout(path) -> bool:
    """Whether a CSV/UFF file is in the input/output layout (:func:`io_layout_of_header`,
    :func:`io_layout_of_sets`); False for any other file or one that cannot be read."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        try:
            with path.open(encoding="utf-8") as fh:
                return io_layout_of_header(next(csv.reader(fh), []))
        except (OSError, UnicodeDecodeError):
            return False
    if suffix in (".uff", ".unv"):
        try:
            return io_layout_of_sets(_uff_sets(path.name, path))
        except InputError:
            return False
    return False
