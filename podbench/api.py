"""One way through podbench: the functions ``podbench run | regress | sweep | experiment``
call, for Python users too.

``podbench.run("chapter4")`` does exactly what ``podbench run chapter4`` does — the same
checks in the same order (every input read and checked before anything is simulated), the
same outputs, byte for byte — and returns a :class:`StudyResult` instead of printing::

    import podbench as pb
    res = pb.run("chapter4", figures=False)        # -> results/chapter4/
    res.summary                                    # summary.csv as a DataFrame
    res.claims[0]["verdict"]                       # FINDINGS.md's first claim
    res.plot("lti_beam", "load5", scenario="beam_forced")   # a matplotlib Figure

A study is named as on the command line: a bundled study (``"chapter4"``), one of its
scenarios (``"chapter4/beam_forced"``), a folder or scenario file of your own, or a list
of these. Errors on input raise :class:`podbench.errors.InputError` (the CLI's exit code 2)
with one line naming the file and the field, or the parameter.
"""

from __future__ import annotations

import csv
import os
import shlex
import shutil
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from podbench.core.atomic import atomic_write_text
from podbench.core.hints import did_you_mean
from podbench.core.resources import (
    DEFAULT_BASELINE,
    DEFAULT_CACHE,
    DEFAULT_RESULTS,
    DEFAULT_STUDY,
    SWEEPS_STUDY,
    bundled_studies,
    display_path,
    resolve_bundled,
)
from podbench.errors import InputError, UnknownNameError
from podbench.harness.bands import BAND_COLUMNS
from podbench.harness.base_excited import run_study as run_base_excited
from podbench.harness.executor import resolve_jobs
from podbench.harness.f16_gvt import run_study as run_f16_gvt
from podbench.harness.fit import fit_files
from podbench.harness.linked import linked_scenarios, run_linked
from podbench.harness.metrics import ERROR_COLUMNS, NORM_COLUMNS
from podbench.harness.nonlinearity import check_rows, check_task, check_tasks
from podbench.harness.painter_street import run_study as run_painter_street
from podbench.harness.predict import PredictResult, predict_files
from podbench.harness.progress import Progress
from podbench.harness.regress import Comparison, compare, read_table
from podbench.harness.rewrite import unmoved
from podbench.harness.runner import SideTasks, plan, response_counts, run_study
from podbench.harness.seeds import SeedPlan, plan_seeds, seed_unit
from podbench.harness.substructuring import run_substructuring
from podbench.harness.sweep import run_sweep
from podbench.harness.tables import summary_table, table_csv
from podbench.report.base_excited import write_study as write_base_excited
from podbench.report.f16_gvt import write_study as write_f16_gvt
from podbench.report.figures import make_figure
from podbench.report.painter_street import write_study as write_painter_street
from podbench.report.study import figure_tasks, write_study
from podbench.report.substructuring import write_substructuring
from podbench.report.sweep import write_sweep
from podbench.study.base_excited import load_study as load_base_excited
from podbench.study.claims import check_claims, load_claims_file, seed_names
from podbench.study.experiments import check_experiment, write_experiment
from podbench.study.f16_gvt import load_f16_gvt
from podbench.study.nonlinearity import NonlinearitySpec
from podbench.study.own_runner import (
    STUDY_TABLE,
    OwnStudy,
    check_requires,
    load_own_study,
    own_study_file,
)
from podbench.study.painter_street import load_painter_street
from podbench.study.scenarios import CLAIMS_FILE, SolverChoice, find_scenarios, load_scenario
from podbench.study.substructuring import load_substructuring
from podbench.sysid.deconvolution import RENAMED, available_solvers, current_name
from podbench.sysid.models import Model
from podbench.sysid.registry import lookup

__all__ = ["run", "StudyResult", "predict", "fit", "load_model", "Model", "regress", "sweep",
           "experiment", "resolve_study", "own_study", "Runner", "RUNNERS", "DEFAULT_CACHE",
           "DEFAULT_RESULTS", "DEFAULT_BASELINE", "REGRESS_STUDIES"]

REGRESS_STUDIES = ("chapter4", "chapter5")
"""What ``regress`` re-runs without a study: the numerical study and the noisy-measurement
study (the committed baseline holds their rows)."""


# ----------------------------------------------------------------------------- inputs
def _as_list(study) -> list:
    """``study`` as a list of names/paths: one string or path is one item (never its
    characters), a sequence is its items, None is none."""
    if study is None:
        return []
    if isinstance(study, (str, os.PathLike)):
        return [study]
    if isinstance(study, Sequence):
        return list(study)
    raise InputError(f"Parameter `study`: expected a name, a path or a list of them, got "
                     f"{type(study).__name__}")


