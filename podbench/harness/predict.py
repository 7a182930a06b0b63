"""``podbench predict``: fit a registered method on training record files, predict every target.

The method is any name of :mod:`podbench.sysid.registry` (a class or a configuration, letter
case aside) or a user's ``file.py:Class``; the records are read by the one reader of
:mod:`podbench.core.recordfiles` (``.npz``, ``.mat``, CSV, UFF 58; the displacement/force
layout and the input/output layout alike, free responses included) and checked against the
first training file (``dt``, channels, quantities, units, NaN/Inf, length) before any
fitting: the first problem is one line naming the file and the field. ``--solver`` and
``--n-modes`` become the method's parameters through
:meth:`~podbench.sysid.methods.PODMethod.command_line_params`. A method on a periodic
excitation (ML-periodic, BLA, ML-interp) takes its period from the training files'
``period_samples`` (:func:`file_period`).

The output folder ``OUT`` (built beside its place and swapped in whole: nothing half-written
is left):

* ``OUT/<target stem>.npz``: ``y_hat`` (n_out × n), ``W_hat`` as well when the outputs are
  displacements, ``lower`` and ``upper`` with ``--coverage``, ``dt`` (s), ``units``,
  ``quantity``, ``output_channels``;
* ``OUT/errors.csv``: one row per target, ``target`` (the file stem), ``method``,
  ``total_error`` (‖ŷ − y‖_F/‖y‖_F where the target holds outputs, empty otherwise),
  ``units`` (of the outputs), ``error:<channel>`` per output channel (empty for a channel
  whose measured output is zero), and with
  ``--coverage`` ``error_estimate`` (the predicted total error, three significant digits),
  ``coverage`` (the fraction of the target's measured samples inside the band) and ``note``
  (why no estimate is given, where none can be made);
* ``OUT/config.json``: the fitted configuration: the method, its class and parameters, what
  the fit chose (solver, lags, prior, order: its diagnostics and the choices as
  parameters), the training and target files.

A target that is also a training file gets a warning: its error measures the fit, not a
prediction. The band (``--coverage``) is calibrated on the training records
(:mod:`podbench.sysid.methods.bands`); on measured inputs by leave-one-record-out, which
needs at least :data:`MIN_BAND_RECORDS` training records. A measured target's outputs hold
its noise: its coverage is that of the measurement, not of the noise-free response.
"""

from __future__ import annotations

import csv
import inspect
import io
import json
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from podbench.core.atomic import replace_dir
from podbench.core.hints import percent_hint
from podbench.core.recordfiles import read_record
from podbench.core.records import Record, check_compatible, check_records
from podbench.core.threads import single_blas_thread
from podbench.core.units import normalize_unit
from podbench.core.version import __version__
from podbench.errors import InputError, PodbenchWarning, RecordTooShortError
from podbench.sysid import registry
from podbench.sysid.methods.bands import check_coverage
from podbench.sysid.models import load_model

__all__ = ["MIN_BAND_RECORDS", "PredictResult", "read_any", "predict_files"]

MIN_BAND_RECORDS = 3
"""Training records ``--coverage`` needs on measured inputs: leave-one-record-out folds of at
least two records (ML's lag length and TC prior are themselves chosen by
leave-one-record-out)."""


@dataclass
class PredictResult:
    """What :func:`predict_files` wrote: ``rows`` (of errors.csv, one per target), ``out``
    (the folder), ``config`` (config.json as a dict) and the ``warnings`` given."""

    rows: list[dict]
    out: Path
    config: dict
    warnings: list[str] = field(default_factory=list)


def read_any(path, *, input_units=None, output_units=None, system=None,
             default_output_units=None, require_outputs: bool = False) -> Record:
    """A record from a file of either layout (:func:`podbench.core.recordfiles.read_record`);
    ``default_output_units``: the unit of a target without outputs. A unit given for files
    that carry none must be a known one even when this file carries its own."""
    for name, unit in (("input_units", input_units), ("output_units", output_units)):
        if unit is not None:
            normalize_unit(unit, f"Parameter `{name}`")
    return read_record(path, input_units=input_units, output_units=output_units,
                       require_outputs=require_outputs, system=system,
                       default_output_units=default_output_units)


