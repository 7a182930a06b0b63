"""docs/chapter5.md's "Over noise seeds" table quotes the committed results/chapter5/seeds.csv
(issue 24 item 8: the prose and the study agree)."""

from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "chapter5.md"
SEEDS = ROOT / "results" / "chapter5" / "seeds.csv"


def _rows():
    text = DOC.read_text(encoding="utf-8")
    start = text.index("## Over noise seeds")
    section = text[start:text.index("\n## ", start + 5)]
    return [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in section.splitlines()
            if line.startswith(("| linear_beam |", "| rubber_band_beam |"))]


def _series(sub, method: str, column: str) -> str:
    rows = sub[sub.method == method].sort_values("seed")
    return " / ".join(f"{v:.3g}" for v in rows[column])


@pytest.mark.skipif(not SEEDS.is_file(), reason="results/chapter5/seeds.csv not generated")
def test_the_seed_table_of_the_chapter5_doc_is_seeds_csv():
    df = pd.read_csv(SEEDS)
    rows = _rows()
    assert len(rows) == 8  # two beams, four noise levels
    for beam, noise, seeds, ml, sl, ahead, sl_med, ml_med in rows:
        scenario = f"{beam}_noise_{noise.replace(' %', '').replace('.', 'p')}pct"
        sub = df[(df.scenario == scenario) & (df.target == "load4")]
        assert seeds == ",".join(str(k) for k in sorted(sub.seed.unique())), scenario
        assert ml == _series(sub, "ML-tls", "total_error"), scenario
        assert sl == _series(sub, "SL-tls", "total_error"), scenario
        assert sl_med == _series(sub, "SL-tls", "norm_pe_median"), scenario
        assert ml_med == _series(sub, "ML-tls", "norm_pe_median"), scenario
        m = sub[sub.method == "ML-tls"].sort_values("seed").total_error.to_numpy()
        s = sub[sub.method == "SL-tls"].sort_values("seed").total_error.to_numpy()
        assert ahead == f"{int((m < s).sum())} of {len(m)}", scenario