def resolve_study(study, default=(DEFAULT_STUDY,)) -> tuple[list[Path], list[Path]]:
    """The paths a study names and their scenario files.

    A name that is not an existing file or folder is looked up among the bundled studies
    (``chapter4``) and their scenarios (``chapter4/beam_forced``); without ``study`` the
    bundled studies ``default`` are taken.

    Raises
    ------
    UnknownNameError
        A name that is neither a path nor bundled (with the closest bundled name).
    ScenarioFileError
        A folder without scenario files, a file that is not ``.toml``.
    """
    names = _as_list(study)
    resolved = []
    for p in names or list(default):
        if not names or not Path(p).exists():
            b = resolve_bundled(str(p))
            if b is None:
                studies = bundled_studies()
                choices = list(studies) + [f"{s}/{f.stem}" for s, d in studies.items()
                                           for f in find_scenarios([d])]
                raise UnknownNameError(
                    f"{p}: no such file or folder, nor a bundled study or scenario"
                    f"{did_you_mean(str(p), choices)} (bundled studies: "
                    f"{', '.join(studies)}; podbench list shows every scenario)")
            resolved.append(b)
        else:
            resolved.append(Path(p))
    return resolved, find_scenarios(resolved)


def _param(name: str) -> str:
    """How an error names the Python parameter ``name`` (the command line shows its flag)."""
    return f"Parameter `{name}`"


def writable_folder(path, option: str) -> Path:
    """``path`` after checking, before any work, that it is a folder or can be created as one:
    not a file, not under a file, its nearest existing ancestor writable. ``option``: the
    Python parameter that gave it (named in the error)."""
    p = Path(path).expanduser()
    where = f"{_param(option)}: {path}"
    if p.exists() and not p.is_dir():
        raise InputError(f"{where}: exists and is not a folder")
    a = p.absolute()
    while not a.exists() and a != a.parent:
        a = a.parent
    if not a.is_dir():
        raise InputError(f"{where}: {a} is a file, so no folder can be made under it")
    if not os.access(a, os.W_OK | os.X_OK):
        raise InputError(f"{where}: {a} is not writable")
    return p


def output_folder(path, option: str, marker: str, *, also=()) -> Path:
    """Check an output folder that podbench fills (or replaces): it must not exist, be empty,
    or be a previous podbench output (holding ``marker``), so that a mistyped ``--out ~``
    cannot replace a home folder; ``marker`` and ``also`` must not be folders."""
    p = writable_folder(path, option)
    where = f"{_param(option)}: {path}"
    if p.is_dir():
        for name in (marker, *also):
            if (p / name).exists() and not (p / name).is_file():
                raise InputError(f"{where}: {p / name} is a folder, not a file")
        if not (p / marker).is_file() and any(p.iterdir()):
            raise InputError(f"{where}: a non-empty folder that is not a podbench "
                             f"output (no {marker} in it); give a new or empty folder")
    return p


def default_out(paths) -> Path:
    """``results/<folder name>`` for a folder, ``results/<file stem>`` for a single scenario
    file (a part of a study never goes over the study's folder), names joined by ``+``."""
    names = [Path(p).resolve().name if Path(p).is_dir() else Path(p).stem for p in paths]
    return DEFAULT_RESULTS / "+".join(dict.fromkeys(names))


def _scenarios_held(out: Path) -> set[str]:
    """The scenarios of a previous output's ``summary.csv`` (empty if none or unreadable)."""
    try:
        with open(out / "summary.csv", newline="", encoding="utf-8") as fh:
            return {row["scenario"] for row in csv.DictReader(fh) if row.get("scenario")}
    except (OSError, UnicodeDecodeError, KeyError, csv.Error):
        return set()


def _refuse_partial_over(out: Path, names, option: str) -> None:
    """Refuse to replace an output holding scenarios this run does not produce (running
    one scenario of a study must not replace the whole study's results)."""
    lost = sorted(_scenarios_held(out) - set(names))
    if lost:
        shown = ", ".join(lost[:4]) + (f" and {len(lost) - 4} more" if len(lost) > 4 else "")
        raise InputError(f"{option} {out}: holds the results of {len(lost)} scenario"
                         f"{'s' if len(lost) != 1 else ''} this run does not produce "
                         f"({shown}); replacing it would lose them: give another --out, or "
                         "run them all")


def _refuse_own(files, command: str) -> None:
    """Refuse a study with its own runner where scenarios are needed (``regress``,
    ``sweep``): only ``podbench run`` runs it."""
    own = own_study(files)
    if own is not None:
        raise InputError(f"{display_path(own.path)}: a study with its own runner "
                         f"({own.runner}), not scenarios: podbench run runs it, podbench "
                         f"{command} does not")


