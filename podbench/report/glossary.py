"""The report page's glossary: the terms of the summary tables and of the error decomposition
in a reader's words, each with its formula and where it comes from, under an anchor the
tables' column heads link to (``#g-<term>``).

The formulas are those of :mod:`podbench.harness.metrics` (the definitions the page also
prints in full); the dissertation's words are quoted from §3.6, "Sources of Error", and
§4.1 (Eqs. 4.1 and 4.2).
"""

from __future__ import annotations

import html

__all__ = ["GLOSSARY", "COLUMN_TERMS", "glossary_html", "term_link"]

GLOSSARY = (
    # anchor, term, what it means (HTML), formula (HTML; "" for none)
    ("k", "k (modes)",
     "The number of proper orthogonal modes (POMs) the method keeps: the columns of its "
     "basis U, taken from the training responses' POD (Eq. 2.2).", ""),
    ("total", "total error",
     "How far the prediction is from the truth over the whole record, all sensors and "
     "samples together. 100 % is what predicting no motion at all would score, so a total "
     "above 100 % (marked ▲) is further from the truth than a zero prediction.",
     "‖Ŵ − W‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("projection", "projection",
     "What the method's k POMs cannot represent of the target: the floor of any prediction "
     "in their span. §3.6: “the model can only accurately predict a response matrix that "
     "may be spanned by the original set of POMs.”",
     "‖W − P W‖<sub>F</sub> / ‖W‖<sub>F</sub>, P = U Uᵀ"),
    ("subspace", "subspace",
     "What the method loses inside the span of its POMs. Every POD method predicts inside "
     "that span, so total² = projection² + subspace².",
     "‖Ŵ − P W‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("twin", "twin (coupled twin)",
     "The total error of the method's coupled twin: the method of the same family that "
     "does not assume diagonal modal matrices (MDS for POVR, ML for SL, MDS + MDS + ML for "
     "MR), fitted in the same basis U on its own training cases. MDS and ML are their own "
     "twins. When the twin does worse than the method, the three parts measured against it "
     "(diagonalization, linearization, residual) are undefined (—).",
     "‖Ŵ<sub>c</sub> − W‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("diagonalization", "diagonalization",
     "What assuming diagonal Φ₁₁(t), Φ₁₂(t) and C(t) in the POM basis costs: the distance "
     "from the method's prediction to its coupled twin's. §3.6: “structures will not "
     "generally meet the conditions required for these matrices to be diagonal and the "
     "resulting error is called ‘diagonalization’ error.” 0 for MDS and ML.",
     "‖Ŵ − Ŵ<sub>c</sub>‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("linear-twin", "linear twin (structure)",
     "The same structure with its nonlinear elements removed (dashpots kept), driven by the "
     "same excitations: what the linearization columns compare with.", ""),
    ("linearization", "linearization",
     "What the structure's nonlinearity costs the coupled twin: its error relative to the "
     "POM span on the structure, minus the same on the linear twin. §3.6: the linear model "
     "“will be unable to predict these new effects and we call the resulting error "
     "‘linearization’ error.” 0 on a linear structure.",
     "‖(Ŵ<sub>c</sub> − PW) − (Ŵ<sub>c</sub><sup>lin</sup> − PW<sup>lin</sup>)‖<sub>F</sub>"
     " / ‖W‖<sub>F</sub>"),
    ("residual", "residual",
     "What remains when neither the diagonal assumption nor the nonlinearity is in play "
     "(the coupled twin on the linear twin): dynamics outside the span of U, time variance "
     "of the structure, deconvolution (§3.6: it “cannot be performed exactly when noise is "
     "present”) and numerics.",
     "‖Ŵ<sub>c</sub><sup>lin</sup> − PW<sup>lin</sup>‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("own-linearization", "own linearization",
     "The nonlinearity's share of the method's <em>own</em> error: the method itself "
     "refitted on the linear twin with the same POMs (Ŵ<sup>lin</sup>), not its coupled "
     "twin. 0 on a linear structure.",
     "‖(Ŵ − PW) − (Ŵ<sup>lin</sup> − PW<sup>lin</sup>)‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("linear-diagonalization", "diagonalization on linear twin",
     "The diagonal assumption's cost measured on the linear twin, where the nonlinearity "
     "cannot blur it: the method refitted there against its coupled twin refitted there. "
     "Equal to diagonalization on a linear structure; undefined when the twin does worse "
     "there than the method.",
     "‖Ŵ<sup>lin</sup> − Ŵ<sub>c</sub><sup>lin</sup>‖<sub>F</sub> / ‖W‖<sub>F</sub>"),
    ("eq42", "Eq. 4.2 median, p90",
     "The dissertation's plotted measure, the percent error of the displacement norm at "
     "each sample, summarized by its median and 90th percentile over the record. It grows "
     "without bound where ‖w(t)‖ nears zero (§4.1: “a very small number in the denominator "
     "of Eq. (4.2)”), hence the robust summaries.",
     "100 |‖ŵ(t)‖ − ‖w(t)‖| / ‖w(t)‖, ‖w(t)‖ the norm over the sensors (Eq. 4.1)"),
    ("peak-ratio", "peak ratio",
     "The amplitude of the predicted norm against the truth's (1 = the right peak).",
     "max<sub>t</sub> ‖ŵ(t)‖ / max<sub>t</sub> ‖w(t)‖"),
    ("undefined", "— (undefined)",
     "A part that is not a number for this row: the method has no POD basis (a peer), no "
     "coupled twin is declared, the twin failed, or the twin does worse than the method.", ""),
)
"""(anchor, term, meaning, formula) of every glossary entry, in the order shown."""

COLUMN_TERMS = {
    "n_modes": "k", "total_error": "total", "projection_error": "projection",
    "subspace_error": "subspace", "diagonalization_error": "diagonalization",
    "linearization_error": "linearization", "residual_error": "residual",
    "twin_error": "twin", "own_linearization_error": "own-linearization",
    "linear_diagonalization_error": "linear-diagonalization", "norm_pe_median": "eq42",
    "norm_pe_p90": "eq42", "norm_peak_ratio": "peak-ratio",
}
"""The glossary anchor of each ``summary.csv`` column the page shows."""


def term_link(column: str, text: str) -> str:
    """``text`` (HTML) as a link to the glossary entry of ``column`` (unchanged without
    one)."""
    anchor = COLUMN_TERMS.get(column)
    if anchor is None:
        return text
    return f'<a class="term" href="#g-{anchor}">{text}</a>'


def glossary_html() -> str:
    """The glossary as a definition list, one ``<div id="g-<anchor>">`` per term."""
    items = []
    for anchor, term, meaning, formula in GLOSSARY:
        f = f' <span class="formula">{formula}</span>' if formula else ""
        items.append(f'<div class="gl" id="g-{anchor}"><dt>{html.escape(term)}</dt>'
                     f"<dd>{meaning}{f}</dd></div>")
    return ('<p>The words of the tables, in brief; the exact definitions are under '
            '<a href="#decomposition">Error decomposition</a>. Ŵ is a method\'s prediction, '
            "W the truth (sensors × samples), U the method's k POMs, Ŵ<sub>c</sub> its "
            "coupled twin's prediction, <sup>lin</sup> the same on the linear twin. Every "
            "error is in percent of ‖W‖<sub>F</sub>.</p>"
            f'<dl class="glossary">{"".join(items)}</dl>')
