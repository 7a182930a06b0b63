"""Run scenarios: simulate truth (cached), fit every method, predict every target, decompose
the errors.

The unit of work is one (scenario, structure) pair; units are independent, so ``jobs > 1``
runs them in separate processes (spawned, one BLAS thread each) and the result does not
depend on ``jobs``: rows are sorted by scenario file, structure (scenario order), method
(scenario order) and target (scenario order).

``run_unit`` also runs one point of a sweep (:mod:`podbench.harness.sweep`): ``overrides``
derives the point's scenario (:func:`podbench.scenarios.apply_overrides`) and ``noise``
(:class:`podbench.noise.NoiseSpec`) adds measurement noise to the training data only
(:func:`podbench.noise.noisy`; both re-exported here).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from podbench.core.recordfiles import read_record
from podbench.core.resources import display_path as _display
from podbench.core.response import Response, displacement_norm, norm_percent_error
from podbench.dynamics import simulate
from podbench.dynamics.excitations import excitation_from_dict
from podbench.errors import PodbenchError, RecordTooShortError, ScenarioFileError
from podbench.harness.bands import BAND_COLUMNS, band_prediction, band_row, band_stats
from podbench.harness.cache import TruthCache, structure_fingerprint
from podbench.harness.digits import diagnostic_digits, estimator_writer
from podbench.harness.executor import execute
from podbench.harness.metrics import ERROR_COLUMNS, NORM_COLUMNS, decompose, norm_summaries
from podbench.harness.modal import modal_rows, pom_rows
from podbench.harness.progress import as_stage
from podbench.harness.series import prediction_series, truth_series
from podbench.structures.files import structure_length_unit
from podbench.study.estimators import (
    all_cases,
    build_estimator,
    is_user_method,
    method_entry,
    training_records,
)
from podbench.study.resolve import MEASURED, MeasuredStructure, resolve_structure
from podbench.study.scenarios import Scenario, apply_overrides, load_scenario, method_solver
from podbench.sysid.conditioning import Conditioning, WindowCorrected, condition
from podbench.sysid.methods import MDS, POVR, MixedResponse, MultipleLoad, SingleLoad
from podbench.sysid.noise import NoiseSpec, noise_generator, noisy

__all__ = ["run_study", "run_unit", "UnitResult", "SideTasks", "COLUMNS", "response_counts",
           "NoiseSpec", "noisy", "check_cases", "noise_generator"]

COLUMNS = ("scenario", "structure", "method", "target", "n_modes", *ERROR_COLUMNS,
           *NORM_COLUMNS, *BAND_COLUMNS, "status")
SWEEP_DIAGNOSTICS = ("solver_reg", "solver_iterations", "solver_amplification")
"""Fit diagnostics (:attr:`podbench.methods.PODMethod.diagnostics_`) a sweep row carries:
the Tikhonov parameter the solver chose, its iterations and the deconvolution's
amplification ‖A‖‖X‖/‖B‖ (NaN for a method or solver without them)."""
"""Columns of ``summary.csv`` in order."""


@dataclass
class UnitResult:
    """What one (scenario, structure) unit produced."""

    scenario: str
    structure: str
    rows: list = field(default_factory=list)
    fits: list = field(default_factory=list)  # one dict per reported method: its diagnostics_
    series: dict = field(default_factory=dict)  # target -> {"t", "truth", label: norm}
    events: list = field(default_factory=list)  # (time in s, description) of Structure.events
    band_stats: list = field(default_factory=list)  # per row: interval scores, seconds
    simulated: int = 0
    cached: int = 0
    seconds: float = 0.0
    timing: list = field(default_factory=list)  # per method: fit and total wall seconds
    simulated_keys: list = field(default_factory=list)  # cache keys of the responses simulated
    cached_keys: list = field(default_factory=list)  # and of those read from the cache
    modal: list = field(default_factory=list)  # modal.csv rows (podbench.harness.modal)
    pom_modes: list = field(default_factory=list)  # pom_modes.csv rows


def _references(case) -> dict[str, str]:
    """Names of the reference structures of a case's excitations, each with the field that
    names it first (``cases.<case>.<key>.reference``)."""
    refs: dict[str, str] = {}
    for key, d in case.excitation_fields():
        if isinstance(d, dict) and isinstance(d.get("reference"), str):
            refs.setdefault(d["reference"], f"cases.{case.name}.{key}.reference")
    return refs


def _case_error(scenario: Scenario, case: str, key: str, exc: Exception,
                structure: str = "") -> ScenarioFileError:
    """The one-line error for the excitation ``key`` of ``case``; an ``exc.field`` (set by
    :mod:`podbench.excitations`) is appended to the dotted field."""
    inner = getattr(exc, "field", None)
    path = f"cases.{case}.{key}" + (f".{inner}" if inner else "")
    on = f" on {structure}" if structure else ""
    msg = " ".join(str(exc).split())
    return ScenarioFileError(f"{_display(scenario.path)}: field `{path}`{on}: {msg}")


def _build_case(scenario: Scenario, case: str, refs: dict) -> list[tuple[str, Any]]:
    """``(key, excitation)`` of every excitation of ``case`` (``refs``: name → Structure)."""
    out = []
    for key, d in scenario.cases[case].excitation_fields():
        try:
            out.append((key, excitation_from_dict(d, structures=refs)))
        except PodbenchError as exc:
            raise _case_error(scenario, case, key, exc) from None
    return out


def _check_built(scenario: Scenario, case: str, built, structure) -> None:
    """Check the built excitations of ``case`` against ``structure`` (no solve, no run)."""
    for key, exc in built:
        try:
            if key.startswith("force"):
                exc.check(structure, scenario.n_samples, scenario.dt)
            else:
                exc.check(structure)
        except PodbenchError as err:
            raise _case_error(scenario, case, key, err, structure.name) from None


def check_cases(scenario: Scenario, structure, loaded: dict | None = None) -> None:
    """Check every case's excitations against ``structure`` before anything is simulated:
    kinds and entries, reference structures (``cases.<case>.<key>.reference``), load
    locations (on the structure or its reference), pulse windows inside the record,
    force-history shapes.

    ``loaded`` caches reference structures by name across calls (one scenario).

    Raises
    ------
    ScenarioFileError
        One line naming the scenario file, the dotted field and the structure.
    """
    loaded = {} if loaded is None else loaded
    for cname, case in scenario.cases.items():
        if case.file is not None or isinstance(structure, MeasuredStructure):
            read_case(scenario, cname, structure)
            continue
        refs = {}
        for name, fld in sorted(_references(case).items()):
            if name == structure.name:
                refs[name] = structure
                continue
            if name not in loaded:
                loaded[name] = resolve_structure(name, scenario, field=fld)
            refs[name] = loaded[name]
        _check_built(scenario, cname, _build_case(scenario, cname, refs), structure)


_POM_METHODS = (POVR, MDS, SingleLoad, MultipleLoad, MixedResponse)
"""The dissertation's methods (Ch. 3), whose ``n_modes`` is the number of POMs."""