def load_scenarios(files, command: str = "run") -> dict:
    """Scenario name → scenario of every file (two scenarios of one name are refused, and so
    is a study with its own runner: only ``podbench run`` runs it)."""
    _refuse_own(files, command)
    scenarios: dict = {}
    for f in files:
        sc = load_scenario(f)
        if sc.name in scenarios:
            raise InputError(f"{f}: a second scenario named {sc.name!r}")
        scenarios[sc.name] = sc
    return scenarios


def _claims_path(paths) -> Path | None:
    """The one claims file beside the paths run (None if none, or several)."""
    dirs = {Path(p).resolve() if Path(p).is_dir() else Path(p).resolve().parent for p in paths}
    found = [d / CLAIMS_FILE for d in sorted(dirs) if (d / CLAIMS_FILE).is_file()]
    return found[0] if len(found) == 1 else None


def _whole_study(claims_path, scenarios) -> bool:
    """Whether ``scenarios`` holds every scenario of the claims file's folder."""
    return {p.stem for p in find_scenarios([Path(claims_path).parent])} <= set(scenarios)


def _check_run_options(jobs, cache) -> Path | None:
    resolve_jobs(jobs, _param("jobs"))
    return None if cache is None else writable_folder(cache, "cache")


def _progress(progress, quiet: bool):
    return progress if progress is not None else Progress(quiet=quiet)


# -------------------------------------------------------------------------------- run
@dataclass
class StudyResult:
    """What :func:`run` wrote and measured.

    Attributes
    ----------
    out : Path
        The output folder (``summary.csv``, ``summary.md``, ``fits.csv``, ``FINDINGS.md``,
        ``figures/``, ``report.html``).
    summary : DataFrame
        ``summary.csv``: one row per scenario × structure × method × target, errors as
        fractions of ‖W‖_F (docs/error-decomposition.md).
    fits : DataFrame
        ``fits.csv``: what each fit measured about itself.
    claims : list of dict or None
        The judged claims of ``FINDINGS.md`` (``id``, ``verdict``, …), None without a
        claims file.
    figures : list of Path
        The figure files written (empty with ``figures=False``).
    scenarios : dict
        Scenario name → the scenario read.
    seconds : float
        Wall time of simulating and fitting.
    simulated, cached : int
        Distinct truth responses simulated, and read from the cache.
    """

    out: Path
    summary: pd.DataFrame
    fits: pd.DataFrame
    claims: list | None
    figures: list
    scenarios: dict
    seconds: float
    simulated: int
    cached: int
    _units: list = field(default_factory=list, repr=False)

    def to_html(self, path) -> Path:
        """Copy the self-contained report page (``report.html``) to ``path``."""
        src = self.out / "report.html"
        if not src.is_file():
            raise InputError(f"{src}: no report page (the output folder was changed)")
        return Path(shutil.copyfile(src, path))

    def plot(self, structure: str, target: str, *, scenario: str | None = None):
        """The figure of one target (the displacement norm, Eq. 4.1, of the truth and every
        method, and the percent error of Eq. 4.2), as a matplotlib Figure.

        Needs the norm series, kept when the run drew figures (``figures=True``).
        ``scenario`` is needed where two scenarios share the structure and target."""
        tasks = [t for t in figure_tasks(self._units, self.scenarios, self.out / "figures")
                 if t.meta["structure"] == structure and t.meta["target"] == target
                 and scenario in (None, t.meta["scenario"])]
        if not tasks:
            have = sorted({(t.meta["scenario"], t.meta["structure"], t.meta["target"])
                           for t in figure_tasks(self._units, self.scenarios, self.out)})
            hint = ("run with figures=True to keep the series" if not have else
                    "targets: " + ", ".join("/".join(h) for h in have[:12]))
            raise InputError(f"Parameter `target`: no figure of {structure}, target {target}"
                             f" ({hint})")
        if len(tasks) > 1:
            names = ", ".join(t.meta["scenario"] for t in tasks)
            raise InputError(f"Parameter `scenario`: {structure}/{target} is a target of "
                             f"several scenarios ({names}); name one")
        return make_figure(tasks[0])


