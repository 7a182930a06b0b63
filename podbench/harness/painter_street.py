"""The Painter Street Overpass study: leave-one-event-out on real earthquake records.

Fourteen earthquakes (2012–2023) recorded by CSMIP station 89324, a two-span concrete
overpass (data: CESMD / CSMIP, California Geological Survey; bundled with their attribution
and the BSD 2-Clause notice of the repository they were obtained from, see
``scenarios/painter_street/data/README.md``). Inputs: absolute transverse
accelerations at the column base (ch 3) and both abutments' ground (17, 20), or every
ground-level channel (1, 2, 3, 15–20); outputs: transverse deck and column-top
accelerations (7, 9, 4), m/s².

For every event, every method is identified from the other thirteen and predicts the
held-out event's outputs from its inputs; its error is ``‖ŷ − y‖_F / ‖y‖_F`` over the three
outputs and the whole record. Every hyper-parameter (lag length, prior, model order) is
chosen by a rule on the thirteen training events only (leave-one-event-out among them, or
the peers' hold-out rule), never on the held-out event.

The deck modes per event (:func:`deck_modes`): ERA/OKID of a fixed order on each event
alone, its physical modes matched by MAC to those of all events together, with the event's
peak ground acceleration: how the modes move with the shaking level.

Harness layer: it runs the methods on the data (the methods see only records) and returns
the numbers; :mod:`podbench.report.painter_street` writes the tables, FINDINGS.md and the
figures, and ``scenarios/painter_street/painter_street.toml`` names this runner
(``[study] runner = "painter_street"``, :data:`podbench.api.RUNNERS`).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from podbench.core.recordfiles import read_record
from podbench.core.records import Record
from podbench.core.resources import bundled_scenarios
from podbench.core.threads import single_blas_thread
from podbench.errors import InputError
from podbench.sysid import registry
from podbench.sysid.methods.inputs import clear_grams
from podbench.sysid.modal import match_modes
from podbench.sysid.realize import to_statespace

__all__ = ["data_folder", "load_events", "events_table", "CONFIGS", "run_study", "TARGETS",
           "deck_modes", "DECK_CHANNELS", "MODES_ORDER", "MODES_BAND_HZ"]

TARGETS = {"fir_three_inputs_baseline": 0.399, "fir_ground_baseline": 0.343,
           "best_factor": 0.9, "seconds": 10.0}
"""The baselines the study was set against (FIR least squares, leave-one-event-out mean
errors measured before the study) and its targets (ML at most ``best_factor`` × the
baseline, in at most ``seconds``)."""

STUDY = "painter_street"
"""The study's name (``podbench run painter_street``) and its folder under ``scenarios/``."""


def data_folder() -> Path:
    """The bundled records (``scenarios/painter_street/data``)."""

    return bundled_scenarios() / "painter_street" / "data"


def load_events(folder=None, inputs: str = "three") -> list[Record]:
    """The events as records (names: the file stems), sorted by file name.

    ``inputs="three"``: channels 3, 17, 20; ``"ground"``: every ground-level channel."""
    folder = Path(folder) if folder is not None else data_folder()
    files = sorted(folder.glob("*.npz"))
    if not files:
        raise InputError(f"{folder}: no .npz records")
    recs = []
    for f in files:
        rec = read_record(f)
        if inputs == "ground":
            with np.load(f, allow_pickle=False) as z:
                if "ground" not in z.files:
                    raise InputError(f"{f.name}: variable `ground`: missing")
                rec = Record(u=z["ground"], y=rec.y, dt=rec.dt,
                               input_units=str(z["ground_units"]),
                               output_units=rec.output_units,
                               input_channels=tuple(str(c) for c in z["ground_channels"]),
                               output_channels=rec.output_channels, name=rec.name)
        elif inputs != "three":
            raise InputError(f"Parameter `inputs`: expected 'three' or 'ground', got {inputs!r}")
        object.__setattr__(rec, "name", f.stem)
        recs.append(rec)
    return recs


def events_table(folder=None) -> dict[str, dict]:
    """The rows of ``events.csv`` (date, magnitude, peak input and output in g, ...) by event
    name (the record file's stem)."""
    folder = Path(folder) if folder is not None else data_folder()
    with open(folder / "events.csv", newline="") as fh:
        return {Path(r["file"]).stem: r for r in csv.DictReader(fh)}


