"""The report page's reading aids, from the summary table and the claims' evaluation: the
summary at the top (what was run, how long it took, the best and worst method of each
scenario and structure) and the notes that put a large error in context (which part of
the error decomposition carries it, what the coupled twin reaches, which claims judge it).
They restate the tables in words; nothing is computed that the tables do not hold.
"""

from __future__ import annotations

import html
import math
import re

import pandas as pd

from podbench.report.figures import percent

__all__ = ["OFF_SCALE", "ranking", "summary_rows", "large_errors", "claims_about",
           "run_words", "large_error_html", "best_worst_html"]

OFF_SCALE = 1.0
"""A total error from which a row is marked and explained: 100 % of ‖W‖_F, what a
prediction of no motion at all scores."""

PARTS = (("projection_error", "projection"), ("diagonalization_error", "diagonalization"),
         ("linearization_error", "linearization"), ("residual_error", "residual"))
"""The attributed parts of the decomposition (:mod:`podbench.harness.metrics`)."""

WHY = {
    "projection_error": "the method's {k} POMs cannot represent this target (projection "
                        "{v}): no prediction in their span does better",
    "diagonalization_error": "the diagonal assumption (uncoupled POMs, §3.6) fails on this "
                             "structure (diagonalization {v})",
    "linearization_error": "the structure's nonlinearity (linearization {v}: the coupled "
                           "twin on the structure against the same on its linear twin)",
    "residual_error": "what is left without the diagonal assumption and the nonlinearity "
                      "(residual {v}): dynamics outside the POMs, time variance, "
                      "deconvolution",
}
"""Why a row's error is large, by the part of the decomposition that carries most of it."""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _get(obj, name, default=None):
    """An entry of a claim's evaluation, held as a mapping or as attributes."""
    if isinstance(obj, dict):
        return obj.get(name, default)
    return getattr(obj, name, default)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(float(v))


def _pct(v) -> str:
    return f"{percent(100 * float(v))} %" if _finite(v) else "—"


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", str(text)).strip("-") or "x"


def ranking(sub: pd.DataFrame) -> list[tuple[str, float, int, int]]:
    """The methods of a slice of ``summary.csv``, best first: ``(method, median total
    error over its rows, rows, failed rows)``; a method that failed on every row last."""
    out = []
    for method, rows in sub.groupby("method", sort=False):
        tot = rows["total_error"].astype(float)
        ok = tot[tot.map(math.isfinite)]
        out.append((str(method), float(ok.median()) if len(ok) else math.nan, len(rows),
                    int(len(rows) - len(ok))))
    return sorted(out, key=lambda r: (not math.isfinite(r[1]), r[1] if math.isfinite(r[1])
                                      else 0.0, r[0]))


def summary_rows(df: pd.DataFrame) -> list[dict]:
    """One entry per (scenario, structure): its best and worst method by median total
    error, the rows at or above :data:`OFF_SCALE` and the failed rows."""
    out = []
    for (scenario, structure), sub in df.groupby(["scenario", "structure"], sort=False):
        r = ranking(sub)
        done = [x for x in r if math.isfinite(x[1])]
        out.append({"scenario": scenario, "structure": structure,
                    "targets": int(sub["target"].nunique()),
                    "best": done[0] if done else None,
                    "worst": done[-1] if len(done) > 1 else None,
                    "off": int((sub["total_error"].astype(float) >= OFF_SCALE).sum()),
                    "failed": [x[0] for x in r if x[3]]})
    return out


def claims_about(evaluated, scenario: str, structure: str, method: str) -> list:
    """The claims whose checks read ``method`` on ``structure`` in ``scenario``, as
    ``(id, verdict)``."""
    out = []
    for e in evaluated or ():
        c = _get(e, "claim")
        scen = c.all_scenarios() if hasattr(c, "all_scenarios") else (c.scenario,)
        if scenario not in scen:
            continue
        for d in _get(e, "details", ()):
            if _get(d, "structure") == structure and re.search(
                    rf"(?<![\w.]){re.escape(method)}\.", str(_get(d, "check", ""))):
                out.append((c.id, str(_get(e, "verdict"))))
                break
    return out


def large_errors(sub: pd.DataFrame, scenario=None) -> list[dict]:
    """The (structure, method) groups of a scenario's rows with a total error at or above
    :data:`OFF_SCALE`, with what their decomposition says (the worst row's parts)."""
    big = sub[sub["total_error"].astype(float) >= OFF_SCALE]
    out = []
    for (structure, method), rows in big.groupby(["structure", "method"], sort=False):
        worst = rows.loc[rows["total_error"].astype(float).idxmax()].to_dict()
        parts = {c: float(worst[c]) for c, _ in PARTS if _finite(worst.get(c))}
        twin = None
        if scenario is not None:
            spec = next((m for m in scenario.methods if m.label == method), None)
            twin = getattr(spec, "twin", None)
        out.append({"structure": structure, "method": method, "row": worst, "twin": twin,
                    "targets": [(r["target"], float(r["total_error"]))
                                for r in rows.to_dict("records")],
                    "main": max(parts, key=parts.get) if parts else None})
    return out


