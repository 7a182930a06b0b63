"""Verdicts as a function of a parameter the text does not state.

A *derived* scenario (``scenario.base``) runs the cases and methods of a study's scenario on
*variants* of its structures (``[variants.<name>]``: a structure file with some fields
replaced). When every scenario of a run is derived from scenarios of one folder that has a
``claims.toml``, each of those claims that names a varied structure is judged again on every
variant, and ``FINDINGS.md`` says over which values of the parameter it holds (where the
text is silent, the verdict as a function of the parameter over a stated range, not one
pick). The unstated noise level of a virtual experiment is judged the same way
(:func:`noise_verdicts`).

``scenarios/sensitivity`` applies this to Chapter 4: the LTV beam over the mean tip mass
(Fig. 4.3 is not in the text) and the NL beam over the cubic spring's calibration (Fig. 4.2).

Where the claims file bounds a varied structure by the text's words (``[[bounds]]``, see
:mod:`podbench.study.bounds`), each point also says whether the words admit it, and the
verdict is summarised over the admitted values (:func:`bounded_summary`). The same summary
is linked from the base study's ``FINDINGS.md`` (:func:`linked_verdicts`).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import pandas as pd

from podbench.study.bounds import bound_for, evaluate_bounds
from podbench.study.claims import Verdict, check, combine, evaluate_claims, noise_points
from podbench.study.nonlinearity import NonlinearitySpec, zeta_words
from podbench.study.scenarios import CLAIMS_FILE

__all__ = ["base_claims_path", "sensitivity_verdicts", "sensitivity_markdown",
           "bounded_summary", "linked_verdicts", "noise_verdicts", "swept_verdicts"]


def base_claims_path(scenarios: dict) -> Path | None:
    """The ``claims.toml`` of the folder every scenario's ``base`` lies in, when all of them
    are derived from one such folder; else None."""
    folders = {sc.base.parent for sc in scenarios.values() if sc.base is not None}
    if not scenarios or len(folders) != 1 or any(sc.base is None for sc in scenarios.values()):
        return None
    path = next(iter(folders)) / CLAIMS_FILE
    return path if path.is_file() else None


def _parameter(variant) -> tuple[str, object]:
    """The variant's parameter: the first field it sets (the others follow it)."""
    key = next(iter(variant.set))
    return key, variant.set[key]


def sensitivity_verdicts(claims, scenarios: dict, table, bounds=()) -> list[dict]:
    """Every claim on a base scenario that names a varied structure, judged on each variant.

    Returns one dict per (claim, derived scenario): ``claim``, ``scenario`` (the derived
    one), ``structure`` (the varied base structure), ``parameter`` (dotted field),
    ``bound`` (the :class:`~podbench.study.bounds.Bound` of that structure, or None) and
    ``points``: a list of ``{"variant", "value", "set", "verdict", "details"}`` in the order
    of the scenario's ``structures``, with ``"measure"`` (the bound's statistics and
    ``admitted`` / ``admitted_alternative`` flags) when the structure is bounded.
    """
    base_names = {name: Path(sc.base).stem for name, sc in scenarios.items()}
    measured: dict = {}  # (scenario, structure) -> evaluate_bounds(...)
    out = []
    for c in claims:
        for name, sc in scenarios.items():
            if base_names[name] != c.scenario:
                continue
            variants = [sc.variants[s] for s in sc.structures if s in sc.variants
                        and sc.variants[s].structure in c.structures]
            if not variants:
                continue
            points = []
            for v in variants:
                derived = dataclasses.replace(c, scenario=name, structures=(v.name,))
                e = evaluate_claims([derived], table)[0]
                key, value = _parameter(v)
                points.append({"variant": v.name, "value": value, "set": dict(v.set),
                               "verdict": e.verdict, "details": e.details})
            structure = variants[0].structure
            bound = bound_for(bounds, structure)
            if bound is not None:
                bkey = (name, structure)
                if bkey not in measured:
                    measured[bkey] = evaluate_bounds(bound, sc, [v.name for v in variants])
                for p in points:
                    p["measure"] = measured[bkey]["points"][p["variant"]]
            out.append({"claim": c, "scenario": name, "structure": structure,
                        "parameter": _parameter(variants[0])[0], "bound": bound,
                        "reference": measured[(name, structure)]["reference"]
                        if bound is not None else None, "points": points})
    return out