def check_modes(scenario: Scenario, structure, *, source: str | None = None) -> None:
    """Check every POD method's ``n_modes`` against what its training data can hold, before
    anything is simulated: the POMs are orthonormal vectors over the sensors and span the
    columns of the training records (Eqs. 3.4-3.6), so their number is at most the sensor
    count and at most ``n_samples`` times the training records; MDS and ML identify a k × k
    matrix from their training cases (Eqs. 3.26, 3.48), so k is at most their number.

    ``source`` names where ``n_modes`` came from when it is not the method's own field (a
    sweep's axis value, e.g. ``"sweep axis `n_modes` = 40"``).

    Raises
    ------
    ScenarioFileError
        One line naming the scenario file, the field ``methods[i].n_modes`` (or ``source``)
        and the structure.
    """
    for i, spec in enumerate(scenario.methods):
        if spec.n_modes is None or spec.composite or is_user_method(spec.method):
            continue
        cls = method_entry(spec.method, scenario.folder).cls
        if cls not in _POM_METHODS:
            continue  # another meaning of n_modes (ERA: the order 2 n_modes)
        k = len(spec.train)
        limits = [(scenario.n_samples * k, f"{k} training record{'s' if k > 1 else ''} of "
                   f"scenario.n_samples = {scenario.n_samples}")]
        if structure.n_sensors is not None:
            limits.append((structure.n_sensors, f"{structure.n_sensors} sensors"))
        if getattr(cls, "records_per_mode", False):
            limits.append((k, f"{k} training case{'s' if k > 1 else ''}: it identifies a "
                           "k × k matrix from them, Eqs. 3.26, 3.48"))
        bound, why = min(limits)
        if spec.n_modes > bound:
            where = source or f"field `methods[{i}].n_modes`"
            raise ScenarioFileError(
                f"{_display(scenario.path)}: {where} on {structure.name}: "
                f"{spec.n_modes} modes, but {spec.method}'s POMs number at most {bound} ({why})")