def run(study=None, *, out=None, jobs: int | str = "auto", cache=DEFAULT_CACHE,
        engine: str | None = None, figures: bool = True, figure_format: str = "png",
        quiet: bool = True, progress=None, command: str | None = None) -> StudyResult:
    """Run a study and write its outputs, as ``podbench run`` does.

    Parameters
    ----------
    study : str, path or list of them, optional
        A bundled study or scenario name, a folder or scenario file (default: the bundled
        Chapter 4 study). A study file whose ``[study]`` table names a runner of
        :data:`RUNNERS` (``painter_street``, ``substructuring``, ``base_excited``) is run
        by that runner.
    out : path, optional
        The output folder (default ``results/<study>``); it must be new, empty or a previous
        podbench output, and is replaced only when the run is complete.
    jobs : int or "auto"
        Processes for the units and the figures, the calling one included (tables are
        identical whatever ``jobs``); ``"auto"``: the cores available, at most 8
        (:func:`podbench.harness.executor.resolve_jobs`). Processes beyond the calling one
        start only once it has computed for 2 s with tasks still waiting.
    cache : path or None
        The truth cache's folder (``None``: no cache).
    engine : {"newmark", "exudyn"}, optional
        The truth engine (default: each scenario's own).
    figures : bool
        Draw the figures (``figure_format``: png, svg or pdf).
    quiet : bool
        No progress on stderr (the CLI shows it unless ``--quiet``).
    command : str, optional
        The command line shown in ``report.html`` (default: ``podbench.run(...)``); a study
        with its own runner names ``podbench run <study>`` in its FINDINGS.md instead.
    """
    paths, files = resolve_study(study)
    out = Path(out) if out is not None else default_out(paths)
    output_folder(out, "out", "summary.csv")
    own = own_study(files)
    if own is not None:  # a study file naming its own runner ([study] runner = "...")
        check_requires(own.path, STUDY_TABLE, own.requires)
        return _run_own(own, out, study, jobs=jobs, cache=cache, engine=engine, figures=figures,
                        figure_format=figure_format, say=_say(progress, quiet, own.name))
    scenarios = load_scenarios(files)
    for sc in scenarios.values():
        check_requires(sc.path, "scenario", sc.requires)
    _refuse_partial_over(out, scenarios, "out")
    claims = _claims_path(paths)
    claims_file = load_claims_file(claims) if claims is not None else None  # before any work
    if claims_file is not None:
        check_claims(claims_file, scenarios, ("n_modes", *ERROR_COLUMNS, *NORM_COLUMNS,
                                              *BAND_COLUMNS))
    cache_dir = _check_run_options(jobs, cache)
    progress = _progress(progress, quiet)
    if isinstance(progress, Progress):
        progress.note(_announcement(files, scenarios, claims_file, claims, figures))
    t0 = time.perf_counter()
    side = _SideStages(claims_file, claims, scenarios, cache_dir)
    results = run_study(files, jobs=jobs, cache_dir=cache_dir, engine=engine,
                        progress=progress, keep_series=figures, also=side.plan)
    seconds = time.perf_counter() - t0
    linked = None
    if claims_file is not None:  # the claims' sensitivity study, judged with the same code
        linked = run_linked(claims_file, scenarios, jobs=jobs, cache_dir=cache_dir,
                            engine=engine, progress=progress)
    seeds, nonlinearity = side.seed_rows(), side.nonlinearity()
    if command is None:
        command = "podbench.run(" + ", ".join(repr(str(p)) for p in _as_list(study)) + ")"
    df, evaluated = write_study(results, out, scenarios=scenarios, claims_path=claims,
                                figures=figures, jobs=jobs, figure_format=figure_format,
                                progress=progress, command=command, sensitivity=linked,
                                nonlinearity=nonlinearity, seeds=seeds, seconds=seconds)
    n_sim, n_cached = response_counts(results)
    drawn = sorted((out / "figures").glob(f"*.{figure_format}")) if figures else []
    fits_csv = out / "fits.csv"  # empty when no fit succeeded (every row says why it failed)
    fits = pd.read_csv(fits_csv) if fits_csv.stat().st_size > 1 else pd.DataFrame()
    return StudyResult(out=out, summary=df, fits=fits,
                       claims=evaluated, figures=drawn, scenarios=scenarios, seconds=seconds,
                       simulated=n_sim, cached=n_cached, _units=results)


class _SideStages:
    """The stages of a study run beside its units, in the units' pool (:func:`run`,
    :class:`podbench.harness.runner.SideTasks`): the comparisons on the other noise seeds
    (claims.toml's ``noise_seeds``, :func:`podbench.harness.seeds.plan_seeds`) and, on a
    whole-study run, §5.2's nonlinearity checks (``[nonlinearity]``)."""

    def __init__(self, claims_file, claims, scenarios: dict, cache_dir):
        self.claims_file, self.claims, self.scenarios = claims_file, claims, scenarios
        self.cache_dir = cache_dir
        self.seeds: SeedPlan | None = None
        self.seed_tasks: SideTasks | None = None
        self.spec: NonlinearitySpec | None = None
        self.check_tasks: SideTasks | None = None

    def plan(self) -> list[SideTasks]:
        cf = self.claims_file
        if cf is None:
            return []
        out: list[SideTasks] = []
        self.seeds = plan_seeds(cf, cf.claims, self.scenarios)
        if self.seeds is not None:
            self.seed_tasks = SideTasks(f"comparisons over noise {seed_names(self.seeds.seeds)}",
                                        seed_unit, self.seeds.tasks)
            out.append(self.seed_tasks)
        if cf.nonlinearity is not None and _whole_study(self.claims, self.scenarios):
            spec: NonlinearitySpec = cf.nonlinearity
            self.spec = spec
            self.check_tasks = SideTasks("nonlinearity checks", check_task,
                                         check_tasks(spec, self.cache_dir))
            out.append(self.check_tasks)
        return out

    def seed_rows(self):
        if self.seeds is None or self.seed_tasks is None:
            return None
        return self.seeds.rows(self.seed_tasks.results)

    def nonlinearity(self):
        if self.spec is None or self.check_tasks is None:
            return None
        return self.spec, check_rows(self.check_tasks.results)