def _ranges(points, want: bool = True) -> str:
    """The parameter values at which the claim holds (``want`` False: fails), as runs of
    consecutive points ("0.02–0.1, 1"), or "nowhere" / "everywhere"."""
    held = [(p["verdict"] == "reproduced") == want for p in points]
    if not points:
        return "nowhere"
    if all(held):
        return f"everywhere ({points[0]['value']:g}–{points[-1]['value']:g})"
    if not any(held):
        return "nowhere"
    runs, start = [], None
    for i, h in enumerate(held + [False]):
        if h and start is None:
            start = i
        elif not h and start is not None:
            a, b = points[start]["value"], points[i - 1]["value"]
            runs.append(f"{a:g}" if start == i - 1 else f"{a:g}–{b:g}")
            start = None
    return ", ".join(runs)


def _span(points) -> str:
    a, b = points[0]["value"], points[-1]["value"]
    return f"{a:g}" if len(points) == 1 else f"{a:g}–{b:g}"


def bounded_summary(v, alternative: bool = False) -> tuple[str, str]:
    """``(kind, text)`` of one sensitivity verdict over the values the text admits.

    ``kind``: "holds over the text's range", "fails over the text's range" or "depends on
    an unstated parameter" (without a bound: over the whole studied range, and the text
    says so). ``alternative``: use the bound's alternative reading."""
    pts, param = v["points"], f"{v['structure']} `{v['parameter']}`"
    bound = v.get("bound")
    if bound is not None:
        flag = "admitted_alternative" if alternative else "admitted"
        adm = [p for p in pts if p["measure"][flag]]
        where = (f"{param} {_span(adm)}, the values the text admits"
                 if adm else f"no value of {param} the text admits")
        scope = "the text's range"
    else:
        adm = pts
        where = f"{param} {_span(pts)}, the studied range (the text gives no bound)"
        scope = "the studied range"
    if not adm:
        return "not measured", where
    held = [p["verdict"] == "reproduced" for p in adm]
    if all(held):
        return f"holds over {scope}", f"holds at every value of {where}"
    if not any(held):
        return f"fails over {scope}", f"fails at every value of {where}"
    return ("depends on an unstated parameter",
            f"holds at {_ranges(adm)}, fails at {_ranges(adm, False)} of {where}")


def linked_verdicts(verdicts) -> dict:
    """``claim id -> [(kind, text, scenario)]``: the sensitivity summaries of each claim,
    for the base study's ``FINDINGS.md``."""
    out: dict = {}
    for v in verdicts:
        kind, text = bounded_summary(v)
        out.setdefault(v["claim"].id, []).append((kind, text, v["scenario"]))
    return out


def bounds_markdown(verdicts) -> str:
    """The section on the bounds: the reading, and the measure at every variant."""
    seen, out = set(), []
    for v in verdicts:  # one section per bounded structure, measured on its first scenario
        b = v.get("bound")
        if b is None or b.structure in seen:
            continue
        seen.add(b.structure)
        ref = v["reference"]
        out.append(f"\n## The text's bound on `{v['parameter']}` ({b.structure})\n\n"
                   f"*{b.source}*: “{b.quote}”\n\n{b.reading.strip()}\n\n"
                   f"Measure `{b.measure}` over the record of {v['scenario']}; reference "
                   f"{b.reference}: {ref[b.statistic]:.3g}. A value is admitted when the "
                   f"{b.statistic} of the measure exceeds the reference's (the alternative "
                   f"reading: the {b.alternative}).\n\n"
                   f"| `{v['parameter']}` | variant | mean | min | max | admitted "
                   f"({b.statistic}) | admitted ({b.alternative}) |\n"
                   "|---|---|---|---|---|---|---|\n")
        for p in v["points"]:
            m = p["measure"]
            out.append(f"| {p['value']:g} | {p['variant']} | {m['mean']:.3g} | {m['min']:.3g} "
                       f"| {m['max']:.3g} | {'yes' if m['admitted'] else 'no'} | "
                       f"{'yes' if m['admitted_alternative'] else 'no'} |\n")
    return "".join(out)


