"""The base-excitation page's sentence (docs/studies/base_excited.md) is
results/base_excited/summary.csv (issue 23: numbers in the docs come from the tables, never
typed): ML predicts the LTI beam and the unbroken
truss to round-off (written ``<1e-08``) and the LTV and NL beams within the quoted range."""

import re
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def test_the_readme_base_excited_numbers_are_the_table():
    d = pd.read_csv(ROOT / "results" / "base_excited" / "summary.csv", dtype=str)
    ml = d[(d.method == "ML") & (d.status == "ok")]
    exact = ml[ml.structure.isin(["lti_beam", "satellite_truss_unbroken"])]
    assert len(exact) and (exact.total_error == "<1e-08").all()
    page = ROOT / "docs" / "studies" / "base_excited.md"
    text = " ".join(page.read_text(encoding="utf-8").split())
    m = re.search(r"the LTV and NL beams to ([0-9.]+)–([0-9.]+) %", text)
    assert m, f"{page.name}: the base-excited sentence changed its wording"
    err = pd.to_numeric(ml[ml.structure.isin(["ltv_beam", "nl_beam"])].total_error)
    assert m.groups() == (f"{100 * err.min():.1f}", f"{100 * err.max():.0f}")