def _announcement(files, scenarios: dict, claims_file, claims, figures: bool) -> str:
    """What a run is about to do, in one line: scenarios and units, the claims' linked
    sensitivity study and nonlinearity checks (run beside the study, so that FINDINGS
    can state each claim's verdict over the parameters the text leaves open), figures."""
    n_units = len(plan(files))
    parts = [f"{len(scenarios)} scenario{'s' if len(scenarios) != 1 else ''} "
             f"({n_units} unit{'s' if n_units != 1 else ''} of structure × scenario)"]
    if claims_file is not None:
        linked = linked_scenarios(claims_file, scenarios)
        if linked:
            n = len(plan(list(linked)))
            parts.append(f"the claims' sensitivity study ({n} units of "
                         f"{display_path(claims_file.sensitivity)}, for FINDINGS' verdicts "
                         "over the unstated parameters)")
        if claims_file.nonlinearity is not None and _whole_study(claims, scenarios):
            parts.append("the §5.2 nonlinearity checks")
        if claims_file.noise_seeds:
            parts.append(f"the claims' comparisons over noise "
                         f"{seed_names(claims_file.noise_seeds)}")
    parts.append("figures and report.html" if figures else "report.html")
    return "podbench: running " + "; then ".join(parts)


# ----------------------------------------------------------------------------- predict
def predict(method: str | None, train, target, out, *, solver: str = "auto", n_modes=None,
            coverage=None, input_units=None, output_units=None,
            units=None, model=None) -> PredictResult:
    """Fit ``method`` (a registered name, :mod:`podbench.sysid.registry`) on the ``train``
    record files and predict every ``target`` file, as ``podbench predict``:
    ``out/errors.csv`` (target, method, total_error, per-channel errors), ``out/<target
    stem>.npz`` with ``y_hat`` (and ``W_hat`` for displacements; with ``coverage``:
    ``lower``, ``upper`` in the ``.npz``, ``error_estimate`` and ``coverage`` in errors.csv)
    and ``out/config.json`` (the fitted configuration). Every file is checked before any
    fitting; ``out`` is written whole or not at all. With ``model`` (a ``model.npz`` of
    :func:`fit`), the saved model predicts (``method`` and ``train`` None). Returns the
    :class:`~podbench.harness.predict.PredictResult` (``rows`` of errors.csv, ``config``)."""
    out = output_folder(out, "out", "errors.csv")
    return predict_files(method, _as_list(train) if train is not None else None,
                         _as_list(target), out, solver=solver, n_modes=n_modes,
                         coverage=coverage, input_units=input_units,
                         output_units=output_units, units=units, model=model)


def fit(method: str, records, out=None, *, training_files=(), solver: str | None = None,
        n_modes=None, input_units=None, output_units=None, units=None, **params):
    """Fit a registered ``method`` and return the model you keep
    (:class:`~podbench.sysid.models.Model`: ``predict``, ``modes()``, ``to_statespace()``,
    ``save``).

    ``records`` are :class:`~podbench.core.records.Record` objects, fitted with the
    method's ``params`` as given (``pb.fit("ML", records, n_lags="auto")``); or record
    files, fitted as ``podbench fit`` fits them (``solver``, ``n_modes`` as its options)
    and, with ``out``, written as ``podbench fit`` writes them (model.npz, model.json,
    modes.csv).
    """
    recs = _as_list(records)
    if recs and all(isinstance(r, (str, Path)) for r in recs):
        if params:
            raise InputError(f"Parameter `{next(iter(params))}`: record files are fitted as "
                             "podbench fit fits them (solver, n_modes); fit Records to give "
                             "the method's own parameters")
        folder = output_folder(out if out is not None else default_out(recs), "out",
                               "model.npz")
        return fit_files(method, recs, folder, solver=solver or "auto", n_modes=n_modes,
                         input_units=input_units, output_units=output_units,
                         units=units).model
    if out is not None:
        raise InputError("Parameter `out`: a folder for fits of record files; save a model "
                         "of Records with model.save(path)")
    given = {k: v for k, v in (("solver", solver), ("n_modes", n_modes)) if v is not None}
    est = lookup(method).build(**{**params, **given}).fit(recs)
    return Model(est, training_files=training_files)


