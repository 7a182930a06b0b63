"""Sweeps: every scenario point over noise levels × mode counts × seeds × structures × methods
(× deconvolution solvers), serially, in local processes, or on a Dask distributed cluster.

Axes come from a scenario's ``[sweep]`` table (:class:`podbench.scenarios.Sweep`) or from the
command line (``podbench sweep --noise … --n-modes … --seeds … --solvers …``, which replace
the file's axes). One **task** is one (scenario, structure, noise level, k, seed) point; it
runs every method of the scenario (each solver of the ``solvers`` axis as its own entry)
through :func:`podbench.harness.runner.run_unit` and returns its rows. Tasks are
independent pure functions of their arguments, so the table is identical whatever executes
them (``jobs = 1``, ``jobs = N`` local processes, or a Dask scheduler) and whatever order
they finish in.

Noise model (:mod:`podbench.noise`, ``noise_model`` of the ``[sweep]`` table): by default
``"per_channel"`` — Gaussian, standard deviation ``level × RMS`` of each measured channel's
own record, on every sensor row of ``W`` and on the instrumented force rows only (the rows of
``F`` not identically zero: a force channel exists where a load is applied); ``"per_entry_rms"``
is the former model (``level × RMS`` of the whole matrix on every entry). Noise is added after
the truth is loaded from the cache (so the cache stays valid), by default to the training
displacements ``W`` and forces ``F`` (``noise_on`` adds the initial profiles ``w0``/``v0`` on
request); ``snr_db`` replaces ``noise`` by SNRs in dB; ``force_offset`` / ``force_drift`` add
a load-cell offset and linear drift (relative to the channel's peak). Targets are never noisy:
each prediction is made from the target's exact excitation and compared with the noise-free
truth, so the error is the identification error caused by noisy training data. The draws
are seeded by ``(seed, scenario, structure, case, quantity, channel)`` through
``SeedSequence``; the
same seed gives the same pattern at every level, for every method, solver and k. A
noise-free point does not depend on the seed: it is computed once and its rows are repeated
for every seed (so the table stays rectangular).

Axis ``n_modes`` (k) replaces the methods' ``n_modes``; for MDS and ML, whose k is the
number of training sets, ``coupled_train`` says whether they train on their first k cases
(default, the dissertation's square system) or on all of them
(:func:`podbench.scenarios.apply_overrides`). Axis ``solvers`` runs every deconvolving
method (SL, ML, MR) once per solver; POVR and MDS (nothing to deconvolve) are run once
and have an empty ``solver``.

Output (:func:`write_sweep`): ``sweep.csv`` with :data:`SWEEP_COLUMNS`, rows in task order
(structure, noise, k, seed, as listed) then method and target (scenario order), numbers in
``%.6g``; ``sweep.md`` with the median (max) of ``total_error`` over the seeds.

Dask: the workers must see the same project folder (scenario files and structures at the same
absolute paths, e.g. a shared file system) and have podbench installed (``pip install
podbench[dask]``); the cache folder, if given, should be shared too (otherwise each worker
simulates the truth it needs). A worker whose scenario file differs from the client's
refuses the task.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from podbench.errors import InputError, ScenarioFileError
from podbench.harness.executor import execute, resolve_jobs
from podbench.harness.metrics import ERROR_COLUMNS, NORM_COLUMNS, roundoff_errors
from podbench.harness.progress import as_stage
from podbench.harness.runner import (
    SWEEP_DIAGNOSTICS,
    NoiseSpec,
    check_cases,
    check_modes,
    run_unit,
)
from podbench.study.resolve import resolve_structure
from podbench.study.scenarios import (
    Scenario,
    SolverChoice,
    Sweep,
    apply_overrides,
    load_scenario,
)

__all__ = ["SWEEP_COLUMNS", "SweepTask", "plan_sweep", "run_task", "run_sweep", "sweep_table",
           "sweep_axes"]

SWEEP_COLUMNS = ("scenario", "structure", "method", "solver", "target", "noise", "modes",
                 "seed", "n_modes", *ERROR_COLUMNS, *NORM_COLUMNS, *SWEEP_DIAGNOSTICS,
                 "status")
"""Columns of ``sweep.csv``: ``noise`` (relative level), ``modes`` (the k axis; −1 when not
swept), ``seed``, ``solver`` (the solver label; empty for a method that does not
deconvolve) and ``n_modes`` (the k actually used, −1 for a failed fit), then the columns of
``summary.csv`` and what the fit's solver chose (:data:`~podbench.harness.runner.
SWEEP_DIAGNOSTICS`: Tikhonov parameter, iterations, amplification)."""


@dataclass(frozen=True)
class SweepTask:
    """One sweep point: plain values, so it travels to processes and Dask workers."""

    index: int
    scenario_path: str
    digest: str
    structure: str
    noise: float
    modes: int | None
    seed: int
    solvers: tuple[SolverChoice, ...] | None
    noise_on: tuple[str, ...]
    coupled_train: str
    cache_dir: str | None
    engine: str | None
    first_seed: int
    """The sweep's first seed: a noise-free point is computed for it only."""
    noise_model: str = "per_channel"
    force_offset: float = 0.0
    force_drift: float = 0.0


def sweep_axes(scenario: Scenario, *, noise=None, n_modes=None, seeds=None,
               solvers=None) -> Sweep:
    """The scenario's ``[sweep]`` axes (defaults without the table), each replaced by the
    given value when not None (the command line's ``--noise`` etc.)."""
    base = scenario.sweep or Sweep()
    out = Sweep(
        noise=base.noise if noise is None else tuple(float(x) for x in noise),
        n_modes=base.n_modes if n_modes is None else tuple(int(x) for x in n_modes),
        seeds=base.seeds if seeds is None else tuple(int(x) for x in seeds),
        solvers=base.solvers if solvers is None else tuple(solvers),
        noise_on=base.noise_on, coupled_train=base.coupled_train,
        noise_model=base.noise_model, force_offset=base.force_offset,
        force_drift=base.force_drift,
    )
    for name, vals in (("noise", out.noise), ("n_modes", out.n_modes or ()),
                       ("seeds", out.seeds)):
        if len(set(vals)) != len(vals):
            raise InputError(f"sweep axis `{name}`: a value is listed twice: {list(vals)}")
    if any(not (math.isfinite(x) and x >= 0) for x in out.noise):
        raise InputError(f"sweep axis `noise`: expected finite levels >= 0, got {list(out.noise)}")
    if any(k < 1 for k in out.n_modes or ()):
        raise InputError(f"sweep axis `n_modes`: expected integers >= 1, "
                         f"got {list(out.n_modes or ())}")
    if any(s < 0 for s in out.seeds):
        raise InputError(f"sweep axis `seeds`: expected integers >= 0, got {list(out.seeds)}")
    if out.solvers is not None:
        labels = [c.label for c in out.solvers]
        if len(set(labels)) != len(labels):
            raise InputError(f"sweep axis `solvers`: a label is listed twice: {labels}")
    return out


def plan_sweep(paths, *, cache_dir=None, engine=None, **axes) -> tuple[dict, list[SweepTask]]:
    """Validate the scenario files and list their tasks in table order.

    Returns ``({name: Scenario}, tasks)``; ``axes`` are :func:`sweep_axes` replacements.
    Raises :class:`ScenarioFileError` / :class:`InputError` on bad input, before any work,
    a mode count included that no POD method of the scenario can use on a structure (more
    than its sensors, its training records' samples, or, for MDS and ML, their training
    cases: :func:`~podbench.harness.runner.check_modes`).
    """
    scenarios: dict[str, Scenario] = {}
    tasks: list[SweepTask] = []
    cache = None if cache_dir is None else str(Path(cache_dir).resolve())
    for p in paths:
        sc = load_scenario(p)
        if sc.name in scenarios:
            raise ScenarioFileError(f"{p}: a second scenario named {sc.name!r}")
        scenarios[sc.name] = sc
        ax = sweep_axes(sc, **axes)
        loaded: dict = {}
        for i, entry in enumerate(sc.structures):
            # unknown names, bad structure files and excitations fail here, in the parent
            structure = resolve_structure(entry, sc, field=f"scenario.structures[{i}]")
            check_cases(sc, structure, loaded)
            for k in ax.n_modes or ():  # more modes than the sensors or training sets hold
                axis = "--n-modes" if axes.get("n_modes") is not None else "sweep.n_modes"
                check_modes(apply_overrides(sc, n_modes=k, coupled_train=ax.coupled_train),
                            structure, source=f"sweep axis `{axis}` = {k}")
            for level in ax.noise:
                for k in ax.n_modes or (None,):
                    for seed in ax.seeds:
                        tasks.append(SweepTask(
                            index=len(tasks), scenario_path=str(sc.path), digest=sc.digest,
                            structure=entry, noise=level, modes=k, seed=seed,
                            solvers=ax.solvers, noise_on=ax.noise_on,
                            coupled_train=ax.coupled_train, cache_dir=cache, engine=engine,
                            first_seed=ax.seeds[0], noise_model=ax.noise_model,
                            force_offset=ax.force_offset, force_drift=ax.force_drift))
    return scenarios, tasks


def _computed(task: SweepTask) -> bool:
    """Whether the task is computed (a noise-free point only for the first seed; an offset
    or drift is deterministic, so a level-0 point with one is noise-free too)."""
    return task.noise > 0 or task.seed == task.first_seed


def _noise_free_source(task: SweepTask) -> tuple:
    return (task.scenario_path, task.structure, task.modes)


def run_task(task: SweepTask) -> dict:
    """Run one sweep point; returns ``{"index", "rows", "seconds", "simulated", "cached"}``
    with rows carrying :data:`SWEEP_COLUMNS`."""
    t0 = time.perf_counter()
    sc = load_scenario(task.scenario_path)
    if sc.digest != task.digest:
        raise ScenarioFileError(
            f"{task.scenario_path}: this file differs from the one the sweep was planned with "
            "(edited during the run, or a Dask worker with another checkout)")
    overrides = {"n_modes": task.modes, "solvers": task.solvers,
                 "coupled_train": task.coupled_train}
    noise = NoiseSpec(level=float(task.noise), seed=int(task.seed), on=tuple(task.noise_on),
                      model=task.noise_model, force_offset=float(task.force_offset),
                      force_drift=float(task.force_drift))
    res = run_unit(task.scenario_path, task.structure, task.cache_dir, task.engine, False,
                   overrides=overrides, noise=noise)
    modes = -1 if task.modes is None else int(task.modes)
    rows = [{**r, "noise": float(task.noise), "modes": modes, "seed": int(task.seed)}
            for r in res.rows]
    return {"index": task.index, "rows": rows, "seconds": time.perf_counter() - t0,
            "simulated": res.simulated, "cached": res.cached,
            "simulated_keys": res.simulated_keys, "cached_keys": res.cached_keys}


def run_sweep(paths, *, jobs: int | str = 1, scheduler: str | None = None, cache_dir=None,
              engine: str | None = None, progress=None, connect_timeout: float = 10.0,
              **axes) -> tuple[dict, pd.DataFrame]:
    """Run the sweeps of the scenario files ``paths``.

    Parameters
    ----------
    jobs : int or "auto"
        Local processes, the calling one included, or ``"auto"`` (the cores available):
        :func:`podbench.harness.executor.execute`; ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:8786``): every task runs on
        its workers (module docstring: what the workers need).
    cache_dir : path, optional
        Truth-data cache folder (made absolute for the workers).
    progress : Progress or callable, optional
        A :class:`~podbench.harness.progress.Progress` (a bar or plain lines), or a callable
        given one line per finished task.
    connect_timeout : float
        Seconds to wait for the scheduler.
    **axes
        ``noise``, ``n_modes``, ``seeds``, ``solvers``: replace the files' axes.

    Returns
    -------
    ({name: Scenario}, DataFrame)
        The scenarios and the table of :func:`sweep_table`.
    """
    resolve_jobs(jobs)  # InputError before the planning
    scenarios, tasks = plan_sweep(paths, cache_dir=cache_dir, engine=engine, **axes)
    todo = [t for t in tasks if _computed(t)]
    names = {t.index: t for t in todo}
    stage = as_stage(progress, "sweep points", len(todo), "point")

    def report(done, total, elapsed, out):
        t = names[out["index"]]
        k = "own" if t.modes is None else t.modes
        stage.advance(f"{Path(t.scenario_path).stem} × {t.structure}",
                      f"noise {t.noise:g}, k {k}, seed {t.seed}: {out['seconds']:.1f} s")

    with stage:
        outs = execute(run_task, todo, jobs=jobs, scheduler=scheduler, progress=report,
                       connect_timeout=connect_timeout)
    results = {t.index: out for t, out in zip(todo, outs, strict=True)}
    # table order; a noise-free point's rows are repeated for every seed
    source = {_noise_free_source(t): t.index for t in todo if t.noise == 0}
    rows: list[dict] = []
    for t in tasks:
        i = t.index if _computed(t) else source[_noise_free_source(t)]
        rows.extend({**r, "seed": int(t.seed)} for r in results[i]["rows"])
    df = sweep_table(rows)
    # distinct responses: one simulated by a point and read again by another is not a hit
    simulated = {k for o in results.values() for k in o.get("simulated_keys", ())}
    cached = {k for o in results.values() for k in o.get("cached_keys", ())} - simulated
    df.attrs["simulated"] = len(simulated)
    df.attrs["cached"] = len(cached)
    df.attrs["tasks"] = len(todo)
    return scenarios, df


def sweep_table(rows) -> pd.DataFrame:
    """The rows as a DataFrame with :data:`SWEEP_COLUMNS` in order; round-off errors written
    as 0 (:func:`~podbench.harness.metrics.roundoff_errors`), as in ``summary.csv``."""
    df = roundoff_errors(pd.DataFrame(rows, columns=list(SWEEP_COLUMNS)))
    for c in ("n_modes", "modes", "seed"):
        df[c] = df[c].astype(int)
    df["noise"] = df["noise"].astype(float)
    df["solver"] = df["solver"].fillna("").astype(str)
    return df


