"""The F-16 ground vibration test study: linear models across force levels, on real data.

Data: J.P. Noël and M. Schoukens, "F-16 aircraft benchmark based on ground vibration test
data", Workshop on Nonlinear System Identification Benchmarks, Brussels, 2017 (bundled
with their README in ``scenarios/f16_gvt/data/``). One shaker under the right wing (force
measured, N), three accelerometers (m/s²), a multisine on the full grid 2–15 Hz, 9 periods
of 8192 samples at 400 Hz per force level; period 1 holds the start-up transient.

For every set of the study file (training levels → validation levels) every method is
fitted on the training levels and predicts each validation level from its measured force
alone (a simulation from rest over the whole record). Errors as the benchmark defines them
(``e_RMS = sqrt(mean((ŷ − y)²))`` in m/s², per output and over the three) and relative
(``‖ŷ − y‖_F/‖y‖_F`` over the three), over the steady-state periods and over the whole
record; for the periodic methods also the best linear approximation's own prediction (one
steady-state period from the target's period-averaged force spectrum, compared with every
steady-state period). Beside them, per validation level: the level's own BLA (the floor of
any linear model), the linearization error (the distance between the training levels'
model and the level's own, on the level's force) and the POD basis's projection error.

Harness layer: it reads the records, runs the methods (which see only records) and returns
the numbers; :mod:`podbench.report.f16_gvt` writes them.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np

from podbench.core.modeshapes import ModeSet
from podbench.core.recordfiles import read_record
from podbench.core.records import Record, check_records
from podbench.core.threads import single_blas_thread
from podbench.errors import InputError
from podbench.harness.executor import execute
from podbench.study.f16_gvt import F16Plan, MethodEntry, build_estimator, missing_extra
from podbench.sysid.methods.bands import band_coverage
from podbench.sysid.methods.periodic import BestLinearApproximation, input_rms
from podbench.sysid.modal import (
    RESPONSE_POLES,
    STABILITY_ORDERS,
    physical_mask,
    response_fit,
    response_modes,
    stability_mask,
)
from podbench.sysid.periodic import (
    distortion_fractions,
    period_spectra,
    periodic_prediction,
    steady_periods,
)

__all__ = ["level_files", "load_levels", "run_study", "errors", "ISSUE_BLA", "TORSION"]

LEVEL = re.compile(r"level(\d+)_", re.IGNORECASE)
"""A level file's name holds ``level<N>_`` (the benchmark's ``FullMSine_Level<N>``)."""

ISSUE_BLA = {((3,), 2): 0.385, ((1, 3), 2): 0.344, ((1, 3, 5), 2): 0.563, ((5,), 4): 0.228,
             ((3, 5), 4): 0.191, ((1, 3, 5), 4): 0.193, ((1,), 2): 0.495, ((1,), 4): 1.255,
             ((3,), 4): 0.661, ((2,), 2): 0.013, ((4,), 4): 0.178}
"""The BLA errors the study's issue measured (training levels, validation level) → relative
error over periods 2–9; (l,) → l is the level's own BLA."""
ISSUE_INTERPOLATION = {((1, 3), 2): 0.223}
"""The issue's BLA interpolated in force RMS between levels 1 and 3, predicting level 2."""

TORSION = ("acc_wing", 6.5, 8.0)
"""The wing accelerometer next to the nonlinear interface and the band (Hz) of the
wing-torsion mode near 7.3 Hz (the data README)."""


def level_files(folder) -> dict[int, Path]:
    """The level records of ``folder`` by level number (``*level<N>_*.npz``)."""
    out: dict[int, Path] = {}
    for f in sorted(Path(folder).glob("*.npz")):
        m = LEVEL.search(f.name)
        if m is None:
            raise InputError(f"{f.name}: the file name holds no level number "
                             "('level<N>_', as f16_fullmsine_level3_37N.npz)")
        n = int(m.group(1))
        if n in out:
            raise InputError(f"{f.name}: level {n} is also {out[n].name}")
        out[n] = f
    return out


