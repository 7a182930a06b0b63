"""``report.html``: one self-contained page per study.

The page holds the summary tables (error cells coloured by size), every figure (embedded as
``data:`` URIs, so the page needs no other file and loads nothing from the network), the
claims and their verdicts (from the same evaluation as ``FINDINGS.md``), the fit diagnostics
(``fits.csv``), the definitions of the error decomposition (the docstring of
:mod:`podbench.harness.metrics`, the single source of docs/error-decomposition.md) and the
provenance: commit, date, command and the versions of podbench, NumPy, SciPy, pandas and
matplotlib. It carries the commit and the date, so unlike the tables it is not meant to be
committed.
"""

from __future__ import annotations

import datetime as _dt
import html
import math
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy
import pandas as pd
import scipy

from podbench.core.version import __version__
from podbench.harness import metrics
from podbench.report.decomposition import CAPTION
from podbench.report.figures import percent
from podbench.report.glossary import glossary_html, term_link
from podbench.report.markdown import inline_html, markdown_to_html
from podbench.report.overview import (
    OFF_SCALE,
    best_worst_html,
    large_error_html,
    ranking,
    run_words,
)
from podbench.study.claims import Outcome, Verdict, counts_words, text_claims

__all__ = ["as_percent", "provenance", "render_report", "text_to_html"]

ERROR_BINS = ((0.01, "e0", "< 1 %"), (0.05, "e1", "1–5 %"), (0.20, "e2", "5–20 %"),
              (1.0, "e3", "20–100 %"), (math.inf, "e4", "≥ 100 %"))
"""Colour classes of an error cell by its size (a fraction of ‖W‖_F, or Eq. 4.2 / 100)."""

SUMMARY_COLUMNS = (
    # column, header, kind ("frac": fraction shown in %, "pct": already %, "ratio", None)
    ("structure", "structure", None),
    ("method", "method", None),
    ("target", "target", None),
    ("n_modes", "k", None),
    ("total_error", "total", "frac"),
    ("projection_error", "projection", "frac"),
    ("subspace_error", "subspace", "frac"),
    ("diagonalization_error", "diagonal&shy;ization", "frac"),
    ("linearization_error", "linear&shy;ization", "frac"),
    ("residual_error", "residual", "frac"),
    ("twin_error", "twin", "frac"),
    ("own_linearization_error", "own linear&shy;ization", "frac"),
    ("linear_diagonalization_error", "diagonal&shy;ization on linear twin", "frac"),
    ("norm_pe_median", "Eq. 4.2 median", "pct"),
    ("norm_pe_p90", "Eq. 4.2 p90", "pct"),
    ("norm_peak_ratio", "peak ratio", "ratio"),
)