def load_model(path) -> Model:
    """The model saved in ``path`` (a ``model.npz`` of :func:`fit` or ``podbench fit``):
    refused in one line naming the file if it is not a podbench model, has an unknown
    ``format_version`` or holds pickles."""
    return Model.load(path)


# -------------------------------------------------------- studies with their own runner
@dataclass(frozen=True)
class RunnerOptions:
    """What :func:`run` hands a study's own runner: draw ``figures`` (as ``figure_format``),
    ``say`` one line of progress (None: quiet), the ``command`` that FINDINGS.md names
    (``podbench run <study>``, whatever the options, so that FINDINGS regenerates
    byte-identically from the CLI and from Python) and the ``jobs`` it may use."""

    figures: bool
    figure_format: str
    say: Callable[[str], None] | None
    command: str
    jobs: int | str = 1


@dataclass(frozen=True)
class Runner:
    """A study runner of its own: its one-line ``title`` (``podbench list``) and
    ``run(study, out, options) -> StudyResult``, which reads the study file's own table
    (study layer), runs it (harness) and writes ``out`` (report) as a whole."""

    title: str
    run: Callable[[OwnStudy, Path, RunnerOptions], StudyResult]


def _run_painter_street(study: OwnStudy, out: Path, options: RunnerOptions) -> StudyResult:
    """The Painter Street Overpass study (:mod:`podbench.harness.painter_street`):
    leave-one-event-out over measured earthquake records."""
    plan = load_painter_street(study.path)
    res = run_painter_street(plan.data, progress=options.say)
    drawn = write_painter_street(res, out, figures=options.figures,
                                 figure_format=options.figure_format)
    return StudyResult(out=out, summary=pd.read_csv(out / "summary.csv"),
                       fits=pd.read_csv(out / "fits.csv"), claims=None, figures=drawn,
                       scenarios={plan.name: plan}, seconds=0.0, simulated=0, cached=0)


def _run_f16_gvt(study: OwnStudy, out: Path, options: RunnerOptions) -> StudyResult:
    """The F-16 ground vibration test study (:mod:`podbench.harness.f16_gvt`): linear
    models across force levels on the benchmark's records (Noël & Schoukens 2017)."""
    plan = load_f16_gvt(study.path)
    res = run_f16_gvt(plan, progress=options.say, jobs=options.jobs)
    drawn = write_f16_gvt(res, out, figures=options.figures,
                          figure_format=options.figure_format)
    return StudyResult(out=out, summary=pd.read_csv(out / "summary.csv"),
                       fits=pd.read_csv(out / "fits.csv"), claims=None, figures=drawn,
                       scenarios={plan.name: plan}, seconds=0.0, simulated=0, cached=0)


def _run_base_excited(study: OwnStudy, out: Path, options: RunnerOptions) -> StudyResult:
    """The base-excited study (:mod:`podbench.harness.base_excited`): beams and truss shaken
    at the base, acceleration and strain outputs in SI."""
    plan = load_base_excited(study.path)
    res = run_base_excited(plan, progress=options.say, keep_series=options.figures)
    write_base_excited(res, out, figures=options.figures)
    drawn = sorted((out / "figures").glob("*.png")) if options.figures else []
    return StudyResult(out=out, summary=pd.read_csv(out / "summary.csv"),
                       fits=pd.read_csv(out / "fits.csv"), claims=None, figures=drawn,
                       scenarios={"base_excited": study}, seconds=0.0, simulated=0, cached=0)


def _run_substructuring(study: OwnStudy, out: Path, options: RunnerOptions) -> StudyResult:
    """The substructuring study of Chapter 6 (:mod:`podbench.harness.substructuring`): its
    own table (``summary.csv``, ``medians.csv``), ``FINDINGS.md`` and figures."""
    plan = load_substructuring(study.path)
    rows, truths = run_substructuring(plan, progress=options.say)
    df, drawn = write_substructuring(rows, truths, out, dt=plan.dt, figures=options.figures,
                                     figure_format=options.figure_format,
                                     command=options.command)
    return StudyResult(out=out, summary=df, fits=pd.DataFrame(), claims=None, figures=drawn,
                       scenarios={plan.name: plan}, seconds=0.0,
                       simulated=len(plan.components), cached=0)


RUNNERS: dict[str, Runner] = {
    "painter_street": Runner("leave-one-event-out over measured earthquake records "
                             "(the Painter Street Overpass)", _run_painter_street),
    "substructuring": Runner("Chapter 6: identified components coupled to a finite-element "
                             "model", _run_substructuring),
    "base_excited": Runner("beams and truss shaken at the base: acceleration and strain "
                           "outputs (SI)", _run_base_excited),
    "f16_gvt": Runner("F-16 ground vibration test: linear models across force levels "
                      "(Noël & Schoukens 2017)", _run_f16_gvt),
}
"""The runners a study file may name (``[study] runner = "<name>"``). A new study that is
not scenarios of methods and targets adds its runner here (docs/ARCHITECTURE.md)."""


