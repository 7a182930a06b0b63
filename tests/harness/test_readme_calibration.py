"""The calibration page's table of the study's measures (docs/studies/calibration.md) is
results/calibration/calibration.csv (issue 23: numbers in the docs come from the tables, never
typed; issue 21's targets).

Each measured cell of the table is parsed by the template it is written in and compared with
the same measure computed here from the committed table, at the digits the page prints.
When the study is regenerated and a number moves, this test names the row to update."""

import re
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.stats import spearmanr

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "studies" / "calibration.md"
CLASSES = {"LTI": "LTI", "LTV": "LTV", "NL": "NL", "truss": "truss (LTV)"}


@pytest.fixture(scope="module")
def table():
    return pd.read_csv(ROOT / "results" / "calibration" / "calibration.csv")


@pytest.fixture(scope="module")
def rows():
    """``{first cell: measured cell}`` of the calibration page's table."""
    text = PAGE.read_text(encoding="utf-8")
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[1].startswith(("0.85", "≥", "≤")):
            out[cells[0]] = cells[2]
    return out


def _cell(rows, label):
    got = [v for k, v in rows.items() if k.startswith(label)]
    assert len(got) == 1, f"{PAGE.name}: the calibration table lost its row {label!r}"
    return got[0]


def _half_up(x: float, digits: int) -> float:
    """``x`` at ``digits`` decimals, halves rounded up, from its six significant digits (the
    table's): 0.995 is 1.00, as a reader rounds it, not 0.99 as binary floating point does."""
    return float(Decimal(f"{x:.6g}").quantize(Decimal(10) ** -digits, rounding=ROUND_HALF_UP))


def _ratio(d):
    return d.error_estimate / d.total_error


def _within2(d) -> float:
    return float(_ratio(d).between(0.5, 2.0).mean())


def _best_constant(d) -> int:
    """How many of ``d``'s estimates the best constant c puts within ×2 of the realized error
    (c·estimate/realized in [0.5, 2]); an optimal c puts one ratio on an edge of the window,
    so those candidates suffice (an oracle: c is chosen knowing the truth)."""
    r = _ratio(d).to_numpy()
    cands = np.concatenate([0.5 / r, 2.0 / r])
    return max(int(np.sum((c * r >= 0.5 - 1e-12) & (c * r <= 2.0 + 1e-12))) for c in cands)


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def _spearman(d) -> float:
    return float(spearmanr(d.error_estimate, d.total_error).statistic)


def _is_ratio(d) -> float:
    return float(d.interval_score.sum() / d.constant_interval_score.sum())


def test_coverage_by_class_is_the_tables(table, rows):
    """ML's and MDS's mean coverage per class and training noise, the range over both
    families and the three noise levels."""
    cell = _cell(rows, "90 % band coverage, ML and MDS")
    for name, cls in CLASSES.items():
        m = re.search(rf"\b{re.escape(name)} ([0-9.]+)–([0-9.]+)", cell)
        assert m, f"{PAGE.name} calibration row: no range for {name}"
        sub = table[(table["class"] == cls) & table.method.str.match(r"^(ML|MDS)\d")]
        means = [g.coverage.mean() for fam in ("ML", "MDS")
                 for _, g in sub[sub.method.str.startswith(fam)].groupby("training_noise")]
        lo, hi = _half_up(min(means), 2), _half_up(max(means), 2)
        assert (float(m.group(1)), float(m.group(2))) == (lo, hi), (name, lo, hi)


def test_spearman_is_the_tables(table, rows):
    cell = _cell(rows, "Spearman(error_estimate, total_error)")
    m = re.fullmatch(r"([0-9.]+) over all (\d+); ([0-9.]+) over the (\d+) cross-validated; "
                     r"SL ([0-9.]+)", cell)
    assert m, f"{PAGE.name}: the Spearman row changed its wording: {cell!r}"
    cv = table[table.source == "cross-validation"]
    sl = table[table.method == "SL"]
    expected = (f"{_spearman(table):.2f}", str(len(table)), f"{_spearman(cv):.2f}",
                str(len(cv)), f"{_spearman(sl):.2f}")
    assert m.groups() == expected


def test_within_a_factor_of_two_is_the_tables(table, rows):
    cell = _cell(rows, "estimate within a factor of 2")
    m = re.match(r"(\d+ %) \(cross-validated: (\d+ %), median ratio ×([0-9.]+); SL (\d+ %), "
                 r"median ratio ×([0-9.]+); POVR (\d+ %)\); the best constant rescaling of "
                 r"all estimates reaches (\d+ %), one constant per fitted model \(method, "
                 r"class, training noise: (\d+) models\) chosen knowing the truth (\d+ %)",
                 cell)
    assert m, f"{PAGE.name}: the within-×2 row changed its wording: {cell!r}"
    cv = table[table.source == "cross-validation"]
    sl = table[table.method == "SL"]
    povr = table[table.method == "POVR"]
    models = table.groupby(["method", "class", "training_noise"])
    per_model = sum(_best_constant(g) for _, g in models) / len(table)
    expected = (_pct(_within2(table)), _pct(_within2(cv)), f"{_ratio(cv).median():.1f}",
                _pct(_within2(sl)), f"{_ratio(sl).median():.1f}", _pct(_within2(povr)),
                _pct(_best_constant(table) / len(table)), str(models.ngroups), _pct(per_model))
    assert m.groups() == expected


def test_interval_score_ratios_are_the_tables(table, rows):
    cell = _cell(rows, "interval score / best constant width")
    m = re.match(r"([0-9.]+) over all (\d+) \(SL ([0-9.]+), POVR ([0-9.]+)\), ([0-9.]+) over "
                 r"the beams, ([0-9.]+) cross-validated", cell)
    assert m, f"{PAGE.name}: the interval-score row changed its wording: {cell!r}"
    beams = table[~table["class"].str.startswith("truss")]
    expected = (f"{_is_ratio(table):.2f}", str(len(table)),
                f"{_is_ratio(table[table.method == 'SL']):.2f}",
                f"{_is_ratio(table[table.method == 'POVR']):.2f}", f"{_is_ratio(beams):.2f}",
                f"{_is_ratio(table[table.source == 'cross-validation']):.2f}")
    assert m.groups() == expected
