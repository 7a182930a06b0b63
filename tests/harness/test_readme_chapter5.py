"""The Chapter 5 paragraph of the studies' page (docs/studies/index.md, "Chapter 5 in
brief") is results/chapter5's tables (issue 23: numbers in the docs come from the tables,
never typed; issue 24: the paragraph says what the study found
in the text's terms): the headline counts are FINDINGS.md's, and the Eq. 4.2 medians it
quotes (the dissertation's TLS on the linear beam's load 4, percent) are summary.csv's and
seeds.csv's at the digits printed."""

import re
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = (ROOT / "docs" / "studies" / "index.md").read_text(encoding="utf-8")
PARAGRAPH = " ".join(PAGE.split("## Chapter 5 in brief", 1)[1].split("\n## ", 1)[0].split())
RESULTS = ROOT / "results" / "chapter5"


def _said(pattern: str) -> tuple:
    m = re.search(pattern, PARAGRAPH)
    assert m, f"docs/studies/index.md's Chapter 5 paragraph changed its wording: {pattern!r}"
    return m.groups()


@pytest.fixture(scope="module")
def summary():
    d = pd.read_csv(RESULTS / "summary.csv")
    return d[d.target == "load4"].set_index(["scenario", "method"]).norm_pe_median


def test_the_counts_are_findings_headline():
    findings = (RESULTS / "FINDINGS.md").read_text(encoding="utf-8")
    m = re.search(r"\*\*The text's claims: (\d+), each counted once under its best-supported "
                  r"reading: (\d+) reproduced, (\d+) not reproduced, (?:(\d+) tie within the "
                  r"noise seeds' spread, )?(?:(\d+) not measured, )?(\d+) not checkable",
                  findings)
    assert m, "FINDINGS.md lost its headline"
    total, reproduced, failed, ties, unmeasured, uncheckable = m.groups()
    said = _said(r"of the chapter's (\d+) claims.*?, (\d+) are reproduced, (\d+) are ties "
                 r"within the noise seeds' spread, (\d+) are not and (\d+) \(Figs\. "
                 r"5\.12–5\.13\) are not checkable")
    assert said == (total, reproduced, ties or "0", failed, uncheckable)
    assert unmeasured in (None, "0")  # the paragraph names no unmeasured claim


def _rng(values) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.1f}–{hi:.1f}"


def test_the_quoted_eq_4_2_medians_are_the_tables(summary):
    levels = ("linear_beam_noise_0pct", "linear_beam_noise_1pct", "linear_beam_noise_2pct")
    sl5 = summary[("linear_beam_noise_5pct", "SL-tls")]
    said = _said(r"SL's Eq\. 4\.2 median on the linear beam is ([0-9.]+) % at 5 %")
    assert said == (f"{sl5:.1f}",)
    said = _said(r"up to 2 % noise SL gives ([0-9.–]+) % and ML ([0-9.–]+) %")
    assert said == (_rng([summary[(s, "SL-tls")] for s in levels]),
                    _rng([summary[(s, "ML-tls")] for s in levels]))
    said = _said(r"the appendix as written, it is ([0-9.]+) % on seed 0")
    assert said == (f"{summary[('linear_beam_noise_5pct', 'SL-tls-tol1000')]:.1f}",)
    seeds = pd.read_csv(RESULTS / "seeds.csv")
    s = seeds[(seeds.scenario == "linear_beam_noise_5pct") & (seeds.method == "SL-tls-tol1000")
              & (seeds.target == "load4") & (seeds.seed > 0)]
    assert sorted(s.seed) == [1, 2, 3, 4]
    said = _said(r"and ([0-9.–]+) % on noise seeds 1–4")
    assert said == (_rng(s.norm_pe_median),)
