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


BEAMS = {"LTI": "lti_beam", "LTV": "ltv_beam", "NL": "nl_beam"}
TARGETS = ("load5", "load5_half_sine", "double_hit_20")


def _peers_rows(text: str):
    """Rows ``| LTI | ERA (order 24) | 0.0274 | 0.0037 | 0.0139 |`` of a peers table."""
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[0] in BEAMS and re.fullmatch(r"[0-9.]+", cells[2]):
            yield BEAMS[cells[0]], cells[1], cells[2:]


def _close(printed: str, value: float) -> bool:
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    return abs(float(printed) - value) <= 0.5 * 10 ** -decimals + 1e-12


def test_the_readme_and_docs_peers_tables_are_results_peers():
    """docs/peers.md's table of the peers study states results/peers's total errors (to the
    digits it prints; the README's copy of the table moved there)."""
    df = pd.read_csv(ROOT / "results" / "peers" / "summary.csv").set_index(
        ["structure", "method", "target"])
    keys = set(df.index)
    n = 0
    for doc in ("docs/peers.md",):
        for structure, label, cells in _peers_rows((ROOT / doc).read_text(encoding="utf-8")):
            method = label if (structure, label, TARGETS[0]) in keys else \
                re.sub(r"\s*\(.*\)$", "", label)
            if (structure, method, TARGETS[0]) not in keys:
                continue  # a row of the free-decay table (other targets)
            for target, printed in zip(TARGETS, cells, strict=True):
                value = float(df.loc[(structure, method, target), "total_error"])
                assert _close(printed, value), (doc, structure, label, target, printed, value)
            n += 1
    assert n == 15  # 12 rows of ML and the peers, 3 of ML (basis all)


def test_the_readme_peers_paragraphs_numbers_are_results_peers():
    """The numbers of docs/peers.md's summary ("In short"): ML (basis all) on the LTV beam,
    ERA's distance from its ML twin on the LTI beam, ML's linearization error on the NL beam's
    half-sine and ERA from free decays against MDS."""
    df = pd.read_csv(ROOT / "results" / "peers" / "summary.csv")
    text = " ".join((ROOT / "docs" / "peers.md").read_text(encoding="utf-8").split())

    def err(structure, method, target, column="total_error"):
        sel = df[(df.structure == structure) & (df.method == method) & (df.target == target)]
        assert len(sel) == 1, (structure, method, target)
        return float(sel[column].iloc[0])

    m = re.search(r'"ML \(basis all\)" gives ([0-9.]+) / ([0-9.]+) / ([0-9.]+) on the LTV', text)
    assert m and m.groups() == tuple(f"{err('ltv_beam', 'ML (basis all)', t):.3f}"
                                     for t in TARGETS)
    m = re.search(r"ERA's error is within ([0-9.e-]+) of ML fitted in ERA's basis", text)
    gap = max(abs(err("lti_beam", "ERA", t) - err("lti_beam", "ERA", t, "twin_error"))
              for t in TARGETS)
    assert m and gap <= float(m.group(1)) < 10 * gap
    m = re.search(r"ML's linearization column ([0-9.]+)\)", text)
    assert m and m.group(1) == f"{err('nl_beam', 'ML', TARGETS[1], 'linearization_error'):.2f}"
    m = re.search(r"equal to MDS on the LTI beam \(w3 ([0-9.]+), v4 ([0-9.]+)\), worse on the "
                  r"LTV beam \(v4 ([0-9.]+) vs ([0-9.]+)\)", text)
    assert m and m.groups() == (f"{err('lti_beam', 'ERA-free', 'w3'):.3g}",
                                f"{err('lti_beam', 'ERA-free', 'v4'):.3g}",
                                f"{err('ltv_beam', 'ERA-free', 'v4'):.3g}",
                                f"{err('ltv_beam', 'MDS', 'v4'):.3g}")
    assert f"{err('lti_beam', 'MDS', 'w3'):.3g}" == m.group(1)  # "equal to MDS"


def test_the_docs_free_decay_table_is_results_peers():
    """docs/peers.md's free-decay table (MDS, MDS in all records' basis, ERA from free
    decays; targets w3, w3 × 3, v4) states results/peers's total errors to its digits."""
    df = pd.read_csv(ROOT / "results" / "peers" / "summary.csv").set_index(
        ["structure", "method", "target"])
    fits = pd.read_csv(ROOT / "results" / "peers" / "fits.csv").set_index(
        ["scenario", "structure", "method"]).order
    text = (ROOT / "docs" / "peers.md").read_text(encoding="utf-8")
    n = 0
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or cells[0] not in BEAMS or not cells[1].startswith(("MDS", "ERA-")):
            continue
        method = re.sub(r"\s*\(order.*\)$", "", cells[1])
        orders = re.search(r"\(order (\d+) / (\d+)\)", cells[1])
        if orders:  # the realization orders the hold-out rule chose, displacement / velocity
            assert orders.groups() == tuple(
                str(int(fits[(f"peers_free_{kind}", BEAMS[cells[0]], method)]))
                for kind in ("displacement", "velocity")), cells[:2]
        for target, printed in zip(("w3", "w3_x3", "v4"), cells[2:], strict=True):
            value = float(df.loc[(BEAMS[cells[0]], method, target), "total_error"])
            assert _close(printed, value), (cells[0], cells[1], target, printed, value)
        n += 1
    assert n == 9