_CSS = """
:root { --fg:#1d232a; --muted:#5b6570; --line:#d9dee3; --bg:#fff; --soft:#f5f7f9;
  --accent:#0b5cad; }
* { box-sizing: border-box; }
html { font-size: 16px; }
body { margin: 0; color: var(--fg); background: var(--bg);
  font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
  line-height: 1.5; }
.wrap { max-width: 1240px; margin: 0 auto; padding: 0 28px 48px; }
header.top { background: #13293d; color: #fff; padding: 26px 0 18px; margin-bottom: 8px; }
header.top .wrap { padding-bottom: 0; }
header.top p.prov-line { margin-top: 12px; font-size: .85rem; }
header.top p.prov-line code { background: none; color: #e8eef4; }
header.top a { color: #9fd0ff; }
header.top h1 { margin: 0 0 4px; font-size: 1.75rem; font-weight: 650; }
header.top p { margin: 0; color: #c9d6e2; max-width: 60rem; }
header.top .stats { display: flex; gap: 28px; flex-wrap: wrap; margin-top: 14px; }
header.top .stat b { display: block; font-size: 1.45rem; color: #fff; }
header.top .stat span { color: #c9d6e2; font-size: .88rem; }
nav.toc { position: sticky; top: 0; z-index: 5; background: rgba(255,255,255,.96);
  border-bottom: 1px solid var(--line); padding: 8px 0; font-size: .9rem; }
nav.toc .wrap { display: flex; flex-wrap: wrap; gap: 2px 16px; padding-bottom: 0; }
nav.toc a { color: var(--accent); text-decoration: none; white-space: nowrap; }
nav.toc a:hover { text-decoration: underline; }
h2 { font-size: 1.4rem; margin: 38px 0 10px; padding-bottom: 4px;
  border-bottom: 2px solid var(--line); }
h3 { font-size: 1.15rem; margin: 30px 0 4px; }
h4 { font-size: 1rem; margin: 20px 0 4px; }
p, li { max-width: 62rem; }
.muted { color: var(--muted); }
.source { color: var(--muted); font-style: italic; margin: 0 0 6px; }
code { font-family: ui-monospace, "DejaVu Sans Mono", Menlo, Consolas, monospace;
  font-size: .88em; background: var(--soft); padding: 0 3px; border-radius: 3px; }
.scroll { overflow-x: auto; margin: 10px 0 6px; border: 1px solid var(--line);
  border-radius: 6px; }
table { border-collapse: collapse; font-size: .82rem; width: 100%; }
th, td { padding: 4px 6px; border-bottom: 1px solid var(--line); text-align: right;
  white-space: nowrap; font-variant-numeric: tabular-nums; }
th { background: var(--soft); font-weight: 600; vertical-align: bottom; white-space: normal;
  hyphens: manual; }
th.l, td.l { text-align: left; }
tbody tr:hover td { filter: brightness(0.96); }
td.e0 { background: #c8ebc3; } td.e1 { background: #e6f4c4; } td.e2 { background: #fff0b3; }
td.e3 { background: #fdd3a8; } td.e4 { background: #f5aaa6; } td.na { color: #8a949e; }
.legend { display: flex; gap: 6px; flex-wrap: wrap; align-items: center; font-size: .84rem;
  margin: 6px 0; }
.legend span.chip { padding: 1px 8px; border-radius: 4px; border: 1px solid rgba(0,0,0,.08); }
.chip.e0 { background: #c8ebc3; } .chip.e1 { background: #e6f4c4; }
.chip.e2 { background: #fff0b3; } .chip.e3 { background: #fdd3a8; }
.chip.e4 { background: #f5aaa6; }
.status { font-size: .85rem; color: #8a1c1c; }
.figs { display: grid; grid-template-columns: repeat(auto-fill, minmax(540px, 1fr));
  gap: 18px; margin: 14px 0 8px; }
figure { margin: 0; border: 1px solid var(--line); border-radius: 6px; padding: 6px;
  background: #fff; }
figure img { display: block; width: 100%; height: auto; }
figure.decomposition { margin: 14px 0 8px; max-width: 1000px; }
.scroll, .tablewrap { overflow-x: auto; max-width: 100%; }
.sticky1 td:first-child, .sticky1 th:first-child { position: sticky; left: 0; z-index: 1;
  box-shadow: 1px 0 0 var(--line); }
.sticky1 td:first-child { background: var(--bg); }
table.md td, table.md th { white-space: normal; min-width: 7rem; vertical-align: top; }
pre { background: var(--soft); padding: 8px 10px; border-radius: 4px; overflow-x: auto; }
figcaption { font-size: .82rem; color: var(--muted); padding: 4px 4px 0; }
.badge { display: inline-block; padding: 0 8px; border-radius: 10px; font-size: .8rem;
  font-weight: 600; white-space: nowrap; }
.badge.reproduced { background: #c8ebc3; color: #1d4d18; }
.badge.not-reproduced { background: #f5aaa6; color: #6b1411; }
.badge.not-measured { background: #e3e6ea; color: #3b444d; }
.badge.tie-within-the-noise-seeds-spread { background: #f7e3a1; color: #5c4400; }
article.claim { border-left: 4px solid var(--line); padding: 2px 0 2px 14px; margin: 22px 0; }
article.claim.reproduced { border-color: #5fb257; }
article.claim.not-reproduced { border-color: #d9534f; }
blockquote { margin: 6px 0; padding: 4px 12px; background: var(--soft); border-radius: 4px;
  max-width: 62rem; }
ul.checks { font-size: .9rem; padding-left: 20px; }
ul.checks li.holds::marker { content: "✓  "; color: #2e7d32; }
ul.checks li.fails::marker { content: "✗  "; color: #c62828; }
ul.checks li.unmeasured::marker { content: "?  "; color: #6b7580; }
ul.checks li.tie::marker { content: "≈  "; color: #8a6d00; }
dl.prov { display: grid; grid-template-columns: max-content 1fr; gap: 4px 18px;
  font-size: .92rem; }
dl.prov dt { font-weight: 600; } dl.prov dd { margin: 0; word-break: break-all; }
table.verdicts td, table.verdicts th { text-align: left; white-space: normal; }
details > summary { cursor: pointer; color: var(--accent); margin: 8px 0; }
details.scenario { border-top: 1px solid var(--line); margin: 6px 0; }
details.scenario > summary { list-style-position: outside; margin: 0; padding: 10px 0 6px;
  color: var(--fg); }
details.scenario > summary h3 { display: inline; margin: 0; }
details.scenario > summary .gist { display: block; font-size: .88rem; color: var(--muted);
  margin-left: 2px; }
details.sub { margin: 10px 0; border: 1px solid var(--line); border-radius: 6px;
  padding: 0 10px; background: #fcfdfe; }
details.sub > summary { font-weight: 600; }
details.sub[open] { padding-bottom: 8px; }
.toc button { font: inherit; font-size: .82rem; color: var(--accent); background: none;
  border: 1px solid var(--line); border-radius: 4px; padding: 0 6px; cursor: pointer; }
th .u { display: block; font-weight: 400; color: var(--muted); font-size: .75rem; }
th a.term, a.term { color: inherit; text-decoration: underline dotted; }
a.off { color: #8a1c1c; text-decoration: none; font-size: .8em; margin-left: 2px; }
.why { font-size: .88rem; background: #fff7f6; border-left: 4px solid #d9534f;
  padding: 4px 12px; margin: 8px 0; border-radius: 0 4px 4px 0; }
.why ul { margin: 4px 0; padding-left: 18px; } .why li { margin: 3px 0; max-width: none; }
.figs.wide { grid-template-columns: 1fr; }
figure.wide img { max-width: 1180px; margin: 0 auto; }
dl.glossary { display: grid; grid-template-columns: 1fr; gap: 2px; margin: 8px 0; }
dl.glossary .gl { display: grid; grid-template-columns: 15rem 1fr; gap: 12px;
  padding: 5px 0; border-bottom: 1px solid var(--line); }
dl.glossary dt { font-weight: 600; } dl.glossary dd { margin: 0; max-width: 62rem; }
dl.glossary :target, dl.glossary .gl:target { background: #fff6d6; }
.formula { display: block; font-family: ui-monospace, "DejaVu Sans Mono", monospace;
  font-size: .85rem; color: #34404c; margin-top: 2px; }
.lead { font-size: 1.02rem; max-width: 62rem; }
table.overview td, table.overview th { white-space: normal; }
@media print { nav.toc { position: static; } details > summary { list-style: none; } }
"""