def read_case(scenario: Scenario, case_name: str, structure) -> Response:
    """The measured record of case ``case_name`` (``[cases.x] file``), checked against the
    scenario's ``n_samples`` and ``dt`` and the structure's sensors.

    Raises
    ------
    ScenarioFileError
        One line naming the scenario, the field ``cases.<case>.file``, the record file and the
        variable at fault.
    """
    case = scenario.cases[case_name]
    head = f"{_display(scenario.path)}: field `cases.{case_name}.file`"
    if case.file is None:
        raise ScenarioFileError(f"{head}: structure \"{MEASURED}\" simulates nothing; give "
                                "the case a measured record (`file`)")
    path = Path(case.file)
    path = path if path.is_absolute() else scenario.folder / path
    shown = case.file

    def fail(var, message):
        raise ScenarioFileError(f"{head}: {shown}: variable `{var}`: {message}")

    try:
        rec = read_record(path)
    except PodbenchError as exc:
        msg = " ".join(str(exc).split()).replace(str(path), shown)
        raise ScenarioFileError(f"{head}: {msg}") from None
    m, n = rec.W.shape
    if n != scenario.n_samples:
        fail("W", f"{n} samples (columns), the scenario's n_samples is {scenario.n_samples}")
    if abs(rec.dt - scenario.dt) > 1e-9 * scenario.dt:
        fail("dt", f"{rec.dt!r} s differs from the scenario's dt = {scenario.dt!r} s")
    if structure.n_sensors is not None and m != structure.n_sensors:
        fail("W", f"{m} sensors (rows), structure {structure.name!r} has {structure.n_sensors}")
    pos = structure.sensor_positions
    if pos is not None and rec.sensor_positions is not None and not np.allclose(
            rec.sensor_positions, pos, rtol=0, atol=1e-9):
        fail("sensor_positions", f"{list(rec.sensor_positions)} differ from structure "
                                 f"{structure.name!r}'s {list(np.asarray(pos))}")
    w0 = rec.W[:, 0].copy() if rec.w0 is None else rec.w0
    v0 = np.zeros(m) if rec.v0 is None else rec.v0
    F = np.zeros((m, n)) if rec.F is None else rec.F  # a free response: no load
    return Response(t=np.arange(n) * scenario.dt, W=rec.W, F=F, w0=w0, v0=v0,
                    dt=scenario.dt, structure=structure.name, engine="measured",
                    label=case_name)