def _check_request(train, targets, coverage) -> tuple[list[str], float | None]:
    if not train:
        raise InputError("Parameter `train`: no training file given")
    if not targets:
        raise InputError("Parameter `target`: no target file given")
    stems = [Path(t).stem for t in targets]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise InputError(f"Parameter `target`: two targets share the file stem {dup[0]!r} (the "
                         "predictions are named after it)")
    if coverage is not None:
        try:
            coverage = check_coverage(coverage)
        except InputError:
            raise InputError(f"Parameter `coverage`: expected a number in (0, 1), got "
                             f"{coverage!r}{percent_hint(coverage)}") from None
    return stems, coverage


def method_entry(method: str) -> registry.Entry:
    try:
        return registry.resolve(method, Path.cwd())
    except InputError as exc:
        raise InputError(f"Parameter `method`: {exc}") from None


def _same_files(train, targets) -> list[str]:
    """Warnings for targets that are also training files."""
    seen = {Path(p).resolve() for p in train}
    return [f"target {p} is also a training file; its error measures the fit, not a "
            "prediction" for p in targets if Path(p).resolve() in seen]


PERIOD_FIELD = "period_samples"
"""The variable of a record file (``.npz``) that holds the samples per period of a periodic
excitation: the period a method on a periodic excitation (``inputs="periodic"``: ML-periodic,
BLA, ML-interp) takes on the command line."""


def file_period(paths) -> int | None:
    """The samples per period the training files carry (:data:`PERIOD_FIELD` of their
    ``.npz``), None if none carries it; files that disagree, or a value that is not an
    integer of at least 2, are one line naming the file and the field."""
    found: list[tuple[str, int]] = []
    for path in paths:
        if Path(path).suffix.lower() != ".npz":
            continue
        with np.load(path, allow_pickle=False) as z:
            if PERIOD_FIELD not in z.files:
                continue
            v = np.asarray(z[PERIOD_FIELD])
        if v.ndim != 0 or v.dtype.kind not in "iu" or int(v) < 2:
            raise InputError(f"{path}: field `{PERIOD_FIELD}`: expected an integer >= 2 (samples "
                             f"per period), got {v.tolist()!r}")
        if found and int(v) != found[0][1]:
            raise InputError(f"{path}: field `{PERIOD_FIELD}`: {int(v)} differs from "
                             f"{found[0][0]}'s {found[0][1]} samples per period")
        found.append((str(path), int(v)))
    return found[0][1] if found else None


def _periodic_params(entry, est, period) -> dict:
    """``{"period": period}`` for a method on a periodic excitation whose period is open
    (the configuration leaves it, or the class's ``period`` is None), else ``{}``; one line
    if the period is needed and no training file carries it."""
    wants = "period" in entry.supplied or (
        getattr(est, "inputs", None) == "periodic" and est.get_params().get("period") is None)
    if not wants:
        return {}
    if period is None:
        raise InputError(f"Parameter `method`: {entry.name} identifies the kernel over one "
                         f"period of a periodic excitation: no training file carries "
                         f"`{PERIOD_FIELD}` (the samples per period)")
    return {"period": period}


def _period_keyword(est, period) -> dict:
    """``{"period": period}`` for ``command_line_params`` when the files carry a period and
    the method's ``command_line_params`` takes one (a user's class written before the
    keyword existed may not)."""
    if period is None:
        return {}
    accepts = inspect.signature(est.command_line_params).parameters
    return {"period": period} if "period" in accepts else {}


