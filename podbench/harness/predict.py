"""``podbench predict``: fit a method on training record files, predict every target file.

Writes ``OUT/errors.csv`` (one row per target: ``target`` = file stem, ``method``,
``total_error`` = ‖ŷ − y‖_F/‖y‖_F where the target holds outputs, empty otherwise, and the
unit system) and ``OUT/<target stem>.npz`` holding the prediction ``W_hat`` (n_out × n) with
its ``units``, ``output_channels`` and ``dt``. ``OUT`` is built beside its place and swapped
in whole: nothing half-written is left.

Records: input/output files (``inputs``, ``outputs``, ``dt``, channels, units:
:mod:`podbench.core.iorecords`; ``.npz``, ``.mat``, CSV or UFF 58, layouts in
:mod:`podbench.core.iofiles`) or today's displacement/force files (``W``, ``F``:
:mod:`podbench.measured`, in and lbf). On displacement/force files ``ML`` and ``SL`` are the
dissertation's methods (:class:`~podbench.sysid.methods.MultipleLoad`, Eqs. 3.46–3.49, and
:class:`~podbench.sysid.methods.SingleLoad`, Eqs. 3.43–3.44: the POMs of ``W``, the modal
forces ``Uᵀ F``, the deconvolution ``--solver``, default ``auto``), as in the studies; the
other methods read them as input/output records (every force channel an input).

Every file is read and checked against the first training file (``dt``, channels,
quantities, units, NaN/Inf, length) before any fitting; the first problem is one line
naming the file and the field.

``coverage`` (``--coverage``): every prediction gets its band (``lower``, ``upper`` in the
``.npz``) and ``errors.csv`` the columns ``error_estimate`` (the predicted total error, three
significant digits) and ``coverage`` (the fraction of the target's measured samples inside
the band, where it holds outputs). The band is calibrated by leave-one-record-out over the
training records and conformal scaling (:mod:`podbench.sysid.methods.bands`); it needs at
least :data:`MIN_BAND_RECORDS` training records. Note that a measured target's outputs hold
its noise: the coverage of a measured record is that of the measurement, not of the
noise-free response the band is meant to hold.
"""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from pathlib import Path

import numpy as np

from podbench.core.atomic import replace_dir
from podbench.core.iofiles import is_io_layout
from podbench.core.iorecords import (
    UNITS,
    IORecord,
    check_records,
    convert,
    from_record,
    read_io_record,
)
from podbench.core.threads import single_blas_thread
from podbench.errors import InputError
from podbench.sysid.measured import read_record
from podbench.sysid.methods import MultipleLoad, SingleLoad
from podbench.sysid.methods.bands import check_coverage
from podbench.sysid.methods.inputs import FIRLeastSquares, MultipleLoadIO, SingleLoadIO
from podbench.sysid.methods.peers_io import ERAIO, DMDcIO, OpInfIO

__all__ = ["METHODS", "make_method", "read_any", "predict_files"]

METHODS = ("ML", "FIR-LS", "SL", "MR", "ERA", "DMDc", "OpInf")
"""The method names ``podbench predict --method`` takes (SL, MR: refused with the reason
on records whose inputs are not forces at the outputs / that carry no initial condition)."""
MIN_BAND_RECORDS = 3
"""Training records ``--coverage`` needs: leave-one-record-out folds of at least two records
(ML's lag length and TC prior are themselves chosen by leave-one-record-out)."""
SOLVERS_FIR = ("auto", "ls", "tc")
"""``--solver`` for the truncated kernel: ``auto`` (TC prior with three or more training
records, else plain), ``ls`` (plain least squares), ``tc`` (TC prior). Any other name (e.g.
``block``, ``cgls``) is a deconvolution solver on the kernel over the whole record."""


POD_METHODS = {"ML": MultipleLoad, "SL": SingleLoad}
"""``--method`` names that run the dissertation's forced methods on displacement/force files."""


