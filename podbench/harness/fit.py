"""``podbench fit``: fit a registered method on training record files and keep the model.

The files, the method and ``--solver``/``--n-modes`` are read and checked as
``podbench predict`` reads them (:mod:`podbench.harness.predict`). The output folder ``OUT``
(built beside its place and swapped in whole):

* ``OUT/model.npz``: the fitted model with its provenance (:mod:`podbench.sysid.models`:
  arrays plus a JSON header with ``format_version``; no pickles);
* ``OUT/model.json``: its readable summary: the method, its parameters, the training files
  with their SHA-256, ``dt``, channels, units, the podbench version, what the fit chose
  (solver, lags, prior, order) and how the state-space realization and its physical modes
  were chosen (or, where the method has no state-space form, the one line why);
* ``OUT/modes.csv``: one row per physical mode sorted by frequency, ``mode,
  frequency_hz, damping_ratio, shape:<output channel>…`` (the real, phase-aligned shape,
  largest |component| = 1); not written where the method has no state-space form.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from podbench.core.atomic import replace_dir
from podbench.core.records import check_records
from podbench.core.threads import single_blas_thread
from podbench.errors import InputError
from podbench.harness.predict import (
    command_line_estimator,
    file_period,
    fit_records,
    fitted_config,
    method_entry,
    min_samples_of,
    read_any,
)
from podbench.sysid.modal import response_modes
from podbench.sysid.models import Model, realization_summary

__all__ = ["FitResult", "fit_files", "modes_table"]


@dataclass
class FitResult:
    """What :func:`fit_files` wrote: the ``model`` (a :class:`~podbench.sysid.models.Model`),
    the folder ``out``, the ``modes`` table (None where the method has no state-space form)
    and ``note`` (why not)."""

    model: Model
    out: Path
    modes: pd.DataFrame | None
    note: str = ""


def modes_table(method) -> tuple[pd.DataFrame | None, dict]:
    """The physical modes of a fitted method and, for model.json, its realization summary
    and how the modes were chosen; None and the one-line reason (``modes_reason``) where
    it has no state-space form. A kernel over one period (``inputs="periodic"``: the
    frequency response on the excited lines) gets the modes of its frequency response's
    rational fit instead (:func:`response_modes_table`)."""
    if getattr(method, "inputs_", None) == "periodic":
        return response_modes_table(method)
    summary, table = realization_summary(method)
    if table is None:
        return None, {**summary, "modes_table": None, "modes_reason": summary["reason"]}
    return table, {**summary, "modes_table": "modes.csv", "modes_count": len(table)}


def response_modes_table(method) -> tuple[pd.DataFrame | None, dict]:
    """The modes of a periodic fit from its frequency response on the excited lines, as
    the F-16 study finds them (:func:`~podbench.sysid.modal.response_modes`: a
    common-denominator rational fit with :data:`~podbench.sysid.modal.RESPONSE_POLES`
    poles over every output and input, its physical poles stable against the fits with 2
    and 4 more). A model per force level (``ML-interp``) has its modes at each training
    level (``input_rms``, the level's input RMS in the input unit); the others one set.
    ``model.json`` states the rule and the pole-count range over which the study gives its
    verdict."""
    rec = method.training_records_[0]
    channels = rec.output_channels or tuple(str(i) for i in range(rec.n_outputs))
    names = tuple(f"{c}/{i}" for c in channels for i in (rec.input_channels or
                                                         range(rec.n_inputs)))
    names = channels if rec.n_inputs == 1 else names
    f = method.frequencies_
    responses = [(None, method.frequency_response())]
    if hasattr(method, "level_responses_"):
        responses = [(float(a), np.einsum("ok,kil->oil", method.modes_, G))
                     for a, G in zip(method.levels_, method.level_responses_, strict=True)]
    tables, rules = [], []
    for level, G in responses:
        modes, _, rule = response_modes(G.reshape(-1, G.shape[-1]), f, rec.dt, names,
                                        source="rational fit of the frequency response")
        t = modes.table()
        if level is not None:
            t.insert(0, "input_rms", level)
            rule = f"level {level:.6g} (input RMS): {rule}"
        tables.append(t)
        rules.append(rule)
    table = pd.concat(tables, ignore_index=True)
    summary = {"realization": None, "modes_rule": rules,
               "modes_poles_range": RESPONSE_POLES_RANGE,
               "modes": table.to_dict(orient="records"), "modes_table": "modes.csv",
               "modes_count": len(table)}
    return table, summary


RESPONSE_POLES_RANGE = "16-32 poles: the F-16 study's verdict range (docs/studies/f16_gvt.md)"
"""The range of pole counts over which the F-16 study reports the torsion mode
(:data:`podbench.harness.f16_gvt.POLE_RANGE`); model.json names it beside the one count
used."""


def fit_files(method: str, train, out, *, solver: str = "auto", n_modes=None,
              input_units=None, output_units=None, units=None) -> FitResult:
    """Fit ``method`` on the ``train`` files and write ``out`` (module docstring). Raises
    InputError (one line naming the file and the field, or the option) before anything is
    written."""
    train = [str(p) for p in train]
    if not train:
        raise InputError("Parameter `train`: no training file given")
    entry = method_entry(method)
    kw = dict(input_units=input_units, output_units=output_units, system=units)
    tr = [read_any(p, **kw, require_outputs=True) for p in train]
    est = command_line_estimator(entry, tr, solver=solver, n_modes=n_modes,
                                 period=file_period(train))
    check_records(tr, min_samples=min_samples_of(est, tr[0].dt))
    with single_blas_thread():
        fit_records(est, tr, train)
        table, summary = modes_table(est)
    model = Model(est, training_files=train)
    config = fitted_config(entry, est, train, [])
    extra = {"configuration": entry.name, "fitted": config["fitted"], "chosen": config["chosen"],
             "inputs": config["inputs"], **summary}
    with replace_dir(out) as tmp:
        model.save(tmp / "model.npz", extra=extra)
        if table is not None:
            table.to_csv(tmp / "modes.csv", index=False, float_format="%.6g",
                         lineterminator="\n")
    return FitResult(model=model, out=Path(out), modes=table,
                     note=str(summary.get("modes_reason", "")))
