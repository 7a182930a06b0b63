"""docs/peers.md's table of the peers under noise is the median of results/peers_noise/sweep.csv
(issue 23: numbers in the docs come from the tables, never typed)."""

import math
import re
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def _cell(values: pd.Series, status: pd.Series) -> str:
    if (status != "ok").all():
        return "failed"
    x = float(values.median())
    return "failed" if math.isnan(x) else f"{x:.3g}"


def test_the_docs_table_is_the_sweeps_median_over_targets_and_seeds():
    df = pd.read_csv(ROOT / "results" / "peers_noise" / "sweep.csv")
    doc = (ROOT / "docs" / "peers.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- peers_noise:[^>]*-->\n(.*?)<!-- /peers_noise -->", doc, re.S)
    assert block, "docs/peers.md lost its peers_noise table markers"
    rows = [line.strip("|").split("|") for line in block.group(1).strip().splitlines()[2:]]
    seen = set()
    for structure, method, *cells in (map(str.strip, r) for r in rows):
        sub = df[(df.structure == structure) & (df.method == method)]
        assert len(sub), (structure, method)
        levels = sorted(sub.noise.unique())
        assert levels == [0.0, 0.01, 0.05]
        expected = [_cell(sub[sub.noise == lv].total_error, sub[sub.noise == lv].status)
                    for lv in levels]
        assert cells == expected, (structure, method)
        seen.add((structure, method))
    assert seen == set(zip(df.structure, df.method, strict=True))  # every sweep row is in the docs