class _Truth:
    """Truth responses of one structure (and its linear twin), simulated or cached."""

    def __init__(self, scenario: Scenario, structure, cache: TruthCache, engine: str,
                 noise: NoiseSpec | None = None, conditioning: Conditioning | None = None):
        self.scenario, self.structure, self.cache, self.engine = scenario, structure, cache, engine
        self.noise = noise
        self.conditioning = conditioning
        self._refs: dict = {}
        self.fe_modes: dict = {}  # the structure's finite-element modes by dt (modal.csv)
        self._store: dict = {}
        self._noisy: dict = {}
        self.simulated = 0
        self.simulated_keys: list[str] = []
        self.cached_keys: list[str] = []

    def train(self, case_name: str, linear: bool = False) -> Response:
        """A training response: the truth, with the sweep's noise if any, then conditioned
        (:mod:`podbench.conditioning`) if the scenario says so — the conditioning sees only
        the measured arrays. Targets stay noise-free and unconditioned: a prediction is
        compared with the clean truth."""
        key = (case_name, linear)
        if key not in self._noisy:
            r = self.get(case_name, linear)
            if self.noise is not None and not self.noise.is_null:
                r = noisy(r, self.noise, self.scenario.name, self.structure.name, case_name)
            if self.conditioning is not None:
                r = condition(r, self.conditioning)
            self._noisy[key] = r
        return self._noisy[key]

    def _reference(self, name: str, field: str):
        if name not in self._refs:
            if name == self.structure.name:
                self._refs[name] = self.structure
            else:
                self._refs[name] = resolve_structure(name, self.scenario, field=field)
        return self._refs[name]

    def get(self, case_name: str, linear: bool = False) -> Response:
        key = (case_name, linear)
        if key in self._store:
            return self._store[key]
        sc, case = self.scenario, self.scenario.cases[case_name]
        if case.file is not None or isinstance(self.structure, MeasuredStructure):
            if linear:
                raise ScenarioFileError(f"{_display(sc.path)}: case `{case_name}` is measured: "
                                        "it has no linear twin")
            self._store[key] = read_case(sc, case_name, self.structure)
            return self._store[key]
        s = self.structure.linear_twin() if linear else self.structure
        refs = {n: self._reference(n, f) for n, f in sorted(_references(case).items())}
        where = f"{_display(sc.path)}: case `{case_name}`"
        built = _build_case(sc, case_name, refs)
        _check_built(sc, case_name, built, s)
        ic_d = next((e for k, e in built if k == "initial_displacement"), None)
        ic_v = next((e for k, e in built if k == "initial_velocity"), None)
        forces = [e for k, e in built if k.startswith("force")]
        ckey = TruthCache.key(
            structure=structure_fingerprint(s),
            refs={n: structure_fingerprint(r) for n, r in refs.items()},
            case=case.spec(), n=sc.n_samples, dt=sc.dt, engine=self.engine,
        )
        shape = (s.n_sensors, sc.n_samples)
        arrays = self.cache.load(ckey, shape)
        if arrays is not None:
            self.cached_keys.append(ckey)
        else:
            force = None
            if forces:
                force = sum(f.sample(s, sc.n_samples, sc.dt) for f in forces)
            try:
                r = simulate(s, n_samples=sc.n_samples, dt=sc.dt, initial_displacement=ic_d,
                             initial_velocity=ic_v, force=force, engine=self.engine,
                             label=case_name)
            except PodbenchError as exc:
                raise ScenarioFileError(f"{where} on {s.name}: {exc}") from None
            self.simulated += 1
            self.simulated_keys.append(ckey)
            arrays = {"W": r.W, "F": r.F, "w0": r.w0, "v0": r.v0, "t": r.t}
            self.cache.store(ckey, arrays)
        r = Response(t=arrays["t"], W=arrays["W"], F=arrays["F"], w0=arrays["w0"],
                     v0=arrays["v0"], dt=sc.dt, structure=s.name, engine=self.engine,
                     label=case_name)
        self._store[key] = r
        return r


def fit_method(spec, scenario: Scenario, train_case, conditioning, basis=None):
    """A fresh estimator of ``spec`` fitted on its training cases (``train_case(name)``: the
    training record of a case, conditioned), in ``basis`` if given; wrapped so that its
    predictions are un-windowed where ``conditioning`` applies an exponential window."""
    est = build_estimator(spec, scenario.method, scenario.folder)
    est = est.fit(training_records(spec, scenario.method, train_case), basis=basis)
    if conditioning is not None and conditioning.exponential_window is not None:
        return WindowCorrected(est, conditioning.exponential_window)  # predictions un-windowed
    return est


def _fit(spec, scenario: Scenario, truth: _Truth, linear: bool, basis=None):
    """:func:`fit_method` on the truth's training cases (of the linear twin of the structure
    if ``linear``)."""
    return fit_method(spec, scenario, lambda c: truth.train(c, linear), truth.conditioning,
                      basis)


_EXPECTED = (PodbenchError, np.linalg.LinAlgError)
_SCENARIO = object()  # run_unit's default conditioning: the scenario's own


_STATUS_LIMIT = 300


def _failure(exc: BaseException) -> str:
    """``failed: Type: message`` on one line, at most 300 characters, shortened at a word
    boundary with an ellipsis (never cut mid-word)."""
    msg = " ".join(str(exc).split())
    text = f"failed: {type(exc).__name__}: {msg}"
    if len(text) > _STATUS_LIMIT:
        text = text[:_STATUS_LIMIT - 1].rsplit(" ", 1)[0].rstrip(",;:") + " …"
    return text