def command_line_estimator(entry, train: list[Record], *, solver: str, n_modes,
                           period: int | None = None):
    """The estimator of ``entry`` with the parameters ``--solver`` and ``--n-modes`` mean
    for these training records (and ``period``, the samples per period the training files
    carry, for a method on a periodic excitation); the number of training files checked
    against the method's."""
    if entry.cls.composite:
        raise InputError(f"Parameter `method`: {entry.name}: a sum of methods, each fitted "
                         "on its own training records; predict with its parts")
    given = {} if n_modes is None else {"n_modes": n_modes}
    if "period" in entry.supplied:
        given.update(_periodic_params(entry, None, period))
    missing = [p for p in entry.supplied if p not in given]
    if missing:
        raise InputError(f"Parameter `method`: {entry.name}: the configuration leaves "
                         f"{', '.join(missing)} to its caller; name a method that fixes it")
    est = entry.build(**{p: given[p] for p in entry.supplied})
    cli = est.command_line_params(train, solver=solver, n_modes=n_modes,
                                  **_period_keyword(est, period))
    cli.update(_periodic_params(entry, est, period))
    if "n_lags" in entry.params and entry.params["n_lags"] is None:
        cli.pop("prior", None)  # a configuration of the whole-record kernel: no lag prior
    est = entry.build(**{**est.get_params(deep=False), **cli, **entry.params})
    est._validate_params()
    lo, hi = est.n_records
    if len(train) < lo or (hi is not None and len(train) > hi):
        want = f"exactly {lo}" if lo == hi else (f"at least {lo}" if hi is None
                                                  else f"{lo} to {hi}")
        raise InputError(f"Parameter `train`: {entry.name} identifies from {want} training "
                         f"file(s), got {len(train)}")
    return est


def min_samples_of(est, dt: float) -> int:
    """The shortest record the method can take: its shortest lag length, else 2."""
    if getattr(est, "n_lags", None) == "auto" and getattr(est, "lag_grid", None):
        return int(round(min(est.lag_grid) / dt)) + 1
    return 2


_RECORD_PARAMETER = re.compile(r"`records\[(\d+)\]\.(\w+)`")


def _name_files(message: str, files) -> str:
    """An estimator's message about ``records[j].field`` said about the files: "Parameter
    `records[1].W`: shape … differs from `records[0].W` …" becomes "b.npz: field `W`: shape …
    differs from a.npz's `W` …" (the command line's user gave files, not a list)."""
    first = _RECORD_PARAMETER.search(message)
    if not message.startswith("Parameter `records[") or first is None:
        return message
    j, name = int(first.group(1)), first.group(2)
    if j >= len(files):
        return message
    rest = message[message.index(":", first.end()) + 1:].strip()
    rest = _RECORD_PARAMETER.sub(
        lambda m: (f"{Path(files[int(m.group(1))]).name}'s `{m.group(2)}`"
                   if int(m.group(1)) < len(files) else m.group(0)), rest)
    return f"{files[j]}: field `{name}`: {rest}"


def fit_records(est, train, files=None) -> None:
    """``est.fit(train)``; a record too short for the model (:class:`RecordTooShortError`)
    is one line naming the shortest training file and its length, and, with ``files`` (the
    paths ``train`` was read from), an estimator's error about ``records[j]`` names the
    j-th file."""
    try:
        est.fit(train)
    except RecordTooShortError as exc:
        short = min(train, key=lambda r: r.n_samples or 0)
        raise RecordTooShortError(f"{short.name}: {exc}", exc.samples, exc.needed) from None
    except InputError as exc:
        if files is None:
            raise
        said = _name_files(str(exc), [str(f) for f in files])
        if said == str(exc):
            raise
        raise type(exc)(said) from None


