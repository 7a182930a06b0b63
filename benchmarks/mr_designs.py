"""MR over all admissible designs (issue 11 item 3): the summary of
``scenarios/mr_designs/beam_mixed_designs.toml``.

For each structure: the rule ``κ`` (:func:`podbench.methods.mixed_design.design_conditioning`,
training records only) of each of the 60 designs, MR's relative error ``‖W − Ŵ‖_F / ‖W‖_F``
on each target, and the median and quartiles over the admissible designs beside the design
the rule picks on that structure (smallest ``κ``), the Chapter 4 design (the pick on the LTI
beam, impulses 3, 19, 11 in) and podbench's former design (19, 11, 3 in)::

    PYTHONPATH=. python benchmarks/mr_designs.py [--cache DIR] [--structures lti_beam ...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from podbench import errors
from podbench.harness.cache import TruthCache
from podbench.harness.runner import _Truth
from podbench.study.resolve import resolve_structure
from podbench.study.scenarios import load_scenario
from podbench.sysid.methods import MixedResponse
from podbench.sysid.methods.mixed_design import design_conditioning

SCENARIO = (Path(__file__).resolve().parents[1] / "scenarios" / "mr_designs"
            / "beam_mixed_designs.toml")
OLD = "MR 19 11 3"
CH4 = "MR 3 19 11"  # the rule's pick on the LTI beam (the profiles' reference): Chapter 4's
SCALINGS = ("finite_difference", "ratio")


def rel_err(W, W_hat) -> float:
    return float(np.linalg.norm(W - W_hat) / np.linalg.norm(W))


def study(structure: str, cache_dir=None, scenario_path=SCENARIO) -> dict:
    """Rule value, admissibility and errors (per velocity scaling) of every design.

    Returns
    -------
    dict
        ``{label: {"kappa": κ, "admissible": bool, "train": (a, b, c),
        "errors": {scaling: {target: error or NaN}}, "status": str}}``
    """
    sc = load_scenario(scenario_path)
    truth = _Truth(sc, resolve_structure(structure, sc), TruthCache(cache_dir), sc.engine)
    out = {}
    for spec in sc.methods:
        recs = [truth.train(c) for c in spec.train]
        cond = design_conditioning(recs, spec.n_modes)
        row = {"kappa": cond.value, "admissible": cond.admissible, "train": spec.train,
               "errors": {}, "status": "ok"}
        for scaling in SCALINGS:
            errs = dict.fromkeys(sc.targets, float("nan"))
            try:
                model = MixedResponse(n_modes=spec.n_modes, velocity_scaling=scaling,
                                      **dict(spec.options)).fit(recs)
                for t in sc.targets:
                    tr = truth.get(t)
                    errs[t] = rel_err(tr.W, model.predict(tr))
            except errors.PodbenchError as exc:
                row["status"] = f"{scaling}: {exc}"
            row["errors"][scaling] = errs
        out[spec.label] = row
    return out


def summary(rows: dict, targets, scaling="finite_difference") -> str:
    adm = {k: r for k, r in rows.items() if r["admissible"]}
    chosen = min(adm, key=lambda k: adm[k]["kappa"])
    rank_old = sorted(rows, key=lambda k: rows[k]["kappa"]).index(OLD) + 1
    lines = [f"  {len(adm)}/{len(rows)} admissible; rule picks {chosen!r} "
             f"(κ = {rows[chosen]['kappa']:.3g}); old {OLD!r} κ = {rows[OLD]['kappa']:.3g}, "
             f"rank {rank_old}/{len(rows)}",
             f"  {'target':10s} {'q25':>8s} {'median':>8s} {'q75':>8s} "
             f"{'chosen':>8s} {'ch4':>8s} {'old':>8s}   ({scaling}; ch4 = {CH4!r})"]
    for t in targets:
        e = np.array([r["errors"][scaling][t] for r in adm.values()])
        q = np.nanpercentile(e, [25, 50, 75])
        lines.append(f"  {t:10s} {q[0]:8.3g} {q[1]:8.3g} {q[2]:8.3g} "
                     f"{rows[chosen]['errors'][scaling][t]:8.3g} "
                     f"{rows[CH4]['errors'][scaling][t]:8.3g} "
                     f"{rows[OLD]['errors'][scaling][t]:8.3g}")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cache", default=None)
    p.add_argument("--structures", nargs="*", default=None)
    a = p.parse_args(argv)
    sc = load_scenario(SCENARIO)
    for s in a.structures or sc.structures:
        rows = study(s, a.cache)
        print(s)
        for scaling in SCALINGS:
            print(summary(rows, sc.targets, scaling))


if __name__ == "__main__":
    main()
