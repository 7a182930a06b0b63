"""The studies' tables of the docs (docs/studies/index.md, docs/getting-started.md) state how
many scenarios and rows each study has: each count equals the committed table's."""

import csv
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["docs/studies/index.md", "docs/getting-started.md"]


def _stated():
    """``(page, study, what, stated count)`` of every "N scenarios" / "N rows" in a row of
    the studies' tables (``| `podbench run STUDY` | …``)."""
    out = []
    for page in PAGES:
        for line in (ROOT / page).read_text(encoding="utf-8").splitlines():
            m = re.match(r"\| `podbench (?:run|sweep) (?:sweeps/)?(\w+)`", line)
            if m:
                for n, what in re.findall(r"(\d+) (scenarios|rows)\b", line):
                    out.append((page, m.group(1), what, int(n)))
    return out


STATED = _stated()


def test_the_tables_state_the_counts_of_the_two_chapters():
    assert {(p, s, w) for p, s, w, _ in STATED} >= {
        (p, s, w) for p in PAGES for s in ("chapter4", "chapter5") for w in ("scenarios", "rows")}


@pytest.mark.parametrize("page, study, what, n", STATED)
def test_a_stated_count_is_the_committed_tables(page, study, what, n):
    folder = ROOT / "results" / study
    table = folder / "summary.csv" if (folder / "summary.csv").is_file() else folder / "sweep.csv"
    with open(table, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    got = len(rows) if what == "rows" else len({r["scenario"] for r in rows})
    assert got == n, f"{page}: {study}: {n} {what} stated, {table.relative_to(ROOT)} has {got}"