def _predict_targets(est, records, files, coverage) -> list:
    """``est.predict`` of every target record; a prediction the model refuses (a target
    longer than its kernel, say) is one line naming the target file."""
    preds = []
    for rec, path in zip(records, files, strict=True):
        try:
            preds.append(est.predict(rec, coverage=coverage))
        except InputError as exc:
            if str(exc).startswith(str(path)):
                raise
            raise type(exc)(f"{path}: {exc}") from None
    return preds


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _relative(y_hat: np.ndarray, y: np.ndarray) -> str:
    """``‖ŷ − y‖/‖y‖`` written; empty where ``y`` is zero (a relative error is undefined)."""
    den = float(np.linalg.norm(y))
    return _fmt(float(np.linalg.norm(y_hat - y)) / den) if den > 0 else ""


def _row(stem: str, method: str, rec: Record, channels, p, coverage) -> dict:
    """One row of errors.csv (``p``: the prediction, an array or a Prediction)."""
    yh = np.asarray(p)
    row = {"target": stem, "method": method, "total_error": "", "units": rec.output_units}
    if rec.y is not None:
        row["total_error"] = _relative(yh, rec.y)
    for i, c in enumerate(channels):
        row[f"error:{c}"] = "" if rec.y is None else _relative(yh[i], rec.y[i])
    if coverage is not None:
        finite = np.all(np.isfinite(p.lower)) and np.all(np.isfinite(p.upper)) and \
            np.isfinite(p.error_estimate)
        note = str(getattr(p, "note", "") or "")
        if not finite and not note:
            note = (f"coverage {coverage:g} needs more calibration residuals than the "
                    "training records give (the band is infinite): lower it or add --train "
                    "files")
        row["error_estimate"] = f"{p.error_estimate:.3g}" if finite else ""
        row["coverage"] = "" if rec.y is None or not finite else _fmt(p.covers(rec.y))
        row["note"] = note
    return row


def _arrays(rec: Record, ref: Record, p, coverage) -> dict:
    """The arrays of ``<target stem>.npz``."""
    mean = np.asarray(p, dtype=float)
    out = {"y_hat": mean}
    if ref.output_quantity == "displacement":
        out["W_hat"] = mean
    if coverage is not None:
        out["lower"], out["upper"] = p.lower, p.upper
    out.update(dt=np.float64(rec.dt), units=np.array(ref.output_units),
               quantity=np.array(ref.output_quantity),
               output_channels=np.array(ref.output_channels))
    return out


def fitted_config(entry, est, train, targets) -> dict:
    """config.json: the fitted configuration."""
    def plain(v):
        return v if isinstance(v, (int, float, str, bool, type(None))) else str(v)

    params = {k: plain(v) for k, v in est.get_params(deep=False).items()}
    chosen = {k: plain(v) for k, v in est.frozen_params().items()}
    return {"method": entry.name, "class": type(est).__name__, "parameters": params,
            "fitted": {k: plain(v) for k, v in est.diagnostics_.items()}, "chosen": chosen,
            "inputs": getattr(est, "inputs_", None), "train": [str(p) for p in train],
            "targets": [str(p) for p in targets], "podbench": __version__}


