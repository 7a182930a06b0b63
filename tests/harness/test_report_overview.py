"""The report page's reading aids: the summary's ranking of methods, the notes that explain a
total error of 100 % or more by the part of the decomposition that carries it, the glossary
the column heads link to, and the page's outline (summary first, a Modes section where one
is given, the header's figure count equal to the images drawn)."""

import math
import re

import pandas as pd

from podbench.report.glossary import COLUMN_TERMS, GLOSSARY, glossary_html
from podbench.report.html import SUMMARY_COLUMNS, render_report
from podbench.report.overview import large_error_html, large_errors, ranking, summary_rows

NAN = math.nan


def _row(structure, method, target, total, proj=NAN, diag=NAN, lin=NAN, res=NAN, twin=NAN,
         sub=NAN, status="ok"):
    return {"scenario": "beam_forced", "structure": structure, "method": method,
            "target": target, "n_modes": 4, "total_error": total, "projection_error": proj,
            "subspace_error": sub, "diagonalization_error": diag,
            "linearization_error": lin, "residual_error": res, "twin_error": twin,
            "status": status}


def _df():
    return pd.DataFrame([
        # SL on the LTI beam: its diagonal assumption carries the error, ML reaches 3 %
        _row("lti_beam", "SL", "load5", 9.36, 0.004, 9.36, 0.0, 0.03, 0.0325, 9.36),
        _row("lti_beam", "SL", "load5_half", 9.17, 0.004, 9.17, 0.0, 0.03, 0.03, 9.17),
        _row("lti_beam", "ML", "load5", 0.0325, 0.004, 0.0, 0.0, 0.03, 0.0325, 0.032),
        _row("lti_beam", "ML", "load5_half", 0.0121, 0.004, 0.0, 0.0, 0.01, 0.0121, 0.011),
        # a peer without a POD basis, a failed method
        _row("lti_beam", "ERA", "load5", 1.5),
        _row("lti_beam", "POVR", "load5", NAN, status="failed: singular"),
    ])


def test_methods_rank_by_their_median_total_error_failed_last():
    r = ranking(_df())
    assert [x[0] for x in r] == ["ML", "ERA", "SL", "POVR"]
    assert r[0][1:] == (0.0223, 2, 0)  # median of 3.25 % and 1.21 %
    assert r[2][1] == (9.36 + 9.17) / 2
    assert math.isnan(r[3][1]) and r[3][3] == 1
    (s,) = summary_rows(_df())
    assert s["best"][0] == "ML" and s["worst"][0] == "SL" and s["off"] == 3
    assert s["failed"] == ["POVR"]


def test_a_large_error_is_explained_by_the_part_that_carries_it():
    items = {it["method"]: it for it in large_errors(_df())}
    assert set(items) == {"SL", "ERA"}  # ML is under 100 %; POVR failed (no total)
    assert items["SL"]["main"] == "diagonalization_error"
    assert items["SL"]["targets"] == [("load5", 9.36), ("load5_half", 9.17)]
    assert items["ERA"]["main"] is None
    page = large_error_html("beam_forced", _df())
    text = re.sub(r"<[^>]+>", "", page)
    assert "SL on lti_beam (load5 936 %, load5_half 917 %)" in text
    assert "diagonal assumption" in text and "reaches 3.25 %" in text
    assert "ERA on lti_beam" in text and "no POD basis" in text
    assert 'id="why-beam_forced-lti_beam-SL"' in page


def test_every_column_head_of_the_tables_has_a_glossary_entry():
    anchors = {a for a, *_ in GLOSSARY}
    assert len(anchors) == len(GLOSSARY)
    shown = [c for c, _, kind in SUMMARY_COLUMNS if kind is not None or c == "n_modes"]
    assert set(shown) == set(COLUMN_TERMS) and set(COLUMN_TERMS.values()) <= anchors
    page = glossary_html()
    for anchor in anchors:
        assert f'id="g-{anchor}"' in page


def _page(**kw):
    df = _df()
    uri = "data:image/png;base64,AAAA"
    figures = {"beam_forced": [{"uri": uri, "alt": "a", "caption": "c", "wide": True,
                                "unit": "in"}]}
    return render_report(study="s", df=df, fits=None, scenarios={}, figures=figures,
                         decompositions={"beam_forced": uri}, command="podbench run s",
                         seconds=12.3, figure_seconds=4.5, responses=(3, 1), **kw)


def test_the_page_opens_on_its_summary_and_has_a_place_for_modes():
    page = _page(modes="<p>MODES TABLE</p>", calibration="<p>CAL</p>")
    order = [page.index(f'id="{i}"') for i in ("summary", "results", "sc-beam_forced",
                                               "modes", "calibration", "findings",
                                               "glossary")]
    assert order == sorted(order)
    assert '<a href="#modes">Modes</a>' in page and "MODES TABLE" in page
    # the header counts the images on the page: one figure and one decomposition
    n_img = page.count("<img ")
    assert n_img == 2
    assert re.search(r"<b>2</b><span>figures on this page</span>", page)
    assert "Simulating and fitting took 12.3 s (3 truth responses simulated, 1 read" in page
    # a total of 100 % or more is marked in its table and linked to its explanation
    assert page.count('href="#why-beam_forced-lti_beam-SL"') == 2
    assert 'href="#why-beam_forced-lti_beam-ERA"' in page
    # every column head of the table links to its glossary entry
    assert page.count('<a class="term" href="#g-total">total</a>') == 1
    assert 'id="modes"' not in _page()