def run_unit(scenario_path, structure_entry: str, cache_dir=None, engine: str | None = None,
             keep_series: bool = True, *, overrides: dict | None = None,
             noise: NoiseSpec | None = None, conditioning=_SCENARIO,
             bands: bool | None = None) -> UnitResult:
    """Run every method of a scenario on one structure.

    Truth for every case the methods and targets need is simulated (or read from the cache in
    ``cache_dir``); each reported method is fitted on its training cases and predicts every
    target; the error components of :mod:`podbench.harness.metrics` are computed with the
    declared coupled twin and, for a nonlinear structure, the linear twin.
    A method that fails (ill-conditioned data, too few data sets, ...) gets a row with NaN
    errors and the reason in ``status``; an error in the scenario itself raises.

    Sweep points: ``overrides`` (keywords of :func:`podbench.scenarios.apply_overrides`:
    ``n_modes``, ``solvers``, ``coupled_train``) derives the point's scenario, and each row
    then also has a ``solver`` entry and the file's label as ``method``; ``noise`` adds
    :class:`NoiseSpec` noise to every training response (twins and linear twins included),
    never to the targets. Without them the behaviour is that of ``podbench run``.

    ``conditioning`` (:class:`podbench.conditioning.Conditioning` or None) replaces the
    scenario's ``[conditioning]`` table; by default the scenario's applies.

    ``bands`` (default: on for a plain run, off for a sweep point) adds every prediction's
    90 % band and error estimate (:mod:`podbench.harness.bands`: columns ``error_estimate``
    and ``coverage``; its calibration refits the method, so it costs a few fits).
    """
    if bands is None:
        bands = overrides is None and noise is None
    t_start = time.perf_counter()
    scenario = load_scenario(scenario_path)
    if overrides is not None:
        scenario = apply_overrides(scenario, **overrides)
    structure = resolve_structure(structure_entry, scenario)
    cache = TruthCache(cache_dir)
    if noise is None and scenario.training_noise > 0:
        noise = NoiseSpec(scenario.training_noise)
    if conditioning is _SCENARIO:
        conditioning = scenario.conditioning
    if conditioning is not None and conditioning.is_identity:
        conditioning = None
    truth = _Truth(scenario, structure, cache, engine or scenario.engine, noise, conditioning)
    res = UnitResult(scenario=scenario.name, structure=structure.name,
                     events=[(float(e.time), e.description) for e in structure.events])
    nonlinear, measured = _simulate_needed(scenario, structure, truth)

    for target in scenario.targets:
        r = truth.get(target)
        res.series[target] = {"t": r.t, "truth": displacement_norm(r.W)}
        if keep_series:  # the figure's sensors and spectrum (podbench.harness.series)
            res.series[target].update(truth_series(
                r.W, r.dt, positions=getattr(structure, "sensor_positions", None),
                labels=getattr(structure, "sensor_labels", ()),
                unit=_displacement_unit(r, structure)))

    for spec in scenario.reported_methods():
        _run_method(res, spec, scenario, truth, sweep=overrides is not None,
                    nonlinear=nonlinear, measured=measured, keep_series=keep_series,
                    bands=bands)
    res.simulated = truth.simulated
    res.cached = cache.hits
    res.simulated_keys, res.cached_keys = truth.simulated_keys, truth.cached_keys
    res.seconds = time.perf_counter() - t_start
    return res


def _displacement_unit(r, structure) -> str:
    """The unit of a target's displacements: a measured record's own, else the structure
    file's system (m for SI, in for inch–lbf)."""
    if getattr(r, "engine", "") == "measured":
        return getattr(r, "output_units", None) or "in"
    return structure_length_unit(structure)


def _simulate_needed(scenario: Scenario, structure, truth: _Truth) -> tuple[bool, bool]:
    """Simulate (or read) every case the methods and targets need, and its linear twin for a
    nonlinear structure; returns ``(nonlinear, measured)``: whether linear twins exist, and
    whether a case is measured (a measured case has no linear twin: no linearization is
    computed, its columns are NaN)."""
    needed = set(scenario.targets)
    for m in scenario.methods:
        needed |= all_cases(m, scenario.method)
    measured = isinstance(structure, MeasuredStructure) or any(
        scenario.cases[c].file is not None for c in needed)
    nonlinear = not structure.is_linear and not measured
    for c in sorted(needed):
        truth.get(c)
        if nonlinear:
            truth.get(c, linear=True)
    return nonlinear, measured


