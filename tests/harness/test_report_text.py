"""The report page's text: Markdown rendered as HTML (checked against Python-Markdown where
the two dialects agree), checks shown in percent, and the error-decomposition figure's rows
and caption checked against the decomposition itself and every committed table."""

import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from podbench.harness.digits import solver_digits
from podbench.harness.metrics import decompose
from podbench.report.decomposition import CAPTION, decomposition_rows
from podbench.report.html import as_percent
from podbench.report.markdown import markdown_to_html

ROOT = Path(__file__).resolve().parents[2]


# ------------------------------------------------------------------------------ Markdown
def test_a_pipe_table_becomes_a_framed_html_table_with_its_alignment():
    out = markdown_to_html("| a | b | c |\n|---|:-:|--:|\n| x `y` | \\| | **z** |\n| short |")
    assert out.startswith('<div class="scroll"><table class="md">')
    cells = re.findall(r'<t[hd] class="md" style="text-align:(\w+)">(.*?)</t[hd]>', out)
    assert cells == [("left", "a"), ("center", "b"), ("right", "c"),
                     ("left", "x <code>y</code>"), ("center", "|"),
                     ("right", "<strong>z</strong>"),
                     ("left", "short"), ("center", ""), ("right", "")]
    assert out.count("|") == 1  # the escaped one, a cell's content


def test_a_line_starting_with_a_pipe_is_prose_without_a_delimiter_row():
    out = markdown_to_html("The mixing:\n|u₁ᵀφ₂| = 0.29 and |u₂ᵀφ₄| = 0.93.")
    assert out == "<p>The mixing: |u₁ᵀφ₂| = 0.29 and |u₂ᵀφ₄| = 0.93.</p>"


def test_a_list_may_interrupt_a_paragraph_and_nest():
    out = markdown_to_html("Checks:\n  * one\n    continued\n      * inner\n  * two\nAfter.")
    assert out == ("<p>Checks:</p>\n<ul><li>one continued\n<ul><li>inner</li></ul></li>"
                   "<li>two</li></ul>\n<p>After.</p>")


def test_headings_code_quotes_links_and_escaping():
    out = markdown_to_html("# Title <x>\n\n```\na < b\n```\n\n> quoted *word*\n\n"
                           "1. [anchor](#claim-a)\n2. [file](docs/noise.md)", heading_offset=3)
    assert out == ("<h4>Title &lt;x&gt;</h4>\n<pre><code>a &lt; b</code></pre>\n"
                   "<blockquote><p>quoted <em>word</em></p></blockquote>\n"
                   '<ol><li><a href="#claim-a">anchor</a></li>'
                   "<li>file (<code>docs/noise.md</code>)</li></ol>")


class _Structure(HTMLParser):
    """The element names and the text of an HTML fragment (whitespace normalized)."""

    def __init__(self):
        super().__init__()
        self.tags, self.text = [], []

    def handle_starttag(self, tag, attrs):
        if tag not in ("div", "thead", "tbody"):  # the frame and row groups are ours
            self.tags.append(tag)

    def handle_data(self, data):
        self.text.append(data)


def _structure(fragment: str):
    p = _Structure()
    p.feed(fragment)
    return p.tags, " ".join(" ".join(p.text).split())


def test_the_real_remarks_render_as_python_markdown_renders_them():
    """Every remark of the committed claims files, through podbench's renderer and through
    Python-Markdown (with its tables extension): the same elements and the same text where
    the dialects agree (both need a blank line before a list there)."""
    markdown = pytest.importorskip("markdown")
    import tomllib

    n_tables = 0
    for path in sorted((ROOT / "scenarios").glob("*/claims.toml")):
        with open(path, "rb") as fh:
            remarks = tomllib.load(fh).get("remarks", [])
        for r in remarks:
            text = r["text"]
            if re.search(r"\S\n\s*[*-] ", text):  # a list right after a line: dialects differ
                continue
            ours = _structure(markdown_to_html(text))
            ref = markdown.markdown(text.replace("``", "`"), extensions=["tables"])
            theirs = _structure(re.sub(r' (align|style)="[^"]*"', "", ref))
            assert ours == theirs, (path.name, r["title"])
            n_tables += ours[0].count("table")
    assert n_tables >= 1  # Chapter 4's table of readings


