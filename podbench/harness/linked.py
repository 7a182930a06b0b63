"""Run a claims file's linked sensitivity study (``sensitivity = "../sensitivity"``) beside
the study itself, with the same cache and code (:mod:`podbench.study.sensitivity` judges
its verdicts)."""

from __future__ import annotations

from pathlib import Path

from podbench.harness.runner import run_study
from podbench.harness.tables import summary_table
from podbench.study.scenarios import find_scenarios, load_scenario
from podbench.study.sensitivity import sensitivity_verdicts


def linked_scenarios(claims_file, scenarios: dict) -> dict:
    """Scenario file → scenario, for the scenarios of the claims file's ``sensitivity``
    folder that derive from the ``scenarios`` of this run and vary their structures (empty
    without such a folder or such scenarios)."""
    if claims_file.sensitivity is None:
        return {}
    here = {Path(sc.path).resolve() for sc in scenarios.values()}
    derived = {}
    for f in find_scenarios([claims_file.sensitivity]):
        sc = load_scenario(f)
        if sc.base is not None and Path(sc.base).resolve() in here and sc.variants:
            derived[f] = sc
    return derived


def run_linked(claims_file, scenarios: dict, *, jobs: int = 1, cache_dir=None,
               engine: str | None = None, progress=None) -> list[dict] | None:
    """Run the scenarios of the claims file's ``sensitivity`` folder that derive from the
    ``scenarios`` of this run (:func:`linked_scenarios`), and judge the claims on their
    variants (the same computation as ``podbench run`` of that folder, so both FINDINGS
    agree). None without such a folder or such scenarios."""
    linked = linked_scenarios(claims_file, scenarios)
    if not linked:
        return None
    files, derived = list(linked), {sc.name: sc for sc in linked.values()}
    results = run_study(files, jobs=jobs, cache_dir=cache_dir, engine=engine,
                        progress=progress, keep_series=False)
    return sensitivity_verdicts(claims_file.claims, derived, summary_table(results),
                                claims_file.bounds)