def _too_short(scenario: Scenario, spec, exc: RecordTooShortError) -> str:
    """One line for a training record too short for a method: the scenario file, the
    method, the record files it trains on (or ``scenario.n_samples``) and what it needs."""
    files = [scenario.cases[c].file for c in spec.train
             if c in scenario.cases and scenario.cases[c].file]
    what = (f"its training files ({', '.join(files)})" if files
            else f"scenario.n_samples = {scenario.n_samples}")
    return f"{_display(scenario.path)}: method `{spec.label}`: {what} too short: {exc}"


def _raise_unless_expected(exc: Exception, method: str) -> None:
    """Re-raise ``exc`` unless a method may fail that way (a row then says why): an expected
    error (ill-conditioned data, too few data sets, ...) or anything a user's method raises."""
    if not isinstance(exc, _EXPECTED) and not is_user_method(method):
        raise exc


@dataclass
class _Comparisons:
    """Per target (or None): the predictions the error decomposition compares a method's
    with: its coupled twin's, the linear twin's truth, the coupled twin's on the linear twin
    and the method's own refitted on the linear twin."""

    twin: dict | None = None
    lin: dict | None = None
    twin_lin: dict | None = None
    own_lin: dict | None = None


#: Entries of a row that are not estimates: labels, the sweep's coordinates, wall times.
_NOT_FLOORED = ("scenario", "structure", "method", "target", "solver", "status", "noise",
                "modes", "seed", "band_seconds", "plain_seconds", "source")


def _run_method(res: UnitResult, spec, scenario: Scenario, truth: _Truth, **kw) -> None:
    """Fit one reported method, predict every target and add its rows (and fit) to ``res``;
    its wall time to ``res.timing`` (``fit_seconds``: the fit and the targets' predictions;
    ``seconds``: with its twins, refits and bands)."""
    t0 = time.perf_counter()
    fit_seconds = _fit_and_score(res, spec, scenario, truth, **kw)
    res.timing.append({"scenario": scenario.name, "structure": res.structure,
                       "method": spec.label, "fit_seconds": fit_seconds,
                       "seconds": time.perf_counter() - t0})


def _fit_and_score(res: UnitResult, spec, scenario: Scenario, truth: _Truth, *, sweep: bool,
                   nonlinear: bool, measured: bool, keep_series: bool, bands: bool) -> float:
    """Fit one reported method, predict every target and add its rows (and fit) to ``res``;
    returns the seconds of the fit and predictions (NaN when the fit failed)."""
    base = {"scenario": scenario.name, "structure": res.structure, "method": spec.label}
    if sweep:
        base["method"] = spec.base_label or spec.label
        base["solver"] = method_solver(spec, scenario)
    try:
        t_fit = time.perf_counter()
        est = _fit(spec, scenario, truth, False)
        preds = {t: np.asarray(est.predict(truth.get(t)), dtype=float)
                 for t in scenario.targets}
        t_fit = time.perf_counter() - t_fit
    except RecordTooShortError as exc:  # a scenario mistake, not a method's failure
        raise ScenarioFileError(_too_short(scenario, spec, exc)) from None
    except Exception as exc:  # noqa: BLE001 - a user's method may raise anything
        _raise_unless_expected(exc, spec.method)
        status = _failure(exc)
        for t in scenario.targets:
            res.rows.append({**base, "target": t, "n_modes": -1, "status": status,
                             **({k: float("nan") for k in SWEEP_DIAGNOSTICS} if sweep else {}),
                             **dict.fromkeys(ERROR_COLUMNS + NORM_COLUMNS + BAND_COLUMNS,
                                             float("nan"))})
        return float("nan")
    diag = getattr(est, "diagnostics_", None)
    diag = diag if isinstance(diag, dict) else {}
    # every number at the digits the fit determines, as the estimator declares them
    written = estimator_writer(est, keep=_NOT_FLOORED) or (lambda row: row)
    res.fits.append(written({**base, **diag}))
    if not sweep and not measured:  # the modes against the finite-element model's
        _add_modal(res, est, spec, scenario, truth, base)
    if sweep:  # a sweep point: what the solver chose, on every row
        base = {**base, **{k: diagnostic_digits(k, diag.get(k, float("nan")))
                           for k in SWEEP_DIAGNOSTICS}}
    U = getattr(est, "modes_", None)
    U = None if U is None else np.asarray(U, dtype=float)
    coupled = bool(getattr(est, "coupled", False))
    ref, status = _twin_predictions(spec, est, U, coupled, scenario, truth, nonlinear)
    if nonlinear and U is not None:  # the method itself, refitted on the linear twin
        status = _own_linear_refit(spec, U, scenario, truth, ref, status)
    for t in scenario.targets:
        W = truth.get(t).W
        Wh = preds[t]
        row = {**base, "target": t, "n_modes": -1 if U is None else int(U.shape[1])}
        row.update(decompose(
            W, Wh, U, W_twin=None if ref.twin is None else ref.twin[t], coupled=coupled,
            W_lin=None if ref.lin is None else ref.lin[t],
            W_twin_lin=None if ref.twin_lin is None else ref.twin_lin[t],
            nonlinear=nonlinear or measured,
            W_own_lin=None if ref.own_lin is None else ref.own_lin[t],
        ))
        row.update(norm_summaries(W, Wh))
        if bands:
            _add_band(res, row, est, truth.get(t), t_fit / len(scenario.targets),
                      keep_series=keep_series, label=spec.label, written=written)
        row["status"] = status
        res.rows.append(written(row))
        if keep_series:
            res.series[t][spec.label] = displacement_norm(Wh)
            res.series[t][spec.label + "__pe"] = norm_percent_error(W, Wh)
            res.series[t].update(prediction_series(spec.label, Wh, truth.get(t).dt,
                                                   res.series[t]["sensors"]))
    return t_fit