def _why(item: dict) -> str:
    """The sentence that says where a large error comes from."""
    r = item["row"]
    if item["main"] is not None:
        text = "Mostly " + WHY[item["main"]].format(k=r.get("n_modes"), v=_pct(r[item["main"]]))
        if item["main"] == "diagonalization_error" and _finite(r.get("twin_error")):
            twin = f" {_e(item['twin'])}" if item["twin"] else ""
            text += (f"; its coupled twin{twin}, fitted in the same POMs, reaches "
                     f"{_pct(r['twin_error'])}")
        return text
    if not _finite(r.get("projection_error")):
        return ("No decomposition: the method has no POD basis (or failed), so only its "
                "total is measured")
    if _finite(r.get("twin_error")):
        return (f"Its coupled twin does worse ({_pct(r['twin_error'])}), so the parts are "
                f"not attributed; the error lies inside the POMs (subspace "
                f"{_pct(r.get('subspace_error'))}, projection {_pct(r['projection_error'])})")
    return (f"No coupled twin to attribute it to: subspace {_pct(r.get('subspace_error'))}, "
            f"projection {_pct(r['projection_error'])}")


def large_error_html(name: str, sub: pd.DataFrame, scenario=None, evaluated=None) -> str:
    """The notes under a scenario's table: one per (structure, method) with a total error at
    or above :data:`OFF_SCALE`, anchored ``#why-<scenario>-<structure>-<method>``."""
    items = []
    for it in large_errors(sub, scenario):
        anchor = slug(f"why-{name}-{it['structure']}-{it['method']}")
        totals = ", ".join(f"{_e(t)} {_pct(v)}" for t, v in it["targets"])
        claims = claims_about(evaluated, name, it["structure"], it["method"])
        see = ("; judged by " + ", ".join(
            f'<a href="#claim-{slug(cid)}">{_e(cid)}</a> ({_e(v)})' for cid, v in claims)
            if claims else "")
        items.append(f'<li id="{anchor}"><b>{_e(it["method"])} on {_e(it["structure"])}'
                     f"</b> ({totals}): further from the truth than predicting no motion "
                     f"(100 %). {_why(it)}{see}.</li>")
    if not items:
        return ""
    return ('<div class="why"><p><b>▲ Large errors, read.</b> A total error of 100 % is '
            "what a prediction of no motion scores; the part of the "
            '<a href="#decomposition">decomposition</a> that carries most of each is named '
            f"(its worst target).</p><ul>{''.join(items)}</ul></div>")


def _method_cell(entry) -> str:
    if entry is None:
        return '<td class="l na">—</td>'
    method, med, n, failed = entry
    note = f", {failed} failed" if failed else ""
    return (f'<td class="l"><b>{_e(method)}</b> {_pct(med)}'
            f'<span class="muted"> ({n} row{"s" if n != 1 else ""}{note})</span></td>')


def best_worst_html(df: pd.DataFrame) -> str:
    """The summary's table: per scenario and structure, the best and worst method by median
    total error over the targets, the rows off scale and the methods that failed."""
    if not len(df) or "total_error" not in df:
        return ""
    body = []
    for r in summary_rows(df):
        failed = ", ".join(_e(m) for m in r["failed"]) or "—"
        off = (f'<a href="#sc-{slug(r["scenario"])}">{r["off"]}</a>' if r["off"] else "0")
        body.append(f'<tr><td class="l"><a href="#sc-{slug(r["scenario"])}">'
                    f'{_e(r["scenario"])}</a></td><td class="l">{_e(r["structure"])}</td>'
                    f'<td>{r["targets"]}</td>{_method_cell(r["best"])}'
                    f'{_method_cell(r["worst"])}<td>{off}</td><td class="l">{failed}</td>'
                    "</tr>")
    return ('<div class="scroll"><table class="overview"><thead><tr><th class="l">scenario'
            '</th><th class="l">structure</th><th>targets</th><th class="l">best method, '
            '<a class="term" href="#g-total">total error</a> (median over its rows)</th>'
            '<th class="l">worst method, total error (median)</th><th>rows ≥ 100 % ▲</th>'
            '<th class="l">failed</th></tr></thead>'
            f"<tbody>{''.join(body)}</tbody></table></div>")


def run_words(df: pd.DataFrame, *, seconds=None, figure_seconds=None, n_figures: int = 0,
              responses=None) -> str:
    """What was run and how long it took, in one paragraph (HTML)."""
    if not len(df):
        return "<p>Nothing was run.</p>"
    structures = list(dict.fromkeys(df["structure"]))
    methods = list(dict.fromkeys(df["method"]))
    n_sc = df["scenario"].nunique()
    n_cases = df[["scenario", "structure", "target"]].drop_duplicates().shape[0]
    out = (f"<p>{n_sc} scenario{'s' if n_sc != 1 else ''} on {len(structures)} "
           f"structure{'s' if len(structures) != 1 else ''} "
           f"({', '.join(_e(s) for s in structures)}): {len(methods)} method entries "
           f"({', '.join(_e(m) for m in methods)}) each predicted its targets, "
           f"{n_cases} predictions of a (structure, target) in all, {len(df)} rows.")
    if seconds is not None:
        out += f" Simulating and fitting took {seconds:.1f} s"
        if responses is not None:
            out += (f" ({responses[0]} truth responses simulated, {responses[1]} read from "
                    "the cache)")
        out += "."
    if figure_seconds is not None and n_figures:
        out += f" The {n_figures} figures took {figure_seconds:.1f} s to draw."
    return out + "</p>"