# ------------------------------------------------------------------------------ percent
@pytest.mark.parametrize("text, shown", [
    ("POVR.total_error < 0.10", "POVR.total_error < 10 %"),
    ("POVR.total_error = 0.08875 < 0.1", "POVR.total_error = 8.875 % < 10 %"),
    ("0.05 < SL.total_error", "5 % < SL.total_error"),
    ("MDS.total_error + 0.01 < ML.total_error", "MDS.total_error + 1 % < ML.total_error"),
    ("noise_5pct:SL.total_error = 0.2 > noise_0pct:SL.total_error = 0.1",
     "noise_5pct:SL.total_error = 20 % > noise_0pct:SL.total_error = 10 %"),
    ("MDS.norm_pe_p90 = 10.29 < 5", "MDS.norm_pe_p90 = 10.29 % < 5 %"),
    ("POVR.linear_diagonalization_error = nan > POVR.projection_error = 0.005499",
     "POVR.linear_diagonalization_error = nan > POVR.projection_error = 0.5499 %"),
    ("ML.norm_peak_ratio > 0.9", "ML.norm_peak_ratio > 0.9"),
])
def test_checks_are_shown_in_percent(text, shown):
    assert as_percent(text) == shown


# ------------------------------------------------------------------------------ decomposition
def test_the_caption_states_the_exact_relations_of_the_parts():
    """What the caption says, measured: total² = projection² + subspace² for a prediction
    inside span U, and the four parts sum to at least the total (the bar's sum / total)."""
    rng = np.random.default_rng(7)
    m, n, k = 8, 60, 3
    W = rng.standard_normal((m, n))
    U = np.linalg.qr(rng.standard_normal((m, k)))[0]
    P = U @ U.T
    W_twin = P @ (W + 0.1 * rng.standard_normal((m, n)))
    W_hat = W_twin + P @ (0.2 * rng.standard_normal((m, n)))
    d = decompose(W, W_hat, U, W_twin=W_twin)
    assert math.isclose(d["total_error"] ** 2, d["projection_error"] ** 2
                        + d["subspace_error"] ** 2, rel_tol=1e-12)
    row = {"structure": "s", "method": "M", "target": "t", **d}
    (r,) = decomposition_rows(pd.DataFrame([row]))
    assert list(r["parts"]) == ["projection_error", "diagonalization_error",
                                "linearization_error", "residual_error"]
    s = d["projection_error"] + d["diagonalization_error"] + d["residual_error"]
    assert r["ratio"] == pytest.approx(s / d["total_error"], rel=1e-12)
    assert r["ratio"] >= 1.0
    for words in ("do not add up to the total", "total² = projection² + subspace²",
                  "triangle inequality", "sum / total"):
        assert words in CAPTION


def test_undefined_attributions_and_methods_without_a_basis():
    base = {"structure": "s", "target": "t", "diagonalization_error": math.nan,
            "linearization_error": math.nan, "residual_error": math.nan}
    rows = decomposition_rows(pd.DataFrame([
        {**base, "method": "twin worse", "total_error": 0.5, "projection_error": 0.3,
         "subspace_error": 0.4},
        {**base, "method": "peer", "total_error": 0.2, "projection_error": math.nan,
         "subspace_error": math.nan},
        {**base, "method": "failed", "total_error": math.nan, "projection_error": math.nan,
         "subspace_error": math.nan},
    ]))
    assert rows[0]["parts"] == {"projection_error": 0.3, "subspace_error": 0.4}
    assert rows[0]["ratio"] == pytest.approx(0.7 / 0.5)
    assert rows[1]["parts"] == {} and math.isnan(rows[1]["ratio"]) and rows[1]["total"] == 0.2
    assert math.isnan(rows[2]["total"])


@pytest.mark.parametrize("study", sorted(p.parent.name for p in
                                         (ROOT / "results").glob("*/summary.csv")))
def test_every_committed_row_obeys_the_caption(study):
    """On every committed table: total² = projection² + subspace² to the digits it is
    written with (six; three for a fit with an iterative solver, whose total and subspace
    errors are rounded to their third digit: 1e-2 relative) and sum / total ≥ 1 (to the same
    rounding), as the figure's caption states."""
    df = pd.read_csv(ROOT / "results" / study / "summary.csv")
    if "projection_error" not in df:
        pytest.skip(f"{study}: no error decomposition in its table")
    fits = ROOT / "results" / study / "fits.csv"
    solvers = pd.read_csv(fits, usecols=["scenario", "structure", "method", "solver"]) \
        if fits.is_file() else pd.DataFrame(columns=["scenario", "structure", "method", "solver"])
    iterative = {tuple(r[:3]) for r in solvers.itertuples(index=False)
                 if isinstance(r[3], str) and solver_digits(r[3]) is not None}
    tol = np.array([1e-2 if (r.scenario, r.structure, r.method) in iterative else 1e-4
                    for r in df.itertuples()])
    ok = (np.isfinite(df["projection_error"]) & np.isfinite(df["subspace_error"]) & (
        df["total_error"] > 0)).to_numpy()
    e = df[ok]
    pyth = np.hypot(e["projection_error"], e["subspace_error"]) / e["total_error"]
    assert np.all(np.abs(pyth - 1) < tol[ok])
    ratios = np.array([r["ratio"] for r in decomposition_rows(df)])
    assert np.all(ratios[np.isfinite(ratios)] >= 1 - 1e-2)