def read_any(path, *, input_units=None, output_units=None, system=None,
             default_output_units=None) -> IORecord:
    """An input/output record from a file (input/output layout or W/F layout; ``.npz``,
    ``.mat``, CSV, UFF 58). ``default_output_units``: the unit of a target without outputs."""
    path = Path(path)
    if _is_io_file(path):
        return read_io_record(path, input_units=input_units, output_units=output_units,
                              require_outputs=False, system=system,
                              default_output_units=default_output_units)

    rec = from_record(read_record(path), name=path.name)
    return convert(rec, system) if system else rec


def _is_io_file(path: Path) -> bool:
    """True for the input/output layout, False for a displacement/force (W/F) file."""
    suffix = path.suffix.lower()
    return bool((suffix in (".npz", ".mat") and _has(path, "inputs"))
                or (suffix in (".csv", ".uff", ".unv") and is_io_layout(path)))


def _has(path: Path, key: str) -> bool:
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                return key in z.files
        except (OSError, ValueError) as exc:
            raise InputError(f"{path.name}: not a readable .npz file ({exc})") from None
    import scipy.io

    try:
        return key in scipy.io.whosmat(path) or any(v[0] == key for v in scipy.io.whosmat(path))
    except (ValueError, NotImplementedError, OSError) as exc:
        raise InputError(f"{path.name}: not a readable MATLAB file ({exc})") from None


def make_method(name: str, *, solver: str = "auto", n_modes=None, n_train: int = 1):
    """The estimator ``--method``/``--solver``/``--n-modes`` name."""

    if name == "ML":
        if solver in SOLVERS_FIR:
            prior = "tc" if solver == "tc" or (solver == "auto" and n_train >= 3) else None
            return MultipleLoadIO(n_modes=n_modes, prior=prior)
        return MultipleLoadIO(n_modes=n_modes, n_lags=None, solver=solver)
    if name == "FIR-LS":
        return FIRLeastSquares()
    if name == "SL":
        return SingleLoadIO()
    if name == "ERA":
        return ERAIO()
    if name == "DMDc":
        return DMDcIO()
    if name == "OpInf":
        return OpInfIO()
    if name == "MR":
        raise InputError("--method MR: the mixed-response method identifies Φ11, Φ12 from "
                         "free responses (initial conditions) beside forced ones; records "
                         "driven from rest by measured inputs carry none. Use ML")
    raise InputError(f"--method {name!r}: expected one of {', '.join(METHODS)}")


def predict_files(method: str, train, targets, out, *, solver: str = "auto", n_modes=None,
                  coverage=None, input_units=None, output_units=None, units=None) -> list:
    """Fit ``method`` on the ``train`` files, predict the ``targets``, write ``out``.

    Returns the rows of errors.csv. Raises InputError (one line naming the file and the
    field) before anything is written."""

    if not train:
        raise InputError("--train: no training file given")
    if not targets:
        raise InputError("--target: no target file given")
    if coverage is not None:
        coverage = _check_coverage(coverage)
    stems = [Path(t).stem for t in targets]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise InputError(f"--target: two targets share the file stem {dup[0]!r} (the "
                         "predictions are named after it)")
    if method in POD_METHODS and not any(_is_io_file(Path(p))
                                         for p in [*train, *targets] if Path(p).is_file()):
        tg, preds = _predict_wf(method, train, targets, solver=solver, n_modes=n_modes,
                                coverage=coverage, units=units)
    else:
        if coverage is not None:
            _check_band_records(len(train))
        tg, preds = _predict_io(method, train, targets, solver=solver, n_modes=n_modes,
                                coverage=coverage, input_units=input_units,
                                output_units=output_units, units=units)
    rows = [_row(stem, method, rec, p, coverage)
            for stem, rec, p in zip(stems, tg, preds, strict=True)]
    columns = ["target", "method", "total_error", "units"]
    if coverage is not None:
        columns += ["error_estimate", "coverage", "note"]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    with replace_dir(out) as tmp:
        for stem, rec, p in zip(stems, tg, preds, strict=True):
            arrays = p.to_arrays() if coverage is not None else {"W_hat": p}
            np.savez_compressed(tmp / f"{stem}.npz", **arrays, dt=np.float64(rec.dt),
                                units=np.array(tg[0].output_units),
                                quantity=np.array(tg[0].output_quantity),
                                output_channels=np.array(tg[0].output_channels))
        (tmp / "errors.csv").write_text(buf.getvalue())
    return rows