def _run_own(own: OwnStudy, out: Path, study, *, jobs, cache, engine, figures: bool,
             figure_format: str, say) -> StudyResult:
    """:func:`run` of a study with its own runner: the options checked as for any study
    (``engine`` refused: the runner chooses its own), then the runner, timed."""
    if engine is not None:
        raise InputError(f"{_param('engine')}: {display_path(own.path)} is run by its own runner "
                         f"({own.runner}), which takes no engine")
    _check_run_options(jobs, cache)
    options = RunnerOptions(figures=figures, figure_format=figure_format, say=say,
                            command=command_line(["run", *map(str, _as_list(study))]),
                            jobs=jobs)
    t0 = time.perf_counter()
    res = RUNNERS[own.runner].run(own, out, options)
    res.seconds = time.perf_counter() - t0
    return res


def own_study(files) -> OwnStudy | None:
    """The study with its own runner that ``files`` name (checked: its ``[study]`` table
    names a runner of :data:`RUNNERS`), or None for scenario files."""
    path = own_study_file(files, RUNNERS)
    return None if path is None else load_own_study(path, RUNNERS)


def _say(progress, quiet: bool, name: str) -> Callable[[str], None] | None:
    """One line of an own runner's progress, ``<study>: <message>``, on the progress given
    (a :class:`Progress` or a callable), else on stderr unless ``quiet``."""
    if isinstance(progress, Progress):
        return None if progress.quiet else (lambda m: progress.note(f"{name}: {m}"))
    if callable(progress):
        return lambda m: progress(f"{name}: {m}")
    return None if quiet else (lambda m: print(f"{name}: {m}", file=sys.stderr, flush=True))


# ---------------------------------------------------------------------------- regress
@dataclass
class RegressResult:
    """What :func:`regress` did: the ``comparison`` of every error with the baseline (None
    when ``update`` rewrote it instead), the number of ``rows`` compared or written, and the
    ``baseline`` file."""

    comparison: Comparison | None
    rows: int
    baseline: Path
    updated: bool = False

    @property
    def failed(self) -> bool:
        """Whether an error moved beyond the tolerances."""
        return self.comparison is not None and bool(self.comparison.failed)


def regress(study=None, *, baseline=DEFAULT_BASELINE, rtol: float = 0.01, atol: float = 1e-6,
            update: bool = False, table=None, jobs: int | str = "auto", cache=DEFAULT_CACHE,
            engine: str | None = None, quiet: bool = True, progress=None) -> RegressResult:
    """Re-run studies (default: Chapter 4 and 5) or read a ``table`` and compare every error
    with the ``baseline`` (relative ``rtol``, absolute ``atol``), as ``podbench regress``;
    with ``update`` the baseline is (re)written instead. Only the study's rows are judged
    (the scenarios of ``study``, or with ``table`` alone those the table names): a baseline
    row of another study is neither missing nor compared, and ``update`` replaces the
    study's rows and keeps the others. Returns the :class:`RegressResult`."""
    files = None if table and not study else resolve_study(study, REGRESS_STUDIES)[1]
    if files is not None:  # missing paths first, then a study with its own runner
        _refuse_own(files, "regress")
    baseline = Path(baseline)
    if update:  # checked before any work: the new baseline can be written
        if baseline.is_dir():
            raise InputError(f"{_param('baseline')}: {baseline}: is a folder, not a CSV file")
        if baseline.parent.exists() and not baseline.parent.is_dir():
            raise InputError(f"{_param('baseline')}: {baseline}: {baseline.parent} is a file, "
                             "not a folder")
        writable_folder(baseline.parent, "baseline")
    elif not baseline.is_file():
        raise InputError(f"{baseline}: no such baseline (create it with --update)")
    base = None if update else read_table(baseline)
    names = None if files is None else set(load_scenarios(files, "regress"))
    if table:
        new = read_table(table)
    else:
        cache_dir = _check_run_options(jobs, cache)
        new = summary_table(run_study(files, jobs=jobs, cache_dir=cache_dir, engine=engine,
                                      progress=_progress(progress, quiet), keep_series=False))
    if update:
        if baseline.is_file():  # the other studies' rows stay
            kept = read_table(baseline)
            new = pd.concat([kept[~kept["scenario"].isin(set(new["scenario"]) | (names or set()))],
                             new], ignore_index=True)
        atomic_write_text(baseline, table_csv(new), keep=unmoved)
        return RegressResult(comparison=None, rows=len(new), baseline=baseline, updated=True)
    assert base is not None  # read above, before the run, unless update
    # judge exactly the study's rows: its scenarios, or those the table names
    names = set(new["scenario"]) if names is None else names
    new = new[new["scenario"].isin(names)]
    base = base[base["scenario"].isin(names)]
    return RegressResult(comparison=compare(new, base, rtol=rtol, atol=atol), rows=len(new),
                         baseline=baseline)


