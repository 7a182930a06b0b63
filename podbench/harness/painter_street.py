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

Study layer: it knows the data and the methods; the methods see only records.
"""

from __future__ import annotations

import csv
import io
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from podbench.core.atomic import replace_dir
from podbench.core.iorecords import IORecord, read_io_record
from podbench.core.resources import bundled_scenarios
from podbench.core.threads import single_blas_thread
from podbench.errors import InputError
from podbench.sysid.methods import inputs as _inputs
from podbench.sysid.methods.inputs import FIRLeastSquares, MultipleLoadIO, SingleLoadIO
from podbench.sysid.methods.mdof_peer import MdofIO
from podbench.sysid.methods.peers_io import ERAIO, DMDcIO, OpInfIO

__all__ = ["data_folder", "load_events", "CONFIGS", "run_study", "write_study", "TARGETS"]

TARGETS = {"fir_three_inputs_issue": 0.399, "fir_ground_issue": 0.343, "best_factor": 0.9,
           "seconds": 10.0}
"""The issue's measured baselines and targets (leave-one-event-out mean errors)."""
ONE_G = 1.0


STUDY = "painter_street"
"""The study's name (``podbench run painter_street``) and its folder under ``scenarios/``."""

def data_folder() -> Path:
    """The bundled records (``scenarios/painter_street/data``)."""

    return bundled_scenarios() / "painter_street" / "data"