_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute("data-images", String(imgs.length));
  document.body.setAttribute("data-images-loaded", String(ok));
  document.body.setAttribute("data-ok", ok === imgs.length ? "yes" : "no");
  // every table inside a frame that scrolls sideways; nothing wider than the window
  var tables = Array.prototype.slice.call(document.querySelectorAll("table"));
  var loose = tables.filter(function (t) {
    for (var p = t.parentElement; p; p = p.parentElement) {
      var o = getComputedStyle(p).overflowX;
      if (o === "auto" || o === "scroll") { return false; }
    }
    return true;
  }).length;
  document.body.setAttribute("data-tables", String(tables.length));
  document.body.setAttribute("data-tables-unframed", String(loose));
  document.body.setAttribute("data-page-overflow", String(
    Math.max(0, document.documentElement.scrollWidth - document.documentElement.clientWidth)));
  if (location.hash) { reveal(decodeURIComponent(location.hash.slice(1)), true); }
});
// a link into a folded section unfolds it (and every section around it)
function reveal(id, scroll) {
  var el = document.getElementById(id);
  if (!el) { return; }
  for (var p = el; p; p = p.parentElement) { if (p.tagName === "DETAILS") { p.open = true; } }
  if (scroll) { el.scrollIntoView(); }
}
document.addEventListener("click", function (ev) {
  var a = ev.target.closest ? ev.target.closest("a[href^='#']") : null;
  if (a) { reveal(decodeURIComponent(a.getAttribute("href").slice(1)), false); }
  var b = ev.target.closest ? ev.target.closest("button[data-fold]") : null;
  if (b) {
    var open = b.getAttribute("data-fold") === "open";
    document.querySelectorAll("details").forEach(function (d) { d.open = open; });
  }
});
window.addEventListener("hashchange", function () {
  reveal(decodeURIComponent(location.hash.slice(1)), true);
});
window.addEventListener("beforeprint", function () {
  document.querySelectorAll("details").forEach(function (d) { d.open = true; });
});
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", str(text)).strip("-") or "x"


def text_to_html(text: str, heading_offset: int = 3) -> str:
    """Markdown text (docstrings, scenario descriptions, claims' notes and remarks) as HTML:
    :func:`podbench.report.markdown.markdown_to_html`, headings placed under the page's
    ``<h3>`` by default."""
    return markdown_to_html(text, heading_offset)


def _inline(text: str) -> str:
    return inline_html(text)


def _git(args, cwd) -> str | None:
    try:
        p = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True,
                           timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return p.stdout.strip() if p.returncode == 0 else None


def provenance(command: str | None = None) -> dict:
    """Commit (``git rev-parse HEAD`` of podbench's checkout, ``"unknown"`` without git),
    UTC date, command and versions, as ``{label: text}``."""
    here = Path(__file__).resolve().parent
    commit = _git(["rev-parse", "HEAD"], here) or "unknown"
    if commit != "unknown":
        dirty = _git(["status", "--porcelain", "--untracked-files=no"], here)
        if dirty:
            commit += " (with uncommitted changes)"
    if command is None:
        command = shlex.join(["podbench", *sys.argv[1:]]) if Path(sys.argv[0]).stem == (
            "podbench") else shlex.join([Path(sys.executable).name, *sys.argv])
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0)
    return {
        "commit": commit,
        "date": now.isoformat().replace("+00:00", " UTC"),
        "command": command,
        "podbench": __version__,
        "Python": platform.python_version(),
        "NumPy": numpy.__version__,
        "SciPy": scipy.__version__,
        "pandas": pd.__version__,
        "matplotlib": matplotlib.__version__,
    }