def _read_level(path: Path, plan: F16Plan) -> Record:
    """One level's record, checked: its ``period_samples`` (when the file has it) equal to
    the study's period, at least ``transient_periods + 1`` whole periods, the input the
    study asks for (``voltage`` is read only when asked)."""
    with np.load(path, allow_pickle=False) as z:
        names = set(z.files)
        if "period_samples" in names:
            ps = np.asarray(z["period_samples"])
            if ps.size != 1 or int(ps.reshape(())) != plan.period:
                raise InputError(f"{path.name}: field `period_samples`: {ps.tolist()} differs "
                                 f"from the study's period of {plan.period} samples")
        voltage = z["voltage"] if plan.input == "voltage" and "voltage" in names else None
    rec = read_record(path)
    if plan.input == "voltage":
        if voltage is None:
            raise InputError(f"{path.name}: field `voltage`: missing (the study asks for "
                             "input = \"voltage\")")
        rec = Record(u=voltage, y=rec.y, dt=rec.dt, input_units="V",
                       output_units=rec.output_units, input_channels=("voltage",),
                       output_channels=rec.output_channels, name=rec.name)
    need = (plan.transient_periods + 1) * plan.period
    if rec.n_samples < need:
        raise InputError(f"{path.name}: field `inputs`: {rec.n_samples} samples, fewer than "
                         f"{plan.transient_periods + 1} periods of {plan.period} (the first "
                         f"{plan.transient_periods} is the start-up transient)")
    return rec


def load_levels(plan: F16Plan) -> dict[int, Record]:
    """Every level record of the study's data folder, checked against each other (``dt``,
    channels, units: one line naming the file and the field)."""
    files = level_files(plan.data)
    recs = {n: _read_level(f, plan) for n, f in files.items()}
    ordered = [recs[n] for n in sorted(recs)]
    check_records(ordered, min_samples=(plan.transient_periods + 1) * plan.period)
    return recs


def _steady(x: np.ndarray, plan: F16Plan) -> np.ndarray:
    """The steady-state periods of ``x`` (c × n) side by side (c × P·N)."""
    s = steady_periods(x, plan.period, plan.transient_periods, "prediction")
    return s.transpose(1, 0, 2).reshape(x.shape[0], -1)


def errors(yh: np.ndarray, rec: Record, plan: F16Plan) -> dict:
    """Relative errors and e_RMS (m/s², per output and over the three) of a whole-record
    prediction, over the steady-state periods (``_ss``) and the whole record."""
    y = np.asarray(rec.y, dtype=float)
    out: dict = {}
    for tag, a, b in (("ss", _steady(yh, plan), _steady(y, plan)), ("whole", yh, y)):
        d = a - b
        out[f"rel_{tag}"] = float(np.linalg.norm(d) / np.linalg.norm(b))
        out[f"erms_{tag}"] = float(np.sqrt(np.mean(d ** 2)))
        for name, row in zip(rec.output_channels or (), d, strict=True):
            out[f"erms_{tag}_{name}"] = float(np.sqrt(np.mean(row ** 2)))
    return out


def periodic_error(yp: np.ndarray, rec: Record, plan: F16Plan) -> float:
    """Relative error of one predicted steady-state period against every measured one."""
    y = steady_periods(rec.y, plan.period, plan.transient_periods, rec.name)
    return float(np.linalg.norm(y - yp[None]) / np.linalg.norm(y))


def _band(model, rec: Record, yh_err: float, plan: F16Plan) -> dict:
    """The band's coverage of the measured outputs over the whole record and its error
    estimate against the realized whole-record error."""
    p = model.predict(rec, coverage=plan.coverage)
    est = float(p.error_estimate)
    return {"coverage": band_coverage(rec.y, p.lower, p.upper), "error_estimate": est,
            "estimate_ratio": est / yh_err if yh_err > 0 else float("nan")}


NO_BAND = ("no band: one training level leaves no level out; its periods would show the "
           "noise and the transient, not the change of the linearization with the level")
