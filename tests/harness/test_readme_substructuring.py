"""The substructuring page's medians (docs/studies/substructuring.md) are
results/substructuring/medians.csv (issue 23: numbers in the docs come from the tables, never
typed). Each quoted median (implicit coupling, percent of the assembled truth, over the noise
seeds) is parsed from the page's sentence and compared with the table at the digits
printed."""

import re
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = " ".join((ROOT / "docs" / "studies" / "substructuring.md").read_text(
    encoding="utf-8").split())


@pytest.fixture(scope="module")
def medians():
    d = pd.read_csv(ROOT / "results" / "substructuring" / "medians.csv")
    return d[d.scheme == "implicit"]


def _median(d, component, kernel, records, noise, n_records=None) -> float:
    sel = d[(d.component == component) & (d.kernel == kernel) & (d.records == records)
            & (d.noise == noise)]
    if n_records is not None:
        sel = sel[sel.n_records == n_records]
    assert len(sel) == 1, (component, kernel, records, noise, n_records)
    return float(sel.median_error.iloc[0])


def _pct(x: float) -> str:
    """A median in percent at two significant digits, as the page writes it."""
    s = f"{100 * x:.2g}"
    return s if "e" not in s else f"{100 * x:.2f}"


def _said(pattern: str) -> tuple:
    m = re.search(pattern, PAGE)
    assert m, f"substructuring.md: the sentence {pattern!r} changed its wording"
    return m.groups()


def test_the_time_invariant_components_medians(medians):
    got = _said(r"from acceleration records: heavy chain ([0-9.]+) % / ([0-9.]+) % \(target.*?"
                r"light chain ([0-9.]+) % / ([0-9.]+) %; from velocity records \(heavy chain\) "
                r"([0-9.]+) % / ([0-9.]+) %; from displacement records \(1 %\) ([0-9.]+) % made "
                r"passive, while as fitted (\d) of (\d) seeds diverge")
    p = "lti_passive"
    disp = medians[(medians.component == "chain_heavy") & (medians.kernel == "lti")
                   & (medians.records == "displacement")].iloc[0]
    expected = tuple(_pct(_median(medians, c, p, r, n)) for c, r, n in (
        ("chain_heavy", "acceleration", 0.01), ("chain_heavy", "acceleration", 0.05),
        ("chain_light", "acceleration", 0.01), ("chain_light", "acceleration", 0.05),
        ("chain_heavy", "velocity", 0.01), ("chain_heavy", "velocity", 0.05),
        ("chain_heavy", "displacement", 0.01))) + (str(int(disp.diverged)), str(int(disp.seeds)))
    assert got == expected


def test_the_time_varying_tips_medians(medians):
    got = _said(r"identified time-varying tip: ([0-9.]+) % / ([0-9.]+) % from 2 records, "
                r"([0-9.]+) % / ([0-9.]+) % from 5, ([0-9.]+) % / ([0-9.]+) % from 50 .*?"
                r"a time-invariant kernel of the same records gives ~(\d+) %")
    expected = tuple(_pct(_median(medians, "tip_mass", "ltv", "acceleration", noise, n))
                     for n in (2, 5, 50) for noise in (0.01, 0.05))
    ti = _median(medians, "tip_mass", "lti", "acceleration", 0.01, 50)
    assert got == expected + (f"{100 * ti:.0f}",)