def predict_files(method: str | None, train, targets, out, *, solver: str = "auto",
                  n_modes=None, coverage=None, input_units=None, output_units=None,
                  units=None, model=None) -> PredictResult:
    """Fit ``method`` on the ``train`` files, predict the ``targets``, write ``out``
    (module docstring); or, with ``model`` (a ``model.npz`` of ``podbench fit``), predict
    with the saved model. Raises InputError (one line naming the file and the field, or the
    option) before anything is written."""
    if model is not None:
        return _predict_saved(model, method, train, targets, out, solver=solver,
                              n_modes=n_modes, coverage=coverage, input_units=input_units,
                              output_units=output_units, units=units)
    stems, coverage = _check_request(train, targets, coverage)
    entry = method_entry(method)
    kw = dict(input_units=input_units, output_units=output_units, system=units)
    tr = [read_any(p, **kw, require_outputs=True) for p in train]
    tg = [read_any(p, **kw, default_output_units=tr[0].output_units) for p in targets]
    est = command_line_estimator(entry, tr, solver=solver, n_modes=n_modes,
                                 period=file_period(train))
    check_records(tr, tg, min_samples=min_samples_of(est, tr[0].dt))
    if coverage is not None and tr[0].u is not None and not tr[0].collocated and \
            len(tr) < MIN_BAND_RECORDS:
        raise InputError(f"Parameter `coverage`: the band is calibrated by "
                         f"leave-one-record-out over the training records (each fold fitted on "
                         f"the others, with its own lag and prior choice): give at least "
                         f"{MIN_BAND_RECORDS} training files, got {len(tr)}")
    said = _same_files(train, targets)
    for text in said:
        warnings.warn(text, PodbenchWarning, stacklevel=2)
    with single_blas_thread():
        fit_records(est, tr, train)
        preds = _predict_targets(est, tg, targets, coverage)
    channels = tr[0].output_channels or ()
    rows = [_row(stem, entry.name, rec, channels, p, coverage)
            for stem, rec, p in zip(stems, tg, preds, strict=True)]
    config = fitted_config(entry, est, train, targets)
    _write(out, rows, {stem: _arrays(rec, tr[0], p, coverage)
                       for stem, rec, p in zip(stems, tg, preds, strict=True)}, config)
    return PredictResult(rows=rows, out=Path(out), config=config, warnings=said)


def _saved_reference(est, name: str) -> Record:
    """The record a saved model's targets are checked against: its first training record
    (kept in the file), else the reference record of its channels."""
    recs = getattr(est, "training_records_", None) or []
    ref = recs[0] if recs else getattr(est, "reference_", None)
    if ref is None:
        raise InputError(f"{name}: field `state`: the model keeps no training record to check "
                         "targets against (saved with include_records=False)")
    return ref


def _predict_saved(model, method, train, targets, out, *, solver, n_modes, coverage,
                   input_units, output_units, units) -> PredictResult:
    """``predict --model``: the saved model's prediction of every target (each checked
    against the model's dt, channels and units first)."""
    given = [f"--{k}" for k, v in (("method", method), ("train", train),
                                   ("n-modes", n_modes)) if v]
    if solver != "auto":
        given.append("--solver")
    if given:
        raise InputError(f"Parameter `model`: a saved model is already fitted; {given[0]} "
                         "applies to a fit (drop it, or drop --model)")
    stems, coverage = _check_request(["(model)"], targets, coverage)
    path = Path(model)
    est = load_model(path)
    ref = _saved_reference(est, path.name)
    kw = dict(input_units=input_units, output_units=output_units, system=units)
    tg = [read_any(p, **kw, default_output_units=ref.output_units) for p in targets]
    for rec in tg:
        check_compatible(ref, rec, min_samples=1)
    with single_blas_thread():
        preds = _predict_targets(est, tg, targets, coverage)
    name = getattr(est, "abbreviation", "") or type(est).__name__
    channels = ref.output_channels or ()
    rows = [_row(stem, name, rec, channels, p, coverage)
            for stem, rec, p in zip(stems, tg, preds, strict=True)]
    config = fitted_config(registry.Entry(name, type(est)), est, [], targets)
    config.update(model=str(path), train=[f["name"] for f in
                                          est.provenance_.get("training_files", [])])
    _write(out, rows, {stem: _arrays(rec, ref, p, coverage)
                       for stem, rec, p in zip(stems, tg, preds, strict=True)}, config)
    return PredictResult(rows=rows, out=Path(out), config=config)


def _write(out, rows: list[dict], arrays: dict, config: dict) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    with replace_dir(out) as tmp:
        for stem, a in arrays.items():
            np.savez_compressed(tmp / f"{stem}.npz", **a)
        (tmp / "errors.csv").write_text(buf.getvalue())
        (tmp / "config.json").write_text(json.dumps(config, indent=2, sort_keys=True) + "\n")