# ------------------------------------------------------------------------------ sweep
@dataclass
class SweepResult:
    """What :func:`sweep` wrote: ``table`` (every point), ``written`` (scenario → its
    ``sweep.csv``), ``seconds``, ``jobs`` (the local processes allowed, ``auto``
    resolved; 0 on a Dask cluster)."""

    table: pd.DataFrame
    written: dict
    seconds: float
    jobs: int = 0


def sweep(study=None, *, out=DEFAULT_RESULTS, noise=None, n_modes=None, seeds=None,
          solvers=None, jobs: int | str | None = None, scheduler: str | None = None,
          cache=DEFAULT_CACHE, engine: str | None = None, quiet: bool = True,
          progress=None) -> SweepResult:
    """Run the ``[sweep]`` scenarios (default: the bundled ``sweeps``) over noise levels,
    mode counts, seeds and solvers, as ``podbench sweep``; each scenario writes
    ``out/<scenario>/sweep.csv`` and ``sweep.md``. ``noise``, ``n_modes``, ``seeds``,
    ``solvers``: lists overriding the scenario's own axes. ``jobs``: local processes, the
    calling one included, or ``"auto"`` (the cores available, at most 8; processes beyond
    the calling one start only after 2 s of work, as in :func:`run`); default (None):
    ``"auto"``, or the Dask cluster at ``scheduler``, which refuses a ``jobs`` given with
    it. The table does not depend on either."""
    if scheduler is not None and jobs is not None:
        raise InputError(f"{_param('jobs')} = {jobs} and {_param('scheduler')} = {scheduler}: "
                         "give one (the Dask "
                         "cluster sets the parallelism)")
    jobs = 0 if scheduler is not None else resolve_jobs("auto" if jobs is None else jobs,
                                                        _param("jobs"))
    axes = {"noise": noise, "n_modes": n_modes, "seeds": seeds}
    if solvers is not None:
        for name in solvers:
            if name not in available_solvers() and name.lower() not in RENAMED:
                raise UnknownNameError(f"{_param('solvers')}: unknown solver {name!r}"
                                       f"{did_you_mean(name, available_solvers())} "
                                       f"(solvers: {', '.join(available_solvers())})")
        names = [current_name(n) for n in solvers]  # a former name: its new one (warns)
        axes["solvers"] = [SolverChoice(label=n, solver=n) for n in names]
    _, files = resolve_study(study, default=(SWEEPS_STUDY,))
    cache_dir = None if cache is None else writable_folder(cache, "cache")
    writable_folder(out, "out")
    for name in load_scenarios(files, "sweep"):  # each writes OUT/<name>/sweep.csv, sweep.md
        output_folder(Path(out) / name, "out", "sweep.csv", also=("sweep.md",))
    t0 = time.perf_counter()
    scenarios, df = run_sweep(files, jobs=jobs or 1, scheduler=scheduler, cache_dir=cache_dir,
                              engine=engine, progress=_progress(progress, quiet), **axes)
    seconds = time.perf_counter() - t0
    written = {}
    for name, sc in scenarios.items():
        written[name], _ = write_sweep(df[df["scenario"] == name].reset_index(drop=True),
                                       Path(out) / name, sc)
    return SweepResult(table=df, written=written, seconds=seconds, jobs=jobs)


# ------------------------------------------------------------------------- experiment
@dataclass
class ExperimentResult:
    """What :func:`experiment` did: the record files ``written``, or with ``check``
    (``checked``) the files that ``differ`` from a fresh generation."""

    written: list[Path]
    differ: list[str]
    checked: bool = False


def experiment(study, *, check: bool = False) -> ExperimentResult:
    """Write (or with ``check``, compare with a fresh generation) the record files of a
    virtual experiment (``experiment.toml`` in a study folder, e.g. the bundled
    ``chapter5``). Returns the :class:`ExperimentResult`."""
    path = Path(study)
    if not path.exists():
        b = resolve_bundled(str(study))
        if b is None or not b.is_dir():
            raise UnknownNameError(f"{study}: no such file or folder, nor a bundled study"
                                   f"{did_you_mean(str(study), bundled_studies())}")
        path = b
    if check:
        return ExperimentResult(written=[], differ=list(check_experiment(path)), checked=True)
    return ExperimentResult(written=list(write_experiment(path)), differ=[])


def command_line(argv) -> str:
    """The command line a report shows for ``podbench`` with ``argv``."""
    return shlex.join(["podbench", *map(str, argv)])