class Config(NamedTuple):
    """One configuration of the study: the ``inputs`` ("three" or "ground"), the method's
    ``label`` in the tables, its registered ``method`` (:mod:`podbench.sysid.registry`), the
    ``note`` of summary.csv and whether its folds get ``bands``."""

    inputs: str
    label: str
    method: str
    note: str = ""
    bands: bool = False


def _configs():

    return [
        Config("three", "FIR-LS", "FIR-LS",
               "baseline: FIR least squares per output channel, lags 0.25–2 s by "
               "leave-one-event-out on the training events", bands=True),
        Config("three", "ML", "ML-lags",
               "ML, k = 3 POMs, plain least squares, lags by the same rule (equals FIR-LS)"),
        Config("three", "ML-TC", "ML-TC",
               "ML, k = 3 POMs, lags by the rule, TC-prior kernel (τ, γ by "
               "leave-one-event-out on the training events)", bands=True),
        Config("three", "SL", "SL", "SL (refused: inputs not at the outputs)"),
        Config("three", "ERA", "ERA-measured", "ERA/OKID, order by the peers' hold-out rule"),
        Config("three", "DMDc", "DMDc", "DMDc (PyDMD), rank by the hold-out rule"),
        Config("three", "OpInf", "OpInf", "OpInf (opinf), ρ by the hold-out rule"),
        Config("three", "mdof-SRIM", "mdof-SRIM",
               "mdof SRIM, order 20, horizon 0.5 s; A, C by mdof, B, D with the records' zero "
               "initial state (workaround of mdof 0.0.23's zero model)"),
        Config("three", "mdof-OKID-ERA", "mdof-OKID-ERA",
               "mdof OKID-ERA, order 20, 0.6 s of Markov parameters, Hankel 0.3 s (mdof's "
               "pseudo-inverse of the whole joined record: longer costs minutes per fold); "
               "the OKID recursion's missing term restored (mdof 0.0.23 drops it)"),
        Config("ground", "FIR-LS", "FIR-LS",
               "FIR least squares, every ground-level channel as input"),
        Config("ground", "ML-TC", "ML-TC", "ML-TC, every ground-level channel as input"),
    ]


CONFIGS = _configs


BAND_COVERAGE = 0.9
"""The nominal coverage of the bands of the configurations with ``bands`` (the harness's)."""


def _loeo(recs, method: str, bands: bool = False):
    """Leave-one-event-out: (errors per event, per-output errors, predictions, choices, s,
    bands). ``bands``: each fold's 90 % band (:mod:`podbench.sysid.methods.bands`, its
    calibration over the 13 training events), as ``(error_estimate, coverage)`` per event;
    coverage is the fraction of the *measured* target's samples inside the band (the true
    response of a real bridge is not known). The seconds count the plain fit and predict
    only."""

    clear_grams()  # every method pays for its own Grams in its timing
    seconds = 0.0
    errs, per_out, preds, choices, band = [], [], [], [], []
    for j, target in enumerate(recs):
        t0 = time.perf_counter()
        model = registry.lookup(method).build().fit([r for i, r in enumerate(recs) if i != j])
        yh = model.predict(target)
        seconds += time.perf_counter() - t0
        preds.append(yh)
        errs.append(float(np.linalg.norm(yh - target.y) / np.linalg.norm(target.y)))
        per_out.append(np.linalg.norm(yh - target.y, axis=1) / np.linalg.norm(target.y, axis=1))
        choices.append(dict(model.info_))
        if bands:
            p = model.predict(target, coverage=BAND_COVERAGE)
            inside = (target.y >= p.lower) & (target.y <= p.upper)
            band.append((float(p.error_estimate), float(np.mean(inside))))
    return np.array(errs), per_out, preds, choices, seconds, band


def _band_summary(errs, band) -> dict:
    """Mean coverage of the 90 % bands and the fraction of events whose error estimate is
    within a factor of 2 of the realized error (empty without bands)."""
    if not band:
        return {}
    est = np.array([b[0] for b in band])
    ratio = est / np.asarray(errs)
    return {"mean_coverage": float(np.mean([b[1] for b in band])),
            "estimate_within_2": float(np.mean((ratio >= 0.5) & (ratio <= 2.0)))}


DECK_CHANNELS = ("7", "9")
"""The deck's output channels (transverse deck accelerations; ch 4 is the column top)."""
MODES_ORDER = 20
"""State dimension of the ERA/OKID realizations the deck modes are read from (mdof's
default order of the peers' rows, fixed in advance)."""
MODES_BAND_HZ = 10.0
"""Upper frequency (Hz) of the deck modes reported."""