def load_events(folder=None, inputs: str = "three") -> list[IORecord]:
    """The events as IORecords (names: the file stems), sorted by file name.

    ``inputs="three"``: channels 3, 17, 20; ``"ground"``: every ground-level channel."""
    folder = Path(folder) if folder is not None else data_folder()
    files = sorted(folder.glob("*.npz"))
    if not files:
        raise InputError(f"{folder}: no .npz records")
    recs = []
    for f in files:
        rec = read_io_record(f)
        if inputs == "ground":
            with np.load(f, allow_pickle=False) as z:
                if "ground" not in z.files:
                    raise InputError(f"{f.name}: variable `ground`: missing")
                rec = IORecord(u=z["ground"], y=rec.y, dt=rec.dt,
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
    folder = Path(folder) if folder is not None else data_folder()
    with open(folder / "events.csv", newline="") as fh:
        return {Path(r["file"]).stem: r for r in csv.DictReader(fh)}


@dataclass(frozen=True)
class Config:
    inputs: str
    label: str
    make: object
    note: str = ""


def _configs():

    return [
        Config("three", "FIR-LS", lambda: FIRLeastSquares(),
               "baseline: FIR least squares per output channel, lags 0.25–2 s by "
               "leave-one-event-out on the training events"),
        Config("three", "ML", lambda: MultipleLoadIO(),
               "ML, k = 3 POMs, plain least squares, lags by the same rule (equals FIR-LS)"),
        Config("three", "ML-TC", lambda: MultipleLoadIO(prior="tc"),
               "ML, k = 3 POMs, lags by the rule, TC-prior kernel (τ, γ by "
               "leave-one-event-out on the training events)"),
        Config("three", "SL", lambda: SingleLoadIO(), "SL (refused: inputs not at the outputs)"),
        Config("three", "ERA", lambda: ERAIO(), "ERA/OKID, order by the peers' hold-out rule"),
        Config("three", "DMDc", lambda: DMDcIO(), "DMDc (PyDMD), rank by the hold-out rule"),
        Config("three", "OpInf", lambda: OpInfIO(), "OpInf (opinf), ρ by the hold-out rule"),
        Config("three", "mdof-SRIM", lambda: MdofIO(method="srim"),
               "mdof SRIM, order 20, horizon 0.5 s; A, C by mdof, B, D with the records' zero "
               "initial state (workaround of mdof 0.0.23's zero model)"),
        Config("three", "mdof-OKID-ERA",
               lambda: MdofIO(method="okid-era", horizon=0.3, markov=0.6),
               "mdof OKID-ERA, order 20, 0.6 s of Markov parameters, Hankel 0.3 s (mdof's "
               "pseudo-inverse of the whole joined record: longer costs minutes per fold); "
               "the OKID recursion's missing term restored (mdof 0.0.23 drops it)"),
        Config("ground", "FIR-LS", lambda: FIRLeastSquares(),
               "FIR least squares, every ground-level channel as input"),
        Config("ground", "ML-TC", lambda: MultipleLoadIO(prior="tc"),
               "ML-TC, every ground-level channel as input"),
    ]


CONFIGS = _configs


def _loeo(recs, make):
    """Leave-one-event-out: (errors per event, per-output errors, predictions, choices, s)."""

    _inputs._GRAMS.clear()  # every method pays for its own Grams in its timing
    t0 = time.perf_counter()
    errs, per_out, preds, choices = [], [], [], []
    for j, target in enumerate(recs):
        model = make().fit([r for i, r in enumerate(recs) if i != j])
        yh = model.predict(target)
        preds.append(yh)
        errs.append(float(np.linalg.norm(yh - target.y) / np.linalg.norm(target.y)))
        per_out.append(np.linalg.norm(yh - target.y, axis=1) / np.linalg.norm(target.y, axis=1))
        choices.append(dict(model.info_))
    return np.array(errs), per_out, preds, choices, time.perf_counter() - t0


def run_study(folder=None, progress=None, methods=None) -> dict:
    """Run every configuration (``methods``: only these labels); returns the results (tables
    are made by :func:`write_study`)."""

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
                errs, per_out, pr, choices, secs = _loeo(recs, cfg.make)
            except InputError as exc:
                summary.append({"inputs": cfg.inputs, "method": cfg.label, "status": "refused",
                                "mean_error": "", "median_error": "", "max_error": "",
                                "seconds": "", "note": str(exc)})
                continue
            preds[(cfg.inputs, cfg.label)] = pr
            for rec, e, po, ch in zip(recs, errs, per_out, choices, strict=True):
                rows.append({"event": rec.name, "inputs": cfg.inputs, "method": cfg.label,
                             "total_error": e,
                             **{f"error_ch{c}": v for c, v in zip(rec.output_channels, po,
                                                                   strict=True)}})
                fits.append({"event": rec.name, "inputs": cfg.inputs, "method": cfg.label,
                             **{k: v for k, v in ch.items() if k != "cv_error"}})
            summary.append({"inputs": cfg.inputs, "method": cfg.label, "status": "ok",
                            "mean_error": float(np.mean(errs)),
                            "median_error": float(np.median(errs)),
                            "max_error": float(np.max(errs)), "seconds": secs,
                            "note": cfg.note})
    return {"rows": rows, "fits": fits, "summary": summary, "preds": preds,
            "records": data, "events": events_table(folder)}


def _csv(rows, columns) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def _mean(summary, inputs, method):
    for s in summary:
        if s["inputs"] == inputs and s["method"] == method and s["status"] == "ok":
            return s["mean_error"]
    return float("nan")


_MDOF_AND_LEFT = (
    "## mdof 0.0.23 (BSD-2) as a peer",
    "",
    "Two faults were found and worked around (podbench/sysid/methods/mdof_peer.py; "
    "tests/measured_io/test_mdof_peer.py):",
    "",
    "- `mdof.markov.okid`: the Markov recursion's loop `for i in range(k-1)` drops the "
    "term Ȳ2[k−1]·D; on an exact 4-state system h_0 and h_1 are exact and every h_k from "
    "h_2 on is off by 50–100 %. With `range(k)` every h_k is exact (1e-14). The table's "
    "mdof-OKID-ERA runs mdof's own source with that bound corrected.",
    "- `mdof.realize.srim` returns a zero model (‖B‖ = 3e-11, ‖D‖ = 4e-15 on the first "
    "3000 samples of the 28 Jan 2015 record) when the identified A has an eigenvalue just "
    "outside the unit circle (|λ| = 1.014 there): its output-error step fits an initial "
    "state beside B and D, whose columns C·A^k reach 1e16 over a long record, and the "
    "least-squares cut-off then discards the input columns. It is not the length alone "
    "(the whole 8511-sample record, |λ| = 1.002, gives a non-zero B). The table's "
    "mdof-SRIM takes mdof's A, C and fits B, D with the records' zero initial state.",
    "- mdof identifies from one history: the 13 training records (which start and end "
    "quiet) are joined end to end; orders are mdof's default 20, fixed in advance.",
    "",
    "## Not done here",
    "",
    "- mdof's OKID-ERA-DC variant (only OKID-ERA and SRIM are in the table).",
    "- Prediction bands: `--coverage` is refused until the error-estimate work lands.",
)
"""FINDINGS' sections on mdof's two faults and on what the study leaves out."""


def _strong_events(peaks: dict, strong: list, top: str) -> list[str]:
    """FINDINGS' paragraph on the events above 1 g (none is shipped)."""
    if strong:
        return [f"Events above 1 g among the shipped ones: {', '.join(strong)}."]
    return [
        "None of the 14 shipped events exceeds 1 g: the largest peak (input or output) "
        f"is {peaks[top]:.3f} g ({top}). The two > 1 g events of the station (20 Dec "
        "2022 M6.4, Jan 2023) are among the held-out events, so how far a model "
        "identified from small events is off there cannot be measured on these data; "
        "the largest shipped event's error is in errors.csv."]


def _findings(res) -> str:
    S = res["summary"]
    ev = res["events"]
    fir3 = _mean(S, "three", "FIR-LS")
    ml = _mean(S, "three", "ML")
    mltc = _mean(S, "three", "ML-TC")
    peers = {m: _mean(S, "three", m) for m in ("ERA", "DMDc", "OpInf", "mdof-SRIM",
                                                "mdof-OKID-ERA")}
    peers = {k: v for k, v in peers.items() if np.isfinite(v)}
    firg = _mean(S, "ground", "FIR-LS")
    mlg = _mean(S, "ground", "ML-TC")
    best = min(mltc, mlg, ml)
    peaks = {k: max(float(v["pga_inputs_g"]), float(v["peak_outputs_g"])) for k, v in ev.items()}
    strong = [k for k, p in peaks.items() if p > ONE_G]
    top = max(peaks, key=peaks.get)

    def ok(flag):
        return "met" if flag else "NOT met"

    lines = [
        "# Painter Street Overpass: findings",
        "",
        "Leave-one-event-out over the 14 bundled events (CESMD/CSMIP station 89324, "
        "2012–2023; units m/s², errors ‖ŷ − y‖_F/‖y‖_F over the three transverse "
        "outputs, ch 7, 9, 4). Every hyper-parameter is chosen on the 13 training events "
        "only. Generated by `podbench run painter_street`; the tables are `summary.csv` "
        "(per method), `errors.csv` (per event) and `fits.csv` (each fold's choices).",
        "",
        "| inputs | method | mean | median | max |",
        "|---|---|---|---|---|",
    ]
    for s in S:
        if s["status"] == "ok":
            lines.append(f"| {s['inputs']} | {s['method']} | {s['mean_error']:.3f} | "
                         f"{s['median_error']:.3f} | {s['max_error']:.3f} |")
        else:
            lines.append(f"| {s['inputs']} | {s['method']} | refused | | |")
    lines += [
        "",
        "## Targets",
        "",
        f"- ML (plain least squares, k = 3 POMs) {ml:.3f} = FIR-LS {fir3:.3f}: with as many "
        "POMs as outputs the POD basis is a rotation of the outputs and ML *is* the FIR "
        "baseline (a test checks it to round-off); the lag rule chose the same lengths.",
        f"- ML-TC {mltc:.3f} ≤ FIR-LS {fir3:.3f} (issue: 0.399): "
        f"{ok(mltc <= fir3)}; below every peer "
        f"({', '.join(f'{k} {v:.3f}' for k, v in peers.items())}): "
        f"{ok(all(mltc < v for v in peers.values()))}.",
        f"- Every ground-level channel as input: FIR-LS {firg:.3f} (issue: 0.343), ML-TC "
        f"{mlg:.3f}. podbench's best {best:.3f} ≤ 0.9 × three-input baseline "
        f"{0.9 * fir3:.3f}: {ok(best <= 0.9 * fir3)}.",
        "- Time (target: all 14 events identified and predicted in < 10 s on 2 cores): "
        "measured per method in `timing.csv` (wall-clock, one BLAS thread, the "
        "hyper-parameter rules included; it varies with the machine's load, so it is kept "
        "out of the deterministic tables).",
        "- SL is refused (message in summary.csv): its diagonal assumption pairs each POM "
        "with its own modal force, and ground accelerations are not forces at the outputs. "
        "MR is refused for the same records: it needs free responses.",
        "",
        "## Events above 1 g",
        "",
    ]
    lines += _strong_events(peaks, strong, top)
    worst = max((r for r in res["rows"] if r["method"] == "ML-TC" and r["inputs"] == "three"),
                key=lambda r: r["total_error"])
    lines += [
        "",
        f"The worst-predicted event (ML-TC, three inputs) is {worst['event']} "
        f"({worst['total_error']:.3f}), the M4.9 aftershock 5 minutes after the M6.4 "
        "that the data README says deviates from the others."
        if worst["event"] == "20221220_nc73821046" else
        f"The worst-predicted event (ML-TC, three inputs) is {worst['event']} "
        f"({worst['total_error']:.3f}).",
        "",
        *_MDOF_AND_LEFT,
    ]
    return "\n".join(lines) + "\n"


def _figure(res, path: Path, which: str = "median") -> str:
    """Measured vs predicted deck acceleration (ch 9), ML-TC and FIR-LS, three inputs: the
    event of median ML-TC error (``which="median"``) or of the largest peak input
    (``"largest"``); the whole record and ±5 s around the measured peak."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ev = res["events"]
    recs = res["records"]["three"]
    errs = {r["event"]: r["total_error"] for r in res["rows"]
            if r["method"] == "ML-TC" and r["inputs"] == "three"}
    if which == "median":
        order = sorted(range(len(recs)), key=lambda i: (errs[recs[i].name], recs[i].name))
        j = order[(len(order) - 1) // 2]
    else:
        j = max(range(len(recs)), key=lambda i: float(ev[recs[i].name]["pga_inputs_g"]))
    rec = recs[j]
    ch = rec.output_channels.index("9")
    yh = res["preds"][("three", "ML-TC")][j][ch]
    fir = res["preds"][("three", "FIR-LS")][j][ch]
    t = rec.t
    tp = t[int(np.argmax(np.abs(rec.y[ch])))]
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.2), constrained_layout=True)
    for ax, (lo, hi) in zip(axes, ((0, t[-1]), (tp - 5, tp + 5)), strict=True):
        m = (t >= lo) & (t <= hi)
        ax.plot(t[m], rec.y[ch][m], color="k", lw=0.9, label="measured")
        ax.plot(t[m], yh[m], color="C3", lw=0.8, label="ML-TC, identified from the other 13")
        if hi - lo <= 10:
            ax.plot(t[m], fir[m], color="C0", lw=0.6, ls="--", label="FIR-LS baseline")
        ax.set_ylabel("deck accel. ch 9, m/s²")
    axes[-1].set_xlabel("time, s")
    axes[-1].legend(loc="upper right", fontsize=7)
    e = float(np.linalg.norm(yh - rec.y[ch]) / np.linalg.norm(rec.y[ch]))
    axes[0].set_title(
        f"Painter Street Overpass, {ev[rec.name]['title']} (peak input "
        f"{float(ev[rec.name]['pga_inputs_g']):.3f} g)\ntransverse deck acceleration near the "
        f"east abutment predicted from 3 ground accelerations; ML-TC error on ch 9: {e:.2f}",
        fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return rec.name


def write_study(res, out) -> None:
    """Write ``out``/summary.csv, errors.csv, fits.csv, FINDINGS.md, figures/ as a whole."""
    out = Path(out)
    with replace_dir(out) as tmp:
        (tmp / "summary.csv").write_text(_csv(res["summary"], [
            "inputs", "method", "status", "mean_error", "median_error", "max_error", "note"]))
        (tmp / "timing.csv").write_text(_csv(
            [s for s in res["summary"] if s["status"] == "ok"],
            ["inputs", "method", "seconds"]))
        cols = ["event", "inputs", "method", "total_error"]
        cols += sorted({k for r in res["rows"] for k in r if k.startswith("error_ch")})
        (tmp / "errors.csv").write_text(_csv(res["rows"], cols))
        fcols = ["event", "inputs", "method"]
        fcols += sorted({k for r in res["fits"] for k in r} - set(fcols))
        (tmp / "fits.csv").write_text(_csv(res["fits"], fcols))
        (tmp / "FINDINGS.md").write_text(_findings(res))
        if not res.get("no_figures") and ("three", "ML-TC") in res["preds"] \
                and ("three", "FIR-LS") in res["preds"]:
            (tmp / "figures").mkdir()
            _figure(res, tmp / "figures" / "deck_acceleration.png", "median")
            _figure(res, tmp / "figures" / "deck_acceleration_largest.png", "largest")
