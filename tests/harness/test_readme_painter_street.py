"""The Painter Street page's numbers (docs/studies/painter_street.md) are
results/painter_street's tables (issue 23: numbers in the docs come from the tables, never
typed): the table of mean errors over the 14
events and the paragraph's figures (ML-TC's errors, its band's coverage, its error
estimate's factor-of-2 count and rank correlation). A regenerated study that moves one of
them fails here, naming it."""

import re
from pathlib import Path

import pandas as pd
import pytest
from scipy.stats import spearmanr

ROOT = Path(__file__).resolve().parents[2]
SECTION = (ROOT / "docs" / "studies" / "painter_street.md").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def summary():
    return pd.read_csv(ROOT / "results" / "painter_street" / "summary.csv").set_index(
        ["inputs", "method"])


@pytest.fixture(scope="module")
def tc_events():
    d = pd.read_csv(ROOT / "results" / "painter_street" / "errors.csv")
    return d[(d.method == "ML-TC") & (d.inputs == "three")]


def _label_methods(label: str) -> list[str]:
    """The summary's method names of a table row's label."""
    if "mdof" in label:
        return ["mdof-SRIM", "mdof-OKID-ERA"]
    if "peers" in label:
        return ["ERA", "DMDc", "OpInf"]
    if "TC-prior" in label:
        return ["ML-TC"]
    if label.startswith("ML"):
        return ["ML"]
    return ["FIR-LS"]


def test_the_table_of_mean_errors_is_the_summary(summary):
    n = 0
    for line in SECTION.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or not cells[0].endswith("channels"):
            continue
        inputs = "three" if cells[0].startswith("3 ") else "ground"
        printed = re.findall(r"\d\.\d{3}", cells[2].split("(")[0])
        expected = [f"{summary.loc[(inputs, m), 'mean_error']:.3f}"
                    for m in _label_methods(cells[1])]
        assert printed == expected, (cells[0], cells[1])
        n += 1
    assert n == 7


def test_the_paragraphs_numbers_are_the_tables(summary, tc_events):
    text = " ".join(SECTION.split())
    three = summary.loc[("three", "ML-TC")]
    ground = summary.loc[("ground", "ML-TC")]
    m = re.search(r"to about (\d+) % \(three inputs\) or (\d+) % \(all nine", text)
    assert m and m.groups() == (f"{100 * three.mean_error:.0f}",
                                f"{100 * ground.mean_error:.0f}")
    m = re.search(r"The worst event \((\d\.\d+)\)", text)
    assert m and m.group(1) == f"{three.max_error:.2f}"
    m = re.search(r"ML-TC: (\d\.\d+) of the measured deck samples inside the 90 % band, "
                  r"(\d\.\d+)–(\d\.\d+) per event; the estimate within a factor 2 of the "
                  r"realized error for (\d+) of (\d+) events[^;:]*: Spearman (−?\d\.\d+)",
                  text)
    assert m, "painter_street.md: the Painter Street band sentence changed its wording"
    rho = spearmanr(tc_events.error_estimate, tc_events.total_error).statistic
    expected = (f"{three.mean_coverage:.3f}", f"{tc_events.coverage.min():.2f}",
                f"{tc_events.coverage.max():.2f}",
                f"{round(three.estimate_within_2 * len(tc_events))}", str(len(tc_events)),
                f"{rho:.2f}".replace("-", "−"))
    assert m.groups() == expected