def _add_modal(res: UnitResult, est, spec, scenario: Scenario, truth: _Truth,
               base: dict) -> None:
    """The fit's modes against the structure's (:mod:`podbench.harness.modal`)."""
    recs = training_records(spec, scenario.method, truth.get)  # the band: clean records
    flat = [r for x in recs for r in (x if isinstance(x, list) else [x])]
    res.modal.extend(modal_rows(est, truth.structure, base, flat, scenario.dt,
                                reference=truth.fe_modes))
    res.pom_modes.extend(pom_rows(est, truth.structure, base))


def _add_band(res: UnitResult, row: dict, est, target, plain_seconds: float, *,
              keep_series: bool, label: str, written=lambda r: r) -> None:
    """The 90 % band of one prediction (:mod:`podbench.harness.bands`): its columns into
    ``row``, its interval scores and cost into ``res.band_stats``, its norm into the
    figure's series."""
    W = target.W
    t_band = time.perf_counter()
    band = band_prediction(est, target)
    t_band = time.perf_counter() - t_band
    row.update(band_row(band, W))
    res.band_stats.append(written({
        **{k: row[k] for k in ("scenario", "structure", "method", "target")},
        **band_stats(band, W), "band_seconds": t_band, "plain_seconds": plain_seconds}))
    if keep_series and band is not None:
        # |‖w(t)‖ − ‖ŵ(t)‖| ≤ ‖h(t)‖ wherever the truth is inside the band
        res.series[row["target"]][label + "__band"] = np.linalg.norm(
            band.upper - band.mean, axis=0)


def _twin_predictions(spec, est, U, coupled: bool, scenario: Scenario, truth: _Truth,
                      nonlinear: bool) -> tuple[_Comparisons, str]:
    """The coupled twin's predictions (the method's own if it is coupled), on the linear
    twin too for a nonlinear structure, and the row status ("ok" or why the twin failed)."""
    twin_spec = spec if coupled else (scenario.method(spec.twin) if spec.twin else None)
    ref = _Comparisons()
    if twin_spec is None or U is None:
        return ref, "ok"
    try:
        tw = est if coupled else _fit(twin_spec, scenario, truth, False, basis=U)
        ref.twin = {t: tw.predict(truth.get(t)) for t in scenario.targets}
        if nonlinear:
            twl = _fit(twin_spec, scenario, truth, True, basis=U)
            ref.twin_lin = {t: twl.predict(truth.get(t, True)) for t in scenario.targets}
            ref.lin = {t: truth.get(t, True).W for t in scenario.targets}
    except Exception as exc:  # noqa: BLE001 - a user's twin may raise anything
        _raise_unless_expected(exc, twin_spec.method)
        return _Comparisons(), "twin " + _failure(exc)
    return ref, "ok"


