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


def _wall(minutes: float) -> str:
    """A MANIFEST time as the docs write it: seconds below 2 min, else minutes to 0.1."""
    return f"{round(minutes * 60)} s" if minutes < 2 else f"{minutes:.1f} min"


def _manifest() -> dict:
    import tomllib

    return tomllib.loads((ROOT / "results" / "MANIFEST.toml").read_text(encoding="utf-8"))


def test_the_studies_table_gives_each_manifest_time():
    manifest = _manifest()
    table = {}
    for line in (ROOT / "docs" / "studies" / "index.md").read_text(encoding="utf-8").splitlines():
        m = re.match(r"\| `(podbench [^`]+)`[^|]*\|.*\| ([^|]+) \|$", line)
        if m:
            table[m.group(1)] = m.group(2).strip()
    timed = {e["command"]: e for e in manifest.values() if "minutes" in e}
    assert set(timed) <= set(table), set(timed) - set(table)
    for command, e in timed.items():
        assert table[command].startswith(_wall(e["minutes"])), (command, table[command])


@pytest.mark.parametrize("page, study", [
    ("docs/studies/chapter4.md", "chapter4"), ("docs/studies/calibration.md", "calibration"),
    ("docs/studies/base_excited.md", "base_excited"),
    ("docs/studies/substructuring.md", "substructuring"),
    ("docs/studies/painter_street.md", "painter_street"), ("docs/chapter5.md", "chapter5"),
    ("docs/studies/f16_gvt.md", "f16_gvt"), ("docs/studies/regression.md", "baseline"),
])
def test_a_study_page_gives_its_time_beside_its_command(page, study):
    entry = _manifest()[study]
    text = (ROOT / page).read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if entry["command"] in ln]
    assert any(_wall(entry["minutes"]) in ln for ln in lines[:3]), (page, lines[:3])
