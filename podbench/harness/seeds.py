"""A study's claims on other noise seeds: the rows every check reads, refitted on each seed.

A virtual experiment's noisy records are one realization of the noise (the experiment
file's ``noise_seed``). A claims file with ``noise_seeds = [0, 1, 2, 3, 4]`` has every check
judged on each seed (:mod:`podbench.study.claims`: holds on all, fails on all, else a tie).
The first seed's rows are the study's table (the committed records); for the others this
module regenerates the records the checks read from the same experiment file with the noise
(and any strike scatter) redrawn (:func:`podbench.study.experiments.generate_seeds`, in
memory) and refits only the methods the checks name, predicting only the targets they read,
with the coupled twin where a check reads the diagonalization error; no bands, no linear
twins, no figures. A scenario whose records no seed changes is not refitted.

The rows (``seeds.csv`` of the study's output) are those of ``summary.csv`` for the checks'
(scenario, structure, method, target), with a ``seed`` column, on every seed (the first
seed's copied from the study's table).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from podbench.core.response import Response
from podbench.errors import PodbenchError, ScenarioFileError
from podbench.harness.digits import estimator_writer
from podbench.harness.executor import execute
from podbench.harness.metrics import ERROR_COLUMNS, NORM_COLUMNS, decompose, norm_summaries
from podbench.harness.progress import as_stage
from podbench.harness.runner import fit_method, read_case
from podbench.study.claims import SeedRows, checked_rows, seed_names
from podbench.study.estimators import all_cases
from podbench.study.experiments import (
    generate_seeds,
    level_folder,
    load_experiment,
    seed_dependent,
)
from podbench.study.resolve import resolve_structure
from podbench.study.scenarios import EXPERIMENT_FILE, load_scenario
from podbench.sysid.conditioning import condition

__all__ = ["run_seeds", "plan_seeds", "seed_unit", "SeedPlan", "seed_table", "SEED_COLUMNS",
           "task_arrays"]

SEED_COLUMNS = ("scenario", "structure", "method", "target", "seed", *ERROR_COLUMNS,
                *NORM_COLUMNS, "status")
"""Columns of ``seeds.csv`` in order."""

_EXPECTED = (PodbenchError, np.linalg.LinAlgError)


def _record_key(exp, scenario, case: str):
    """``(test, level folder, case stem)`` of a case's record file when the experiment
    writes it (``data/<test>/noise_<p>pct/<case>.npz`` beside the experiment file), else
    None."""
    f = scenario.cases[case].file
    if f is None:
        return None
    path = Path(f)
    path = (path if path.is_absolute() else scenario.folder / path).resolve()
    try:
        rel = path.relative_to((exp.folder / "data").resolve())
    except ValueError:
        return None
    if len(rel.parts) != 3 or rel.suffix != ".npz" or rel.parts[0] not in exp.tests:
        return None
    return rel.parts[0], rel.parts[1], rel.stem


def _varied(exp, scenario, cases) -> dict | None:
    """``case → (test, level folder, case stem)`` of a scenario whose records the seed
    changes (a noisy level, or strike scatter), None for one it does not change."""
    keys = {c: _record_key(exp, scenario, c) for c in cases}
    levels = {level_folder(lv): lv for t in exp.tests.values()
              for lv in (t.noise_levels or exp.noise_levels)}
    if not any(k is not None and k[1] in levels
               and seed_dependent(exp.tests[k[0]], levels[k[1]]) for k in keys.values()):
        return None
    return keys


@dataclass
class SeedPlan:
    """The refits of :func:`run_seeds`, planned: ``tasks`` for :func:`seed_unit` (run them
    anywhere, e.g. in the study's pool: :class:`podbench.harness.runner.SideTasks`), then
    :meth:`rows` of their results."""

    seeds: tuple
    tasks: list
    varied: frozenset

    def rows(self, results) -> SeedRows:
        """The :class:`SeedRows` of the tasks' results (in task order)."""
        table = pd.DataFrame([r for unit in results for r in unit], columns=list(SEED_COLUMNS))
        return SeedRows(self.seeds, table, self.varied)


def plan_seeds(claims_file, claims, scenarios: dict) -> SeedPlan | None:
    """The tasks of :func:`run_seeds` (None without ``noise_seeds`` or without a check
    among the claims of ``scenarios``): the records of the other seeds generated from the
    experiment file beside the claims file (in this process, except those of tests whose
    strikes scatter with the seed: each task generates its own, :func:`task_arrays`), one
    task per (scenario, structure, seed)."""
    seeds = tuple(claims_file.noise_seeds)
    if not seeds:
        return None
    folder = Path(claims_file.path).parent
    if not (folder / EXPERIMENT_FILE).is_file():
        raise ScenarioFileError(f"{claims_file.path}: field `noise_seeds`: needs the "
                                f"virtual experiment's {EXPERIMENT_FILE} beside it (the "
                                "records of the other seeds are generated from it)")
    exp = load_experiment(folder)
    if exp.noise_seed != seeds[0]:
        raise ScenarioFileError(f"{claims_file.path}: field `noise_seeds`: the first seed must "
                                f"be the committed records' ({EXPERIMENT_FILE}'s noise_seed "
                                f"= {exp.noise_seed}), got {seeds[0]}")
    checked = checked_rows(claims, set(scenarios))
    if not checked:  # no check judged in this run (a part of the study)
        return None
    units, wanted, varied = [], set(), set()
    for (name, structure), (methods, targets, twinned) in checked.items():
        sc = scenarios.get(name)
        if sc is None:
            continue
        methods = tuple(m for m in methods if any(s.label == m for s in sc.methods))
        cases = set(targets)
        for label in methods:
            spec = sc.method(label)
            cases |= all_cases(spec, sc.method)
            if label in twinned and spec.twin:
                cases |= all_cases(sc.method(spec.twin), sc.method)
        keys = _varied(exp, sc, sorted(cases))
        if keys is None or not methods:
            continue
        varied.add(name)
        wanted |= {k[:2] for k in keys.values() if k is not None}
        units += [(str(sc.path), structure, k, methods, targets, twinned, keys)
                  for k in seeds[1:]]
    # records whose strikes scatter with the seed (one simulation per strike and seed) are
    # generated in their tasks, in parallel; the others (one simulation shared by every
    # seed, then only noise) here, once
    scattered = {w for w in wanted if _scatters(exp.tests[w[0]])}
    records = generate_seeds(exp, seeds[1:], wanted - scattered) if units else {}
    args = [(*u, {c: _arrays(records[(u[2], *key)]) for c, key in u[6].items()
                  if key is not None and key[:2] not in scattered},
             (str(folder), tuple(sorted({k[:2] for k in u[6].values()
                                         if k is not None and k[:2] in scattered}))))
            for u in units]
    return SeedPlan(seeds, args, frozenset(varied))


def _scatters(test) -> bool:
    """Whether a test's strikes (hence its clean simulations) change with the seed."""
    return test.amplitude_scatter > 0 or test.hit_jitter > 0


def task_arrays(task) -> dict:
    """``case → (W, F)`` of a task of :func:`plan_seeds`: the records generated in the plan,
    with those of the scattered tests generated here (the same bytes as generated in the
    plan: the draws are keyed by seed, experiment, structure and case; two tasks reading
    the same strikes through another load cell record simulate them each, as keeping the
    simulations across tasks would hold the DOF histories of every strike in memory)."""
    seed, keys, arrays = task[2], task[6], task[7]
    folder, scattered = task[8] if len(task) > 8 else ("", ())  # a task without any
    if not scattered:
        return arrays
    records = generate_seeds(load_experiment(folder), [seed], set(scattered))
    return {**arrays, **{c: _arrays(records[(seed, *key)]) for c, key in keys.items()
                         if key is not None and key[:2] in scattered}}


def run_seeds(claims_file, claims, scenarios: dict, *, jobs: int = 1,
              progress=None) -> SeedRows | None:
    """The checked rows on every seed of ``claims_file.noise_seeds`` (None without them, or
    without a check among the claims of ``scenarios``): the records of the other seeds
    generated from the experiment file beside the claims file, the checked methods refitted
    on them (``jobs`` processes; :func:`plan_seeds`)."""
    sp = plan_seeds(claims_file, claims, scenarios)
    if sp is None:
        return None
    stage = as_stage(progress, f"checks over noise {seed_names(sp.seeds)}",
                     len(sp.tasks), "unit")
    with stage:
        rows = execute(seed_unit, sp.tasks, jobs=jobs,
                       progress=lambda *_: stage.advance())
    return sp.rows(rows)


def _arrays(rec: Response) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(rec.W, dtype=float), np.asarray(rec.F, dtype=float)


def _response(scenario, structure, case: str, arrays) -> Response:
    """A generated record as :func:`podbench.harness.runner.read_case` reads a file."""
    W, F = arrays
    n = W.shape[1]
    return Response(t=np.arange(n) * scenario.dt, W=W, F=F, w0=W[:, 0].copy(),
                    v0=np.zeros(W.shape[0]), dt=scenario.dt, structure=structure.name,
                    engine="measured", label=case)


def seed_unit(task) -> list[dict]:
    """One (scenario, structure, seed): fit the checked methods on the seed's records (and
    their coupled twins where a check reads the diagonalization error), predict the checked
    targets; rows of :data:`SEED_COLUMNS`."""
    path, entry, seed, methods, targets, twinned, keys = task[:7]
    arrays = task_arrays(task)
    sc = load_scenario(path)
    structure = resolve_structure(entry, sc)
    recs: dict = {}

    def get(case: str) -> Response:
        if case not in recs:
            recs[case] = (_response(sc, structure, case, arrays[case]) if case in arrays
                          else read_case(sc, case, structure))
        return recs[case]

    def train(case: str) -> Response:
        r = get(case)
        return condition(r, sc.conditioning) if _conditioned(sc) else r

    rows = []
    for label in methods:
        base = {"scenario": sc.name, "structure": structure.name, "method": label,
                "seed": int(seed)}
        rows += _method_rows(sc, label, base, targets, get, train, label in twinned)
    return rows


def _conditioned(sc) -> bool:
    return sc.conditioning is not None and not sc.conditioning.is_identity


def _failed(exc: BaseException) -> str:
    return "failed: " + " ".join(f"{type(exc).__name__}: {exc}".split())[:290]


def _twin(sc, spec, est, U, targets, get, train):
    """``(predictions, status)`` of the coupled twin fitted in the method's basis ``U``
    (the method's own for a coupled method; None without a twin)."""
    if bool(getattr(est, "coupled", False)) or not spec.twin or U is None:
        return None, "ok"
    try:
        tw = fit_method(sc.method(spec.twin), sc, train,
                        sc.conditioning if _conditioned(sc) else None, basis=U)
        return {t: np.asarray(tw.predict(get(t)), dtype=float) for t in targets}, "ok"
    except _EXPECTED as exc:
        return None, "twin " + _failed(exc)


def _method_rows(sc, label: str, base: dict, targets, get, train, twinned=False) -> list[dict]:
    """The rows of one method: fitted on ``train``'s records, each target predicted (with
    its coupled twin's prediction when ``twinned``)."""
    try:
        spec = sc.method(label)
        est = fit_method(spec, sc, train, sc.conditioning if _conditioned(sc) else None)
        preds = {t: np.asarray(est.predict(get(t)), dtype=float) for t in targets}
    except KeyError:
        status = f"failed: no method {label!r} in the scenario"
        return [{**base, "target": t, "status": status} for t in targets]
    except _EXPECTED as exc:
        return [{**base, "target": t, "status": _failed(exc)} for t in targets]
    U = getattr(est, "modes_", None)
    U = None if U is None else np.asarray(U, dtype=float)
    coupled = bool(getattr(est, "coupled", False))
    twin, status = _twin(sc, spec, est, U, targets, get, train) if twinned else (None, "ok")
    written = estimator_writer(est)
    rows = []
    for t in targets:
        W = get(t).W
        row = {**base, "target": t}
        row.update(decompose(W, preds[t], U, coupled=coupled, nonlinear=True,
                             W_twin=None if twin is None else twin[t]))
        row.update(norm_summaries(W, preds[t]))
        row["status"] = status
        rows.append(row if written is None else written(row))
    return rows


def seed_table(table: pd.DataFrame, seeds: SeedRows | None) -> pd.DataFrame | None:
    """``seeds.csv``: the checked rows on every seed — the first seed's from the study's
    ``table`` (the same (scenario, structure, method, target) as the other seeds' rows),
    then the others' — sorted by scenario, structure, method, target and seed."""
    if seeds is None or seeds.table.empty:
        return None
    other = seeds.table
    keys = other[["scenario", "structure", "method", "target"]].drop_duplicates()
    first = table.merge(keys, on=["scenario", "structure", "method", "target"])
    first = first.assign(seed=seeds.seeds[0])
    both = pd.concat([first[[c for c in SEED_COLUMNS if c in first.columns]], other],
                     ignore_index=True)
    order = {k: i for i, k in enumerate(seeds.seeds)}
    both = both.assign(_o=both.seed.map(order)).sort_values(
        ["scenario", "structure", "method", "target", "_o"], kind="stable")
    return both.drop(columns="_o").reset_index(drop=True)[list(SEED_COLUMNS)]