def sensitivity_markdown(verdicts, claims_path) -> str:
    """``FINDINGS.md`` of a sensitivity study: per claim, the verdict at every value."""
    try:
        shown = os.path.relpath(claims_path)
    except ValueError:  # pragma: no cover - another drive on Windows
        shown = str(claims_path)
    out = ["# Findings as a function of the unstated parameters\n\n",
           f"Generated by `podbench run` from the claims of `{shown}`, each judged again on "
           "every variant of the structure it names (the same checks and thresholds; see "
           "that file). A claim *holds* at a value when it is reproduced there.\n\n",
           "Where the claims file bounds the parameter by the text's words (`[[bounds]]`, "
           "sections below the table), the last columns give the verdict over the values the "
           "text admits, under the headline reading and under the alternative one.\n\n",
           "| claim | source | structure | parameter | holds at | over the text's range | "
           "alternative reading |\n|---|---|---|---|---|---|---|\n"]
    for v in verdicts:
        c = v["claim"]
        alt = bounded_summary(v, alternative=True)[1] if v.get("bound") is not None else "—"
        out.append(f"| [{c.id}](#{c.id}--{v['scenario']}) | {c.source} | {v['structure']} | "
                   f"`{v['parameter']}` | {_ranges(v['points'])} | {bounded_summary(v)[1]} | "
                   f"{alt} |\n")
    out.append(bounds_markdown(verdicts))
    for v in verdicts:
        c = v["claim"]
        out.append(f"\n### {c.id} · {v['scenario']}\n\n*{c.source}*: “{c.quote}”\n\n")
        if c.criterion:
            out.append(f"Criterion: {c.criterion}.\n\n")
        out.append(f"Over the text's range: {bounded_summary(v)[1]}.\n\n")
        bounded = v.get("bound") is not None
        extra = " admitted |" if bounded else ""
        out.append(f"| `{v['parameter']}` | variant | verdict |{extra} checks |\n"
                   f"|---|---|---|{'---|' if bounded else ''}---|\n")
        for p in v["points"]:
            checks = "; ".join(f"{d.target}: {d.shown}" for d in p["details"])
            adm = (f" {'yes' if p['measure']['admitted'] else 'no'} |" if bounded else "")
            out.append(f"| {p['value']:g} | {p['variant']} | {p['verdict']} |{adm} {checks} |\n")
    return "".join(out)


def swept_verdicts(claims, table: pd.DataFrame, spec: NonlinearitySpec) -> dict:
    """``claim id -> [(kind, text, where)]`` for the claims judged on ``spec.name``: each
    claim's checks with ``band`` standing for every swept row, summarized per ζ and per
    kind of offset (slack, pre-stretch; the band's own row is fraction 0 of both) in the
    words of :func:`podbench.study.sensitivity.bounded_summary`."""
    out: dict = {}
    for c in claims:
        if spec.name not in c.all_scenarios():
            continue
        for target in c.targets:
            sub = table[(table.scenario == spec.name) & (table.target == target)]
            if sub.empty:
                continue
            rows = {r["method"]: r for r in sub.to_dict("records")}
            for kind in ("slack", "prestretch"):
                pts = []
                for r in sub.to_dict("records"):
                    if r["kind"] not in ("none", kind):
                        continue
                    oks = [check(expr, {**rows, "band": r})[0] for expr in c.checks]
                    verdict = combine(Verdict.NOT_MEASURED if ok is None else
                                      Verdict.REPRODUCED if ok else Verdict.NOT_REPRODUCED
                                      for ok in oks)
                    pts.append({"value": r["fraction"], "verdict": verdict})
                v = {"points": pts, "structure": f"{spec.structure} ({zeta_words(target)})",
                     "parameter": f"tip_band.{kind} / A"}
                k, text = bounded_summary(v)
                out.setdefault(c.id, []).append((k, text, f"{spec.name}, {target}, {kind}"))
    return out


def _pct(level: float) -> str:
    return f"{100.0 * level:g} %"


def noise_verdicts(evaluated, levels) -> dict:
    """``claim id -> [(kind, text, where)]`` for the claims judged over the noise series of
    ``levels`` (:class:`~podbench.study.claims.NoiseLevels`): the verdict at each level, the
    level where the claim stops holding, and the verdict at the level the text suggests."""
    out: dict = {}
    for e in evaluated:
        pts = noise_points(e, levels)
        if not pts:
            continue
        held = [p["verdict"] == Verdict.REPRODUCED for p in pts]
        span = f"{_pct(pts[0]['value'])}–{_pct(pts[-1]['value'])}"
        at = next((p["verdict"] for p in pts if p["value"] == levels.suggested), None)
        there = ("" if at is None else
                 f"; at {_pct(levels.suggested)}, the level of the {levels.source}'s "
                 f"“{levels.quote}”: {at}")
        if all(held):
            kind, text = "holds over the studied range", f"holds at every level {span}"
        elif not any(held):
            kind, text = "fails over the studied range", f"fails at every level {span}"
        else:
            first = next(i for i, h in enumerate(held) if not h)
            below = (f"holds at {_pct(pts[0]['value'])}–{_pct(pts[first - 1]['value'])}, "
                     if first > 0 else "")
            rest = ", ".join(f"{_pct(p['value'])} {p['verdict']}" for p in pts[first:])
            kind = "depends on the unstated noise level"
            text = (f"{below}stops holding at {_pct(pts[first]['value'])} (over {span}: "
                    f"{rest})")
        scope = ", ".join(e.claim.structures)
        out.setdefault(e.claim.id, []).append((kind, text + there,
                                               f"per-channel noise level, {scope}"))
    return out