def _predict_io(method, train, targets, *, solver, n_modes, coverage, input_units,
                output_units, units):
    """``(target IORecords, predictions)`` of an input/output method."""
    kw = dict(input_units=input_units, output_units=output_units, system=units)
    tr = [read_any(p, **kw) for p in train]
    tg = [read_any(p, **kw, default_output_units=tr[0].output_units) for p in targets]
    est = make_method(method, solver=solver, n_modes=n_modes, n_train=len(tr))
    min_samples = 2
    if getattr(est, "n_lags", None) == "auto":
        min_samples = int(round(min(est.lag_grid) / tr[0].dt)) + 1
    check_records(tr, tg, min_samples=min_samples)
    with single_blas_thread():
        est.fit(tr)
        preds = [est.predict(r, coverage=coverage) for r in tg]
    return tg, preds


def _predict_wf(method, train, targets, *, solver, n_modes, coverage, units):
    """``(target IORecords, predictions)`` of the dissertation's ML or SL on displacement/
    force files (in, lbf). The methods fit in the files' units; with ``units="SI"`` the
    prediction and its band are converted afterwards (m), as the targets are."""
    if method == "SL" and len(train) != 1:
        raise InputError(f"--train: SL identifies from one forced record (Eqs. 3.43-3.44), "
                         f"got {len(train)} files; give one, or use --method ML")
    est = POD_METHODS[method](n_modes=n_modes, solver=solver)
    recs = [read_record(p) for p in train]
    tgs = [read_record(p) for p in targets]
    io_tr = [from_record(r, name=Path(p).name) for r, p in zip(recs, train, strict=True)]
    io_tg = [from_record(r, name=Path(p).name) for r, p in zip(tgs, targets, strict=True)]
    check_records(io_tr, io_tg, min_samples=2)
    with single_blas_thread():
        est.fit(recs if method == "ML" else recs[0])
        preds = [est.predict(t, coverage=coverage) for t in tgs]
    if units in (None, "inch-lbf"):
        return io_tg, preds
    io_tg = [convert(r, units) for r in io_tg]
    f = UNITS["displacement"]["in"][1] / UNITS["displacement"][io_tg[0].output_units][1]
    return io_tg, [p * f if isinstance(p, np.ndarray) else
                   replace(p, mean=p.mean * f, lower=p.lower * f, upper=p.upper * f)
                   for p in preds]


def _check_coverage(coverage) -> float:
    """``--coverage`` in (0, 1)."""
    try:
        return check_coverage(coverage)
    except InputError:
        raise InputError(f"--coverage: expected a number in (0, 1), got {coverage!r}") from None


def _check_band_records(n_train: int) -> None:
    """Enough training records for an input/output method's band calibration."""
    if n_train < MIN_BAND_RECORDS:
        raise InputError(f"--coverage: the band is calibrated by leave-one-record-out over "
                         f"the training records (each fold fitted on the others, with its own "
                         f"lag and prior choice): give at least {MIN_BAND_RECORDS} --train "
                         f"files, got {n_train}")


def _row(stem: str, method: str, rec: IORecord, p, coverage) -> dict:
    """One row of errors.csv (``p``: the prediction, an array or a Prediction)."""
    yh = np.asarray(p)
    err = ("" if rec.y is None else
           f"{float(np.linalg.norm(yh - rec.y) / np.linalg.norm(rec.y)):.6g}")
    row = {"target": stem, "method": method, "total_error": err, "units": rec.output_units}
    if coverage is not None:
        if np.isfinite(p.error_estimate) and not (np.all(np.isfinite(p.lower))
                                                 and np.all(np.isfinite(p.upper))):
            raise InputError(f"--coverage: {coverage:g} needs more calibration residuals "
                             "than the training records give (the band would be infinite); "
                             "lower it or add --train files")
        if not np.isfinite(p.error_estimate):  # no estimate can be made: say why
            row["error_estimate"], row["coverage"] = "", ""
            row["note"] = p.note
            return row
        row["error_estimate"] = f"{p.error_estimate:.3g}"
        row["coverage"] = "" if rec.y is None else f"{p.covers(rec.y):.6g}"
        row["note"] = ""
    return row