"""The note of a banded method's prediction from a single training level. The band is
calibrated by leaving training levels out; the periods of one level are folds of one
steady state, whose spread is the noise alone (a periodic input's nonlinear distortion
repeats in every period), so a band from them would be far narrower than the error of a
change of level, which dominates (docs/studies/f16_gvt.md gives both)."""


def _run_entry(entry: MethodEntry, train, targets, plan: F16Plan, keep) -> tuple:
    """Fit one method on a training set and predict its targets: (rows, fit row, kept
    predictions). A refusal (InputError) is a row with the message."""
    base = {"train": _levels_text(train), "method": entry.label}
    recs = [r for _, r in train]
    t0 = time.perf_counter()
    try:
        model = build_estimator(entry, period=plan.period,
                                transient_periods=plan.transient_periods,
                                n_train=len(recs), dt=recs[0].dt).fit(recs)
        preds = [(n, r, role, np.asarray(model.predict(r), dtype=float))
                 for n, r, role in targets]
    except InputError as exc:
        note = str(exc).splitlines()[0]
        rows = [{**base, "target": n, "role": role, "status": "refused", "note": note}
                for n, _, role in targets]
        return rows, {**base, "status": "refused", "note": note}, {}
    seconds = time.perf_counter() - t0
    rows, kept = [], {}
    for n, rec, role, yh in preds:
        row = {**base, "target": n, "role": role, "status": "ok", **errors(yh, rec, plan)}
        if _periodic(model):
            row["rel_periodic"] = periodic_error(model.predict_periodic(rec), rec, plan)
        if entry.bands and len(recs) >= 2:
            row.update(_band(model, rec, row["rel_whole"], plan))
        elif entry.bands:
            row["note"] = NO_BAND
        rows.append(row)
        if keep(entry.label, n):
            kept[n] = yh
    fit = {**base, "status": "ok", "seconds": seconds, "n_modes": int(model.n_modes_),
           **_torsion_peak(model, recs[0], plan),
           **{k: v for k, v in getattr(model, "info_", {}).items()
              if isinstance(v, (int, float, str)) and k != "cv_error"}}
    return rows, fit, kept


def _periodic(model) -> bool:
    """Whether a fitted model identified the kernel over one period (it then has the
    frequency response on the lines and the steady-state period's prediction)."""
    return getattr(model, "inputs_", None) == "periodic"