def _err_class(frac) -> str:
    if frac is None or not isinstance(frac, (int, float)) or not math.isfinite(frac):
        return "na"
    for limit, cls, _ in ERROR_BINS:
        if frac < limit:
            return cls
    return "e4"  # pragma: no cover - the last bin is unbounded


def _num(x, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    if isinstance(x, (int,)) and not isinstance(x, bool):
        return str(x)
    return f"{x:.{digits}g}"


def _cell(value, kind) -> str:
    if kind is None:
        return f'<td class="l">{_e(value)}</td>'
    if isinstance(value, float) and not math.isfinite(value):
        return '<td class="na">—</td>'
    if kind == "frac":
        return f'<td class="{_err_class(value)}">{percent(100 * value)}</td>'
    if kind == "pct":
        return f'<td class="{_err_class(value / 100)}">{percent(value)}</td>'
    return f"<td>{_num(value)}</td>"


UNITS = {"frac": "%", "pct": "%", "ratio": "ratio"}
"""The unit line of a column head by its kind (errors in % of ‖W‖_F or Eq. 4.2's %)."""


def _legend() -> str:
    chips = "".join(f'<span class="chip {c}">{_e(t)}</span>' for _, c, t in ERROR_BINS)
    return f'<div class="legend"><span class="muted"><a href="#decomposition">error</a>, % of ' \
           f'‖W‖<sub>F</sub>:</span>{chips}' \
           '<span class="chip" style="color:#8a949e"><a class="term" href="#g-undefined">' \
           '—</a> undefined</span><span class="chip"><span style="color:#8a1c1c">▲</span> ' \
           'total ≥ 100 %: worse than no motion, explained under the table</span></div>'


def _head(c: str, h: str, k) -> str:
    unit = "POMs" if c == "n_modes" else UNITS.get(k, "")
    u = f'<span class="u">{unit}</span>' if unit else ""
    return f'<th class="{"l" if k is None else ""}" title="{_e(c)}">{term_link(c, h)}{u}</th>'


def _summary_table(sub, name: str = "") -> str:
    cols = [(c, h, k) for c, h, k in SUMMARY_COLUMNS if c in sub.columns]
    head = "".join(_head(c, h, k) for c, h, k in cols)
    body = []
    for r in sub.to_dict("records"):
        cells = [_cell(r[c], k) for c, _, k in cols]
        tot = r.get("total_error")
        if "total_error" in sub.columns and isinstance(tot, float) and tot >= OFF_SCALE:
            i = [c for c, _, _ in cols].index("total_error")
            why = _slug(f"why-{name}-{r['structure']}-{r['method']}")
            cells[i] = cells[i].replace(
                "</td>", f'<a class="off" href="#{why}" title="worse than predicting no '
                'motion: why, under the table">▲</a></td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    notes = [f'<li>{_e(r["structure"])} / {_e(r["method"])} / {_e(r["target"])}: '
             f'{_e(r["status"])}</li>' for r in sub.to_dict("records") if r["status"] != "ok"]
    out = (f'<div class="scroll"><table><thead><tr>{head}</tr></thead>'
           f'<tbody>{"".join(body)}</tbody></table></div>')
    if notes:
        out += f'<ul class="status">{"".join(notes)}</ul>'
    return out


def _fits_table(fits) -> str:
    if fits is None or not len(fits):
        return '<p class="muted">No method was fitted.</p>'
    cols = list(fits.columns)
    text_cols = {"scenario", "structure", "method", "solver"}
    head = "".join(f'<th class="{"l" if c in text_cols else ""}" title="{_e(c)}">'
                   f'{_e(c).replace("_", "_<wbr>")}</th>' for c in cols)
    body = []
    for r in fits.to_dict("records"):
        cells = []
        for c in cols:
            v = r[c]
            if c in text_cols or isinstance(v, str):
                cells.append(f'<td class="l">{_e(v if v == v else "—")}</td>')
            elif isinstance(v, float) and not math.isfinite(v):
                cells.append('<td class="na">—</td>')
            else:
                cells.append(f"<td>{_num(v, 4)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<p class="muted">{len(fits)} fits × {len(cols)} columns; a table wider than '
            "the page scrolls sideways inside its frame (the first column stays).</p>"
            f'<div class="scroll sticky1"><table><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(body)}</tbody></table></div>')


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_FRACTION_METRIC = r"[\w.:/() -]*?(?:_error|error_estimate)"


def as_percent(text: str) -> str:
    """A claim's check, or its evaluation, with the fraction metrics (``*_error``,
    ``error_estimate``: fractions of ‖W‖_F) and the numbers compared with them in percent:
    ``POVR.total_error = 0.08875 < 0.1`` → ``POVR.total_error = 8.875 % < 10 %``. Checks
    on Eq. 4.2's ``norm_pe_*`` (already percent) get the unit written out."""
    def pct(v: str) -> str:
        return f"{100 * float(v):.4g} %"

    out = re.sub(rf"({_FRACTION_METRIC}) = ({_NUMBER})", lambda m: f"{m.group(1)} = "
                 f"{pct(m.group(2))}", text)
    out = re.sub(rf"((?:_error|error_estimate)\b[^<>=]*?) ([-+]) ({_NUMBER})(?=\s|$)",
                 lambda m: f"{m.group(1)} {m.group(2)} {pct(m.group(3))}", out)
    out = re.sub(rf"^(.*(?:_error|error_estimate).*?) (<=|>=|<|>) ({_NUMBER})$",
                 lambda m: f"{m.group(1)} {m.group(2)} {pct(m.group(3))}", out)
    out = re.sub(rf"^({_NUMBER}) (<=|>=|<|>) (.*(?:_error|error_estimate).*)$",
                 lambda m: f"{pct(m.group(1))} {m.group(2)} {m.group(3)}", out)
    # Eq. 4.2's percent errors: already percent, the unit written out
    out = re.sub(rf"(norm_pe_\w+ = {_NUMBER})(?=\s|$)", r"\1 %", out)
    return re.sub(rf"^(.*norm_pe_\w+.*?) (<=|>=|<|>) ({_NUMBER})$", r"\1 \2 \3 %", out)


def _verdict_badge(verdict: str) -> str:
    return f'<span class="badge {_slug(verdict)}">{_e(verdict)}</span>'


def _headline(evaluated) -> str:
    """The claims' count, as FINDINGS.md gives it (the text's claims once each when the
    claims file marks variants or parts), as an HTML paragraph."""
    n = len(evaluated)
    out = (f"<p><strong>{n} claims: {_e(counts_words(e.verdict for e in evaluated))}."
           "</strong></p>")
    if any(e.claim.variant or e.claim.part_of or not e.claim.checkable
           for e in evaluated):  # the text's claims once each, as FINDINGS.md counts them
        texts = text_claims(evaluated)
        out = (f"<p><strong>The text's claims: {len(texts)}, each counted once: "
               f"{_e(counts_words(v for _, _, v in texts))}.</strong> The table lists "
               f"every entry, the variants ({sum(1 for e in evaluated if e.claim.variant)}"
               " entries: other readings, solvers, units, targets; see FINDINGS.md) "
               "among them.</p>")
    return out


def _findings(evaluated, remarks, claims_path) -> str:
    if evaluated is None:
        return ('<p class="muted">No claims file (<code>claims.toml</code>) beside the '
                "scenarios: nothing to check.</p>")
    out = [f"<p>Each claim of <code>{_e(claims_path)}</code> checked against this run's "
           "summary table (the same evaluation as <code>FINDINGS.md</code>). The words were "
           "translated into thresholds before any run; the structures and methods were not "
           "adjusted to the dissertation. Checks are shown in percent (the claims file's "
           "literal check is the tooltip); the notes are the claims file's text, as in "
           "<code>FINDINGS.md</code>, where an error written as a bare number is a fraction "
           "of ‖W‖<sub>F</sub> (0.05 = 5 %).</p>", _headline(evaluated)]
    rows = "".join(
        f'<tr><td class="l"><a href="#claim-{_slug(e.claim.id)}">{_e(e.claim.id)}</a>'
        f'</td><td class="l">{_e(e.claim.source)}</td><td class="l">'
        f'{_e(e.claim.scenario)}</td><td class="l">{_verdict_badge(e.verdict)}</td></tr>'
        for e in evaluated)
    out.append('<div class="scroll"><table class="verdicts"><thead><tr><th>claim</th>'
               "<th>source</th><th>scenario</th><th>verdict</th></tr></thead>"
               f"<tbody>{rows}</tbody></table></div>")
    out.append(f'<details class="sub" id="claims-all"><summary>Every claim: its quote, '
               f"checks and notes ({len(evaluated)})</summary>")
    for e in evaluated:
        c = e.claim
        cls = _slug(e.verdict)
        out.append(f'<article class="claim {cls}" id="claim-{_slug(c.id)}">')
        out.append(f"<h4>{_e(c.id)} {_verdict_badge(e.verdict)}</h4>")
        out.append(f'<p class="source">{_e(c.source)}, {_e(c.scenario)}</p>')
        out.append(f"<blockquote>“{_inline(c.quote)}”</blockquote>")
        if c.criterion:
            out.append(f"<p><strong>Criterion:</strong> {_inline(c.criterion)}.</p>")
        items = []
        for d in e.details:
            css = "unmeasured" if d.outcome == Outcome.NOT_MEASURED else d.outcome.value
            items.append(f'<li class="{css}">{_e(d.structure)}, {_e(d.target)}: '
                         f'<code title="{_e(str(d.check))}">{_e(as_percent(str(d.check)))}'
                         f'</code> → {_e(as_percent(d.shown))}: {d.outcome}</li>')
        out.append(f'<ul class="checks">{"".join(items)}</ul>')
        if getattr(c, "finding", ""):
            out.append(f"<p><strong>In one line:</strong> {_inline(c.finding)}</p>")
        if c.note:
            out.append(text_to_html(c.note))
        out.append("</article>")
    out.append("</details>")
    if remarks:
        out.append(f'<details class="sub" id="other-findings"><summary>Other findings '
                   f"({len(remarks)}): {_e('; '.join(r['title'] for r in remarks))}"
                   "</summary>")
        for r in remarks:
            out.append(f"<h4>{_e(r['title'])}</h4>{text_to_html(r['text'], 4)}")
        out.append("</details>")
    return "\n".join(out)


def _figures(figs, figure_format: str | None) -> str:
    if figure_format is None:
        return '<p class="muted">Figures not drawn (<code>--no-figures</code>).</p>'
    if not figs:
        return ""
    wide = all(f.get("wide") for f in figs)
    out = [f'<div class="figs{" wide" if wide else ""}">']
    for f in figs:
        out.append(f'<figure class="{"wide" if f.get("wide") else ""}"><img src="{f["uri"]}" '
                   f'alt="{_e(f["alt"])}" loading="eager">'
                   f'<figcaption>{_e(f["caption"])}</figcaption></figure>')
    out.append("</div>")
    return "\n".join(out)


FIGURE_NOTE = (
    "Each figure: left, the displacement norm ‖w(t)‖ over the sensors (Eq. 4.1) of the truth "
    "and of every method, over the percent error of the norm (Eq. 4.2, log scale); right, "
    "the displacement at two sensors chosen from the truth alone (the one that moves most, "
    "the tip of a cantilever, and the one nearest mid-span, or the quarter span when the "
    "first is there) and the amplitude spectrum over all sensors (Hann window; the amplitude "
    "of a sinusoid at that frequency). Every y-axis is fitted to the truth; a method that "
    "leaves it is clipped, marked ▲/▼ where it leaves and labelled “off scale” in the "
    "legend with its total error.")
"""What the prediction figures show (the page's text above them)."""


def render_report(*, study: str, df, fits, scenarios: dict, evaluated=None, remarks=(),
                  claims_path=None, figures: dict | None = None,
                  figure_format: str | None = "png", command: str | None = None,
                  calibration: str = "", decompositions: dict | None = None,
                  modes: str = "", seconds: float | None = None,
                  figure_seconds: float | None = None, responses=None) -> str:
    """The HTML text of a study's ``report.html``.

    Parameters
    ----------
    study : str
        The study's name (its output folder).
    df, fits : pandas.DataFrame
        The summary table (``summary.csv``) and the fit diagnostics (``fits.csv``).
    scenarios : dict
        Scenario name → :class:`podbench.scenarios.Scenario`.
    evaluated, remarks, claims_path
        The claims' evaluation (:func:`podbench.study.claims.evaluate_claims`), the
        claims file's remarks and its path, or None without a claims file.
    figures : dict
        Scenario name → list of ``{"uri", "alt", "caption"}`` (figures as ``data:`` URIs;
        ``"wide": True`` for a figure with the sensor and spectrum panels).
    figure_format : str or None
        The format of the figure files, None when no figures were drawn.
    command : str, optional
        The command that produced the study (default: this process's command line).
    calibration : str, optional
        The calibration section's HTML (:func:`podbench.report.calibration.calibration_html`);
        empty: no section.
    decompositions : dict, optional
        Scenario name → ``data:`` URI of its error-decomposition figure
        (:mod:`podbench.report.decomposition`).
    modes : str, optional
        The modes section's HTML (identified modes against the structure's, their figures);
        empty: no section.
    seconds, figure_seconds : float, optional
        Wall time (s) of simulating and fitting, and of drawing the figures, for the
        summary.
    responses : (int, int), optional
        Truth responses simulated and read from the cache.
    """
    figures = figures or {}
    prov = provenance(command)
    decompositions = decompositions or {}
    toc, sections = _scenario_sections(df, scenarios, figures, figure_format, decompositions,
                                       evaluated)
    extra = []
    if modes:
        extra.append(("modes", "Modes", modes))
    if calibration:
        extra.append(("calibration", "Calibration of the prediction bands", calibration))
    toc += [f'<a href="#{i}">{"Calibration" if i == "calibration" else t}</a>'
            for i, t, _ in extra]
    toc += ['<a href="#findings">Findings</a>', '<a href="#glossary">Glossary</a>',
            '<a href="#decomposition">Error decomposition</a>',
            '<a href="#fits">Fit diagnostics</a>', '<a href="#provenance">Provenance</a>']
    body = "\n".join(sections)
    after = "".join(f'\n<section id="{i}"><h2>{t}</h2>\n{h}</section>' for i, t, h in extra)
    n_figs = body.count("<img ") + after.count("<img ")
    summary = _summary(df, evaluated, seconds=seconds, figure_seconds=figure_seconds,
                       n_figures=n_figs, responses=responses)
    fmt_note = ("" if figure_format is None else
                f" The figure files are in <code>figures/*.{_e(figure_format)}</code> beside "
                "this page; the page embeds them.")
    return _page(study=study, prov=prov, stat_html=_stats(df, evaluated, n_figs, seconds),
                 toc=toc, summary=summary, body=body, after=after, fmt_note=fmt_note,
                 findings=_findings(evaluated, remarks, claims_path), fits=_fits_table(fits),
                 units=_units(figures))


def _units(figures: dict) -> str:
    """The header's units sentence: the displacement unit of the figures' series (the
    dissertation's inch, lbf, second without figures)."""
    units = {f["unit"] for v in figures.values() for f in v if f.get("unit")} or {"in"}
    if units == {"in"}:
        return "Units: inch, lbf, second (displacements in in, forces in lbf)."
    return f"Units: displacements in {', '.join(sorted(units))}, time in seconds."


def _not_reproduced(evaluated) -> str:
    """Links to the claims not reproduced (the text's claims when the file marks them)."""
    if not evaluated:
        return ""
    if any(e.claim.variant or e.claim.part_of or not e.claim.checkable for e in evaluated):
        ids = [e.claim.id for e, _, v in text_claims(evaluated)
               if v == Verdict.NOT_REPRODUCED]
    else:
        ids = [e.claim.id for e in evaluated if e.verdict == Verdict.NOT_REPRODUCED]
    if not ids:
        return ""
    links = ", ".join(f'<a href="#claim-{_slug(i)}">{_e(i)}</a>' for i in ids)
    return f"<p>Not reproduced: {links} (each explained under <a href=\"#findings\">" \
           "Findings</a>).</p>"


def _summary(df, evaluated, **timing) -> str:
    """The summary at the top: what was run and how long it took, the claims' headline,
    the best and worst method of each scenario and structure."""
    out = [run_words(df, **timing)]
    if evaluated is not None:
        out += [_headline(evaluated), _not_reproduced(evaluated)]
    out.append("<p>Best and worst method of each scenario and structure, by the median of "
               "their <a class=\"term\" href=\"#g-total\">total error</a> over the targets "
               "(100 % is what a prediction of no motion scores):</p>")
    out.append(best_worst_html(df))
    return "\n".join(out)


def _stats(df, evaluated, n_figs: int, seconds: float | None = None) -> str:
    """The counts at the top of the page (scenarios, rows, figures drawn on the page,
    claims, failures, time)."""
    n_ok = None if evaluated is None else sum(e.verdict == Verdict.REPRODUCED for e in evaluated)
    stats: list[tuple[object, str]] = [
        (len(df["scenario"].unique()) if len(df) else 0, "scenarios"),
        (len(df), "rows (structure × method × target)"), (n_figs, "figures on this page")]
    if evaluated is not None:
        stats.append((f"{n_ok} / {len(evaluated)}", "claims reproduced"))
    n_failed = int((df["status"] != "ok").sum()) if len(df) else 0
    if n_failed:
        stats.append((n_failed, "rows with a failed method or twin"))
    if seconds is not None:
        stats.append((f"{seconds:.0f} s", "simulating and fitting"))
    return "".join(f'<div class="stat"><b>{_e(v)}</b><span>{_e(t)}</span></div>'
                   for v, t in stats)


def _decomposition(name: str, uri: str | None) -> str:
    if not uri:
        return ""
    return ('<details class="sub"><summary>Where the errors come from: the error '
            f'decomposition of these rows (figure)</summary><figure class="decomposition">'
            f'<img src="{uri}" alt="{_e(name)}: error decomposition per method and target '
            '(stacked bars)" loading="eager">'
            f"<figcaption>{CAPTION} (figures/{_e(name)}__decomposition.*)</figcaption>"
            "</figure></details>")


def _gist(sub, n_figs: int) -> str:
    """A scenario's line under its folded heading: best and worst method, rows, figures."""
    r = [x for x in ranking(sub) if math.isfinite(x[1])]
    parts = []
    if r:
        parts.append(f"best {_e(r[0][0])} {percent(100 * r[0][1])} %")
    if len(r) > 1:
        parts.append(f"worst {_e(r[-1][0])} {percent(100 * r[-1][1])} %")
    parts.append(f"{len(sub)} rows")
    if n_figs:
        parts.append(f"{n_figs} figure{'s' if n_figs != 1 else ''}")
    return " · ".join(parts) + " (total error, median over the rows of a method)"


def _scenario_sections(df, scenarios: dict, figures: dict, figure_format: str | None,
                       decompositions: dict, evaluated=None) -> tuple[list[str], list[str]]:
    """The table of contents' links and one foldable section per scenario (title, source,
    description, its rows and what their large errors mean, its figures); the sections
    are unfolded when the study has at most :data:`UNFOLDED` scenarios."""
    toc = ['<a href="#summary">Summary</a>', '<a href="#results">Results</a>']
    sections = []
    groups = list(df.groupby("scenario", sort=False))
    unfold = " open" if len(groups) <= UNFOLDED else ""
    for name, sub in groups:
        sc = scenarios.get(name)
        figs = figures.get(name, [])
        toc.append(f'<a href="#sc-{_slug(name)}">{_e(name)}</a>')
        part = [f'<details class="scenario" id="sc-{_slug(name)}"{unfold}><summary><h3>'
                f'{_e(name)}' + (f": {_e(sc.title)}" if sc is not None else "") + "</h3>"
                f'<span class="gist">{_gist(sub, len(figs))}</span></summary>']
        if sc is not None and sc.source:
            part.append(f'<p class="source">{_e(sc.source)}</p>')
        if sc is not None and sc.description:
            part.append(text_to_html(sc.description))
        part.append(_summary_table(sub, name))
        part.append(large_error_html(name, sub, sc, evaluated))
        part.append(_decomposition(name, decompositions.get(name)))
        if figs:
            part.append(f'<details class="sub"><summary>Figures: {len(figs)} target'
                        f'{"s" if len(figs) != 1 else ""}, truth against every method'
                        "</summary>")
        part.append(_figures(figs, figure_format))
        if figs:
            part.append("</details>")
        part.append("</details>")
        sections.append("\n".join(p for p in part if p))
    return toc, sections


UNFOLDED = 8
"""Scenario sections shown unfolded when a study has at most this many (Chapter 4's 7);
a larger study (Chapter 5's) opens folded on its summary."""


def _page(*, study: str, prov: dict, stat_html: str, toc: list[str], summary: str, body: str,
          after: str, fmt_note: str, findings: str, fits: str, units: str) -> str:
    """The whole page around its parts."""

    prov_html = "".join(f"<dt>{_e(k)}</dt><dd>{'<code>' + _e(v) + '</code>' if k in ('commit', 'command') else _e(v)}</dd>"  # noqa: E501
                        for k, v in prov.items())
    folds = ('<button type="button" data-fold="open">unfold all</button>'
             '<button type="button" data-fold="close">fold all</button>')
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="podbench {_e(prov['podbench'])}">
<title>podbench study report: {_e(study)}</title>
<style>{_CSS}</style>
</head>
<body>
<header class="top"><div class="wrap">
<h1>podbench study report: {_e(study)}</h1>
<p>POD-based system identification after Allison (2007), <em>System Identification via the
Proper Orthogonal Decomposition</em>. {units} Every error on this page is in
percent: of the target's ‖W‖<sub>F</sub> (<a href="#glossary">glossary</a>,
<a href="#decomposition">definitions</a>), or Eq. 4.2's percent error of the displacement
norm.</p>
<div class="stats">{stat_html}</div>
<p class="prov-line">commit <code>{_e(prov['commit'])}</code> · {_e(prov['date'])} ·
<code>{_e(prov['command'])}</code></p>
</div></header>
<nav class="toc"><div class="wrap">{''.join(toc)} {folds}</div></nav>
<main class="wrap">
<section id="summary"><h2>Summary</h2>
{summary}
</section>
<section id="results"><h2>Results</h2>
<p>One section per scenario (click a heading to fold or unfold it): one row per structure ×
method × target (the rows of <code>summary.csv</code>; a column head links to its entry in the
<a href="#glossary">glossary</a>, its tooltip names the column). Error columns are in percent
of ‖W‖<sub>F</sub> of the target; "—" marks a component that is undefined. Under each table,
the errors of 100 % or more are read against the decomposition; then the decomposition's
figure and the scenario's figures, folded. {FIGURE_NOTE}{fmt_note}</p>
{_legend()}
{body}
</section>{after}
<section id="findings"><h2>Findings</h2>
{findings}
</section>
<section id="glossary"><h2>Glossary</h2>
{glossary_html()}
</section>
<section id="decomposition"><h2>Error decomposition</h2>
<p>The definitions below write each error as a fraction of N = ‖W‖<sub>F</sub>, as
<code>summary.csv</code> stores it; this page shows every one of them multiplied by 100, in
percent.</p>
<details class="sub"><summary>The definitions (podbench.harness.metrics)</summary>
{text_to_html(metrics.__doc__ or "")}
</details>
</section>
<section id="fits"><h2>Fit diagnostics</h2>
<p>What each reported method's fit measured about itself (<code>fits.csv</code>): mode count,
fit residual, condition numbers and the deconvolution solver's amplification, growth,
regularization and iterations.</p>
<details class="sub"><summary>The table</summary>
{fits}
</details>
</section>
<section id="provenance"><h2>Provenance</h2>
<dl class="prov">{prov_html}</dl>
</section>
</main>
<script>{_SCRIPT}</script>
</body>
</html>
"""