def _era_modes(recs):
    """The physical modes of ERA/OKID of order :data:`MODES_ORDER` on ``recs`` (three
    inputs): hard criteria and stabilization at orders 22 and 24
    (:mod:`podbench.sysid.modal`)."""
    model = registry.lookup("ERA-measured").build().set_params(order=MODES_ORDER).fit(recs)
    return to_statespace(model).modes()


def deck_modes(recs) -> tuple[list[dict], list[dict]]:
    """The deck modes identified from each event alone, and their reference.

    The reference: ERA/OKID (:data:`MODES_ORDER`) on the 14 events together, its physical
    modes below :data:`MODES_BAND_HZ` whose largest shape component is at a deck channel
    (:data:`DECK_CHANNELS`). Each event: the same identification on that event alone, its
    physical modes matched to the reference by MAC
    (:func:`podbench.sysid.modal.match_modes`). Returns ``(rows, reference)``: one row per
    (event, reference mode) with the identified frequency (Hz), damping ratio and MAC (NaN
    when no mode of the event has MAC ≥ 0.5 with it), and the reference modes."""
    joint = _era_modes(recs)
    chans = np.array(joint.channels)
    top = chans[np.argmax(np.abs(joint.shapes), axis=0)] if len(joint) else chans[:0]
    ref = joint.subset((joint.frequency_hz < MODES_BAND_HZ) & np.isin(top, DECK_CHANNELS))
    reference = [{"mode": i + 1, "frequency_hz": float(f), "damping_ratio": float(z)}
                 for i, (f, z) in enumerate(zip(ref.frequency_hz, ref.damping_ratio,
                                                strict=True))]
    rows = []
    for rec in recs:
        table = match_modes(_era_modes([rec]), ref)
        for _, m in table.iterrows():
            rows.append({"event": rec.name, "mode": int(m["mode"]),
                         "reference_frequency_hz": float(m["frequency_hz"]),
                         "frequency_hz": float(m["identified_frequency_hz"]),
                         "damping_ratio": float(m["identified_damping_ratio"]),
                         "mac": float(m["mac"])})
    return rows, reference


def run_study(folder=None, progress=None, methods=None) -> dict:
    """Run every configuration (``methods``: only these labels) on the records of ``folder``
    (default: the bundled ones); returns the results: ``rows`` (per event), ``fits``,
    ``summary`` (per method), ``preds``, ``records`` and ``events``, which
    :func:`podbench.report.painter_street.write_study` writes."""

    data = {k: load_events(folder, k) for k in ("three", "ground")}
    rows, fits, preds = [], [], {}
    summary = []
    with single_blas_thread():
        for cfg in _configs():
            if methods is not None and cfg.label not in methods:
                continue
            recs = data[cfg.inputs]
            if progress:
                progress(f"{cfg.inputs} inputs: {cfg.label}")
            try:
                errs, per_out, pr, choices, secs, band = _loeo(recs, cfg.method, cfg.bands)
            except InputError as exc:
                summary.append({"inputs": cfg.inputs, "method": cfg.label, "status": "refused",
                                "mean_error": "", "median_error": "", "max_error": "",
                                "seconds": "", "note": str(exc)})
                continue
            preds[(cfg.inputs, cfg.label)] = pr
            for j, (rec, e, po, ch) in enumerate(zip(recs, errs, per_out, choices,
                                                     strict=True)):
                rows.append({"event": rec.name, "inputs": cfg.inputs, "method": cfg.label,
                             "total_error": e,
                             **{f"error_ch{c}": v for c, v in zip(rec.output_channels, po,
                                                                   strict=True)},
                             **({"error_estimate": band[j][0], "coverage": band[j][1]}
                                if band else {})})
                fits.append({"event": rec.name, "inputs": cfg.inputs, "method": cfg.label,
                             **{k: v for k, v in ch.items() if k != "cv_error"}})
            summary.append({"inputs": cfg.inputs, "method": cfg.label, "status": "ok",
                            "mean_error": float(np.mean(errs)),
                            "median_error": float(np.median(errs)),
                            "max_error": float(np.max(errs)), "seconds": secs,
                            **_band_summary(errs, band), "note": cfg.note})
        if progress:
            progress("deck modes per event (ERA/OKID)")
        modes, reference = deck_modes(data["three"])
    return {"rows": rows, "fits": fits, "summary": summary, "preds": preds,
            "records": data, "events": events_table(folder), "modes": modes,
            "modes_reference": reference}