def _own_linear_refit(spec, U, scenario: Scenario, truth: _Truth, ref: _Comparisons,
                      status: str) -> str:
    """The method refitted on the linear twin (in the basis ``U``) into ``ref.own_lin``;
    returns the row status (the first failure's reason)."""
    try:
        own = _fit(spec, scenario, truth, True, basis=U)
        ref.own_lin = {t: own.predict(truth.get(t, True)) for t in scenario.targets}
        if ref.lin is None:
            ref.lin = {t: truth.get(t, True).W for t in scenario.targets}
    except Exception as exc:  # noqa: BLE001 - a user's method may raise anything
        _raise_unless_expected(exc, spec.method)
        if status == "ok":
            status = "linear refit " + _failure(exc)
    return status


def _unit_worker(args):
    return run_unit(*args)


@dataclass
class SideTasks:
    """Tasks of another stage of a study run (the noise seeds' refits, the nonlinearity
    checks) run in the same pool of processes as the units (:func:`run_study`'s ``also``):
    ``func(task)`` for every task of ``tasks`` (``func`` a module-level function, the tasks
    picklable), the results in task order in ``results`` afterwards."""

    name: str
    func: Callable
    tasks: list
    results: list = field(default_factory=list)


def _dispatch(item):
    func, task = item
    return func(task)


def plan(paths) -> list[tuple[Path, str]]:
    """The (scenario file, structure entry) units of the given scenario files, validated."""
    units = []
    for p in paths:
        sc = load_scenario(p)
        loaded: dict = {}
        for i, entry in enumerate(sc.structures):
            # fail early, in the parent, before anything is simulated: unknown names,
            # malformed structure files, excitations that do not fit the structure
            structure = resolve_structure(entry, sc, field=f"scenario.structures[{i}]")
            check_cases(sc, structure, loaded)
            check_modes(sc, structure)
            units.append((Path(p), entry))
    return units


def run_study(paths, *, jobs: int = 1, cache_dir=None, engine: str | None = None,
              progress=None, keep_series: bool = True,
              also: Callable[[], list[SideTasks]] | None = None) -> list[UnitResult]:
    """Run every unit of the scenario files ``paths`` (in ``jobs`` processes, see
    :func:`podbench.harness.executor.execute`); results in deterministic order.
    ``progress``: a :class:`~podbench.harness.progress.Progress` (a bar or lines per
    finished unit) or a callable given one line per finished unit.

    ``also``: called once the scenarios are validated, returns :class:`SideTasks` of other
    stages to run in the same pool after the units (one pool and no barrier between the
    stages: with ``jobs`` = 2 a core no longer waits for the last unit of a stage); their
    results go to each ``SideTasks.results``. Every task computes what it would alone
    (one BLAS thread), so nothing depends on ``jobs`` or on the grouping."""
    units = plan(paths)
    side = also() if also is not None else []
    args = [(str(p), e, None if cache_dir is None else str(cache_dir), engine, keep_series)
            for p, e in units]
    items = [(_unit_worker, a) for a in args] + [(st.func, t) for st in side for t in st.tasks]
    desc = ", ".join(["simulating and fitting", *(st.name for st in side if st.tasks)])
    stage = as_stage(progress, desc, len(items), "task" if len(items) > len(args) else "unit")

    def report(done, total, elapsed, r):
        if isinstance(r, UnitResult):
            stage.advance(f"{r.scenario} × {r.structure}", f"{r.simulated} simulated, "
                          f"{r.cached} from the cache, {r.seconds:.1f} s")
        else:
            stage.advance()

    with stage:
        out = execute(_dispatch, items, jobs=jobs, progress=report)
    k = len(args)
    for st in side:
        st.results, k = out[k:k + len(st.tasks)], k + len(st.tasks)
    return out[:len(args)]


def response_counts(results) -> tuple[int, int]:
    """``(simulated, from the cache)`` of a run: distinct truth responses, each counted once
    however many units used it; a response simulated in this run and read again by another
    unit counts as simulated, not as a cache hit."""
    simulated = {k for u in results for k in u.simulated_keys}
    cached = {k for u in results for k in u.cached_keys} - simulated
    return len(simulated), len(cached)