def _torsion_peak(model, rec: Record, plan: F16Plan) -> dict:
    """The torsion peak of a fitted model's frequency response at the wing accelerometer
    ((m/s²)/N on the period's lines in the torsion band, :data:`TORSION`): for the periodic
    methods their response on the excited lines, for a truncated kernel (``theta_``) its
    DTFT; ``{}`` for the others."""
    channel, lo, hi = TORSION
    names = rec.output_channels or ()
    if channel not in names:
        return {}
    f = np.arange(plan.period // 2 + 1) / (plan.period * rec.dt)
    band = np.flatnonzero((f >= lo) & (f <= hi))
    if _periodic(model):
        lines = list(model.lines_)
        keep = [i for i, k in enumerate(lines) if lo <= f[k] <= hi]
        G = model.frequency_response()[names.index(channel), 0, keep]
    elif hasattr(model, "theta_") and hasattr(model, "first_lag_"):
        n_in = rec.n_inputs
        th = model.theta_.reshape(-1, n_in, model.theta_.shape[1])[:, 0, :]  # (L, k)
        lags = model.first_lag_ + np.arange(th.shape[0])
        E = np.exp(-2j * np.pi * np.outer(f[band], lags) * rec.dt)  # (F, L)
        G = (E @ th) @ model.modes_[names.index(channel)]
    else:
        return {}
    return {"torsion_peak": float(np.max(np.abs(G)))} if np.size(G) else {}


def _levels_text(train) -> str:
    return "+".join(str(n) for n, _ in train)


def _common_lines(levels, plan: F16Plan) -> tuple[int, ...]:
    """The lines every level excites (the rule of the periodic methods on all records)."""
    recs = [levels[n] for n in sorted(levels)]
    lines = BestLinearApproximation(period=plan.period,
                                    transient_periods=plan.transient_periods).fit(recs).lines_
    return tuple(int(k) for k in lines)


def _own_model(rec: Record, lines: tuple[int, ...], plan: F16Plan) -> BestLinearApproximation:
    """A level's own BLA (the linear model of its record alone) on the given lines."""
    return BestLinearApproximation(period=plan.period, transient_periods=plan.transient_periods,
                                   lines=lines).fit([rec])


def _own_models(levels, plan: F16Plan) -> dict[int, BestLinearApproximation]:
    """Each level's own BLA, on one set of lines: those every level excites
    (:func:`_common_lines`)."""
    lines = _common_lines(levels, plan)
    return {n: _own_model(levels[n], lines, plan) for n in sorted(levels)}


def _decomposition(train, n: int, rec: Record, own, plan: F16Plan) -> dict:
    """Per validation level: the training levels' pooled BLA (total), the level's own BLA
    (floor), the linearization error ‖(G_train − G_own)·Ū‖ over the steady-state periods
    relative to the measured outputs, and the projection error of the training outputs'
    POD basis with k = 1, 2 modes (k = n_out: zero)."""
    recs = [r for _, r in train]
    lines = own[n].lines_
    model = BestLinearApproximation(period=plan.period,
                                    transient_periods=plan.transient_periods,
                                    lines=tuple(int(k) for k in lines)).fit(recs)
    spec = period_spectra(rec.u, None, plan.period, plan.transient_periods, rec.name)
    diff = periodic_prediction(model.frequency_response() - own[n].frequency_response(),
                               lines, spec.U_mean, plan.period)
    y = steady_periods(rec.y, plan.period, plan.transient_periods, rec.name)
    norm = float(np.linalg.norm(y))
    P = y.shape[0]
    out = {"train": _levels_text(train), "target": n,
           "total": periodic_error(model.predict_periodic(rec), rec, plan),
           "own_floor": periodic_error(own[n].predict_periodic(rec), rec, plan),
           "linearization": float(np.sqrt(P) * np.linalg.norm(diff) / norm)}
    out.update(_oracle(train, rec, own, plan))
    Ub, _, _ = np.linalg.svd(np.hstack([r.y for r in recs]), full_matrices=False)
    ys = _steady(rec.y, plan)
    for k in range(1, Ub.shape[1]):
        Uk = Ub[:, :k]
        out[f"projection_k{k}"] = float(np.linalg.norm(ys - Uk @ (Uk.T @ ys))
                                        / np.linalg.norm(ys))
    return out


def _oracle(train, rec: Record, own, plan: F16Plan) -> dict:
    """For a validation level strictly between two training levels (in force RMS): the
    weight force-RMS interpolation gives the upper neighbour's model, and the best weight
    and error of any mixture of the two neighbours' own models, the weight chosen on the
    validation record itself (an oracle: the bound of interpolating between the two)."""
    levels = sorted((input_rms(r.u, plan.period, plan.transient_periods), n) for n, r in train)
    x = input_rms(rec.u, plan.period, plan.transient_periods)
    below = [lv for lv in levels if lv[0] < x]
    above = [lv for lv in levels if lv[0] > x]
    if not below or not above:
        return {}
    (ra, a), (rb, b) = below[-1], above[0]
    y = steady_periods(rec.y, plan.period, plan.transient_periods, rec.name)
    ya, yb = own[a].predict_periodic(rec), own[b].predict_periodic(rec)
    d = yb - ya
    w = float(np.sum((y - ya[None]) * d[None]) / (y.shape[0] * np.sum(d * d)))
    best = ya + w * d
    return {"force_weight": (x - ra) / (rb - ra), "oracle_weight": w,
            "oracle_interpolation": float(np.linalg.norm(y - best[None]) / np.linalg.norm(y))}


def _half_power(f: np.ndarray, a: np.ndarray, j: int) -> float:
    """Half-power damping ratio of the peak at line ``j`` of the magnitude ``a`` (the
    −3 dB crossings interpolated linearly between lines): ``(f₂ − f₁)/(2 f_peak)``; NaN
    when a crossing is outside the lines."""
    half = a[j] / np.sqrt(2.0)
    lo = j
    while lo > 0 and a[lo] >= half:
        lo -= 1
    hi = j
    while hi < a.size - 1 and a[hi] >= half:
        hi += 1
    if a[lo] >= half or a[hi] >= half:
        return float("nan")
    f1 = f[lo] + (half - a[lo]) / (a[lo + 1] - a[lo]) * (f[lo + 1] - f[lo])
    f2 = f[hi - 1] + (a[hi - 1] - half) / (a[hi - 1] - a[hi]) * (f[hi] - f[hi - 1])
    return float((f2 - f1) / (2.0 * f[j]))


def _level_row(n: int, rec: Record, own, plan: F16Plan) -> dict:
    """What one level's record shows: force RMS, output RMS, the distortion on the
    non-excited lines (and the noise share there), the own BLA's floor and noise, the
    torsion peak of the wing accelerometer's BLA."""
    model = own[n]
    spec = period_spectra(rec.u, rec.y, plan.period, plan.transient_periods, rec.name)
    dist, noise = distortion_fractions(spec, model.lines_)
    ys = _steady(rec.y, plan)
    G = model.frequency_response()
    row = {"level": n, "file": rec.name, "input_rms": input_rms(rec.u, plan.period,
                                                              plan.transient_periods),
           "own_floor": periodic_error(model.predict_periodic(rec), rec, plan),
           "n_lines": int(model.lines_.size)}
    names = rec.output_channels or ()
    for c, name in enumerate(names):
        row[f"rms_{name}"] = float(np.sqrt(np.mean(ys[c] ** 2)))
        row[f"distortion_{name}"] = float(dist[c])
        row[f"noise_{name}"] = float(noise[c])
    sd = np.sqrt(np.nan_to_num(model.noise_variance_))
    row["bla_noise"] = float(np.linalg.norm(sd * np.abs(spec.U_mean[0, model.lines_]))
                             / np.linalg.norm(np.abs(spec.Y_mean[:, model.lines_])))
    channel, lo, hi = TORSION
    if channel in names:
        a = np.abs(G[names.index(channel), 0])
        f = model.frequencies_
        band = np.flatnonzero((f >= lo) & (f <= hi))
        j = int(band[np.argmax(a[band])])
        row.update(torsion_peak=float(a[j]), torsion_Hz=float(f[j]),
                   torsion_half_power_damping=_half_power(f, a, j))
    return row


def _available(levels, wanted) -> tuple[list, list]:
    have = [(n, levels[n]) for n in wanted if n in levels]
    return have, [n for n in wanted if n not in levels]


def _check_extras(plan: F16Plan) -> None:
    """Refuse to run when a method needs a package that is not installed: the committed
    tables hold its rows, which a run without it would overwrite with refusals."""
    for i, entry in enumerate(plan.methods):
        extra = missing_extra(entry)
        if extra is not None:
            raise InputError(f"{plan.path.name}: field `f16_gvt.methods[{i}]` "
                             f"({entry.label}): needs the {extra} package (pip install "
                             f"'podbench[{INSTALL_EXTRA.get(extra, 'peers')}]'); the "
                             "study's tables include it; remove the entry to run without")


INSTALL_EXTRA = {"mdof": "mdof"}
"""The podbench extra that installs a package (default: ``peers``)."""


MODES_POLES = RESPONSE_POLES
"""Poles of the rational fit of a level's own BLA over the excited band (2–15 Hz): twelve
modes; the poles that are physical (:func:`podbench.sysid.modal.physical_mask`) and stable
against the fits with 26 and 28 poles (:func:`podbench.sysid.modal.stability_mask`, its
criteria :data:`~podbench.sysid.modal.STABILITY`) are the level's modes."""


def _band_fit(cache: dict, G, f, n_poles: int, channels) -> tuple[ModeSet, float]:
    """The rational fit of ``G`` over the whole band with ``n_poles`` poles, computed once
    per level (``cache``: pole count → fit, shared by :func:`level_modes` and
    :func:`pole_sweep`)."""
    return response_fit(G, f, n_poles, channels, cache, BAND_SOURCE)


BAND_SOURCE = "rational fit of the BLA"


def level_modes(model, rec: Record, plan: F16Plan, fits: dict | None = None) -> list[dict]:
    """Modes of one level's own BLA (``model``, fitted on ``rec``) against force level: the
    stable physical modes of a rational fit over the excited band (:data:`MODES_POLES`), and
    the torsion mode of a one-mode fit (two poles, a real numerator of degree two for the
    modes outside) on the torsion band (:data:`TORSION`). Frequencies in Hz, damping
    ratios, misfits ``‖N/D − G‖/‖G‖``; the input RMS in the input unit (N). ``fits``: the
    level's band fits already made (pole count → fit), added to."""
    fits = {} if fits is None else fits
    G = model.frequency_response()[:, 0]
    f = model.frequencies_
    channels = rec.output_channels or tuple(str(i) for i in range(G.shape[0]))
    rms = input_rms(rec.u, plan.period, plan.transient_periods)
    base = {"input_rms": rms}
    modes, misfit, _ = response_modes(G, f, rec.dt, channels, MODES_POLES, fits, BAND_SOURCE)
    rows = [{**base, "fit": f"2-15 Hz, {MODES_POLES} poles", "frequency_Hz": float(fr),
             "damping_ratio": float(z), "misfit": misfit}
            for fr, z in zip(modes.frequency_hz, modes.damping_ratio, strict=True)]
    _, lo, hi = TORSION
    band = (f >= lo) & (f <= hi)
    torsion, tmis = response_fit(G[:, band], f[band], 2, channels, source=BAND_SOURCE)
    rows += [{**base, "fit": f"torsion {lo:g}-{hi:g} Hz, 2 poles", "frequency_Hz": float(fr),
              "damping_ratio": float(z), "misfit": tmis}
             for fr, z in zip(torsion.frequency_hz, torsion.damping_ratio, strict=True)]
    return rows


POLE_RANGE = tuple(range(16, 33, 2))
"""Pole counts of the band fit over which the torsion mode is reported (:func:`pole_sweep`):
the 24 poles of :data:`MODES_POLES` are one choice among them, so the verdict is given over
the range (8 to 16 modes in 2-15 Hz)."""


def _torsion_pole(modes: ModeSet, wing: int, dt: float, f: np.ndarray) -> int | None:
    """The wing-torsion pole of a band fit: among its physical poles in the torsion band
    (:data:`TORSION`), the one whose term ``r/(jω − s)`` carries the most of the fitted
    wing response over the band's lines ``f`` (Hz), ``Σ |r_wing/(jω − s)|²``: neither a
    near-undamped computational pole (a high, narrow peak between the lines) nor a broad
    overdamped one (a residual term); None if the band holds none."""
    _, lo, hi = TORSION
    fr = modes.frequency_hz
    ok = physical_mask(modes, dt) & (fr >= lo) & (fr <= hi)
    if not np.any(ok):
        return None
    jw = 2j * np.pi * f[(f >= lo) & (f <= hi)]
    terms = modes.shapes[wing][:, None] / (jw[None, :] - modes.poles[:, None])
    energy = np.sum(np.abs(terms) ** 2, axis=1)
    return int(np.flatnonzero(ok)[np.argmax(energy[ok])])


def pole_sweep(model, rec: Record, plan: F16Plan, fits: dict | None = None) -> list[dict]:
    """The torsion mode of one level's own BLA from the band fit (2-15 Hz) at every pole
    count of :data:`POLE_RANGE`: frequency (Hz), damping ratio, the fit's misfit and whether
    the mode is stable against the fits with two and four more poles
    (:func:`podbench.sysid.modal.stability_mask`). An empty frequency: no physical pole in
    the torsion band at that count. ``fits``: as for :func:`level_modes`."""
    fits = {} if fits is None else fits
    G = model.frequency_response()[:, 0]
    f = model.frequencies_
    channels = rec.output_channels or tuple(str(i) for i in range(G.shape[0]))
    wing = channels.index(TORSION[0]) if TORSION[0] in channels else 0
    counts = sorted(set(POLE_RANGE) | {n + s for n in POLE_RANGE for s in STABILITY_ORDERS})
    for n in counts:
        _band_fit(fits, G, f, n, channels)
    rms = input_rms(rec.u, plan.period, plan.transient_periods)
    rows = []
    for n in POLE_RANGE:
        modes, misfit = fits[n]
        j = _torsion_pole(modes, wing, rec.dt, f)
        row = {"input_rms": rms, "n_poles": n, "misfit": misfit, "frequency_Hz": None,
               "damping_ratio": None, "stable": None}
        if j is not None:
            one = modes.subset(np.arange(len(modes)) == j)
            stable = stability_mask(one, [fits[n + s][0] for s in STABILITY_ORDERS])
            row.update(frequency_Hz=float(one.frequency_hz[0]),
                       damping_ratio=float(one.damping_ratio[0]), stable=bool(stable[0]))
        rows.append(row)
    return rows


COSTS = {"ERA-measured": 1.5, "mdof-SRIM": 3.0, "ML-TC": 1.3, "FIR-LS": 0.4}
"""Expected CPU seconds of a method per training record, bands and predictions included
(the periodic methods: 0.3), so that the executor starts the long tasks first. Only the
schedule depends on it."""
MODES_COST = 3.3
"""Expected CPU seconds of one level's modes and pole sweep (:func:`_modes_task`)."""


def _method_task(task) -> tuple:
    """One method on one training set (a task of :func:`run_study`, module level for the
    executor's worker processes)."""
    plan, entry, train, targets, keep = task
    return _run_entry(entry, train, targets, plan, lambda label, n: n in keep)


def _modes_task(task) -> tuple[list[dict], list[dict]]:
    """The modes (:func:`level_modes`) and the pole sweep (:func:`pole_sweep`) of one
    level's own BLA on the common lines, sharing the level's rational fits: a task of
    :func:`run_study`, so that the fits run beside the methods' tasks."""
    plan, n, rec, lines = task
    model = _own_model(rec, lines, plan)
    fits: dict = {}
    modes = [{**m, "level": n} for m in level_modes(model, rec, plan, fits)]
    poles = [{**m, "level": n} for m in pole_sweep(model, rec, plan, fits)]
    return modes, poles


def _task(task):
    """A task of :func:`run_study`: ``("method", …)`` or ``("modes", …)``."""
    kind, payload = task
    return _method_task(payload) if kind == "method" else _modes_task(payload)


def _tasks(plan: F16Plan, levels) -> tuple[list, list, list]:
    """``(tasks, costs, skipped)``: one task per training set and method (the sets that
    train on the same levels share the fit), its targets those of every such set that runs
    the method and whose level file is present, each with the set's role."""
    fig_label, fig_train, fig_target = plan.figure
    skipped = []
    groups: dict = {}
    for s in plan.sets:
        train, absent = _available(levels, s.train)
        targets, gone = _available(levels, s.targets)
        if absent or gone:
            skipped.append({"train": "+".join(map(str, s.train)),
                            "targets": " ".join(map(str, s.targets)),
                            "missing": " ".join(map(str, absent + gone))})
        if absent:
            continue
        for entry in plan.methods:
            if s.methods is not None and entry.label not in s.methods:
                continue
            task = groups.setdefault((s.train, entry.label), [entry, train, []])
            task[2] += [(n, r, s.role) for n, r in targets]
    tasks, costs = [], []
    for (train_levels, label), (entry, train, targets) in groups.items():
        if not targets:
            continue
        keep = (fig_target,) if (label, train_levels) == (fig_label, fig_train) else ()
        tasks.append((plan, entry, train, targets, keep))
        costs.append(COSTS.get(entry.method, 0.3) * len(train))
    return tasks, costs, skipped


def run_study(plan: F16Plan, progress=None, jobs=1) -> dict:
    """Run every set and method of the plan on its data folder (one task per set and
    method, and one per level for its modes and pole sweep, on ``jobs`` processes:
    :func:`podbench.harness.executor.execute`, results in task order whatever ``jobs``).
    Returns ``rows`` (per set, target and method),
    ``fits``, ``skipped`` (sets or targets whose level file is absent),
    ``decomposition``, ``levels`` (per level), ``bla`` (the issue's BLA table
    recomputed), ``figure`` (the figure's predictions), ``records``, ``own`` (each
    level's own BLA) and ``plan``, which :func:`podbench.report.f16_gvt.write_study`
    writes."""
    _check_extras(plan)
    levels = load_levels(plan)
    tasks, costs, skipped = _tasks(plan, levels)
    with single_blas_thread():
        lines = _common_lines(levels, plan)
    mode_tasks = [("modes", (plan, n, levels[n], lines)) for n in sorted(levels)]

    def say(done, total, elapsed, out):
        if progress:
            what = (f"levels {out[1]['train']}: {out[1]['method']}" if len(out) == 3 else
                    f"level {out[1][0]['level']}: modes and pole sweep")
            progress(f"{done}/{total} {what} ({elapsed:.0f} s)")

    results = execute(_task, [("method", t) for t in tasks] + mode_tasks, jobs=jobs,
                      progress=say, costs=costs + [MODES_COST] * len(mode_tasks))
    rows, fits, figure, modes, poles = [], [], {}, [], []
    for r, f, kept in results[:len(tasks)]:
        rows += r
        fits.append(f)
        figure.update(kept)
    for m, p in results[len(tasks):]:
        modes += m
        poles += p
    with single_blas_thread():
        own = {n: _own_model(levels[n], lines, plan) for n in sorted(levels)}
        pairs = {(s.train, n): s.role for s in plan.sets for n in s.targets
                 if n in levels and all(t in levels for t in s.train)}
        decomposition = [{**_decomposition([(t, levels[t]) for t in train], n, levels[n],
                                           own, plan), "role": role}
                         for (train, n), role in pairs.items()]
        level_rows = [_level_row(n, levels[n], own, plan) for n in sorted(levels)]
        bla = _bla_table(levels, own, plan)
    return {"rows": rows, "fits": fits, "skipped": skipped, "decomposition": decomposition,
            "levels": level_rows, "bla": bla, "figure": figure, "records": levels,
            "own": own, "plan": plan, "modes": modes, "poles": poles}


def _bla_table(levels, own, plan: F16Plan) -> list[dict]:
    """The issue's BLA table recomputed: pooled BLA (periodic prediction) per (training
    levels, validation level) it lists, the own-level floors and the interpolation."""
    out = []
    table = {**ISSUE_BLA, **{k: v for k, v in ISSUE_INTERPOLATION.items()}}
    for (train, n), issue in table.items():
        if n not in levels or any(t not in levels for t in train):
            continue
        interp = (train, n) in ISSUE_INTERPOLATION
        kind = "interpolation" if interp else "own" if train == (n,) else "pooled"
        if kind == "own":
            err = periodic_error(own[n].predict_periodic(levels[n]), levels[n], plan)
        else:
            name = "ML-interp" if interp else "BLA"
            est = build_estimator(MethodEntry(name, name),
                                  period=plan.period,
                                  transient_periods=plan.transient_periods,
                                  n_train=len(train), dt=levels[n].dt)
            model = est.fit([levels[t] for t in train])
            err = periodic_error(model.predict_periodic(levels[n]), levels[n], plan)
        out.append({"train": "+".join(map(str, train)), "target": n, "kind": kind,
                    "bla": err, "issue": issue})
    return out
