"""Claim checks: the grammar, the verdicts on a known table, and the decomposition helpers."""

import math

import numpy as np
import pandas as pd
import pytest

from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.harness.metrics import decompose, norm_summaries
from podbench.study.claims import evaluate_claims, load_claims

TABLE = pd.DataFrame([
    {"scenario": "s", "structure": "a", "method": "POVR", "target": "t", "total_error": 0.3,
     "projection_error": 0.01},
    {"scenario": "s", "structure": "a", "method": "MDS", "target": "t", "total_error": 0.02,
     "projection_error": 0.01},
    {"scenario": "s", "structure": "b", "method": "MDS", "target": "t", "total_error": 0.2,
     "projection_error": float("nan")},
])


def _claims(tmp_path, body):
    p = tmp_path / "claims.toml"
    p.write_text(body)
    return load_claims(p)


def test_verdicts(tmp_path):
    claims, remarks = _claims(tmp_path, """
[[claims]]
id = "one"
source = "§x"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05", "MDS.total_error < POVR.total_error"]
[[claims]]
id = "two"
source = "§x"
quote = "q"
scenario = "s"
structure = ["a", "b"]
target = "t"
checks = ["MDS.total_error <= 0.1"]
[[claims]]
id = "three"
source = "§x"
quote = "q"
scenario = "s"
structure = "b"
target = "t"
checks = ["MDS.projection_error < 1", "POVR.total_error > 0"]
[[remarks]]
title = "r"
text = "t"
""")
    v = {e["claim"].id: e["verdict"] for e in evaluate_claims(claims, TABLE)}
    assert v == {"one": "reproduced", "two": "not reproduced", "three": "not measured"}
    assert remarks == [{"title": "r", "text": "t"}]


@pytest.mark.parametrize("check", ["MDS.total_error", "MDS.total_error == 1", "< 3",
                                   "MDS.total_error < < 2"])
def test_bad_checks_are_rejected(tmp_path, check):
    with pytest.raises(ScenarioFileError, match="checks"):
        _claims(tmp_path, f"""
[[claims]]
id = "x"
source = "s"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["{check}"]
""")


def test_decompose_on_constructed_matrices():
    rng = np.random.default_rng(0)
    U, _ = np.linalg.qr(rng.standard_normal((8, 3)))
    W = rng.standard_normal((8, 40))
    PW = U @ U.T @ W
    W_hat = PW + U @ rng.standard_normal((3, 40)) * 0.1
    d = decompose(W, W_hat, U, coupled=True)
    N = np.linalg.norm(W)
    assert d["projection_error"] == pytest.approx(np.linalg.norm(W - PW) / N)
    assert d["diagonalization_error"] == 0 and d["linearization_error"] == 0
    assert d["residual_error"] == pytest.approx(np.linalg.norm(W_hat - PW) / N)
    # with the full basis the projection error vanishes
    Q, _ = np.linalg.qr(rng.standard_normal((8, 8)))
    assert decompose(W, W, Q, coupled=True)["projection_error"] < 1e-14
    # zero truth: every error is undefined rather than infinite
    assert all(math.isnan(v) for v in decompose(0 * W, W, U).values())
    s = norm_summaries(W, 1.1 * W)
    assert s["norm_pe_median"] == pytest.approx(10.0) and s["norm_peak_ratio"] == pytest.approx(1.1)


def test_percent_error_conclusions_are_judged_on_the_percent_error_alone():
    """§4.3: "accurate predictions with percent error generally less than 10% for initial
    displacements and loads and 20% for initial velocities" defines "accurate" by the Eq. 4.2
    percent error; those claims check norm_pe_median only (issue 11, item 6)."""

    from podbench.study.claims import CHECK_RE

    path = bundled_scenarios() / "chapter4" / "claims.toml"
    claims, _ = load_claims(path)
    chosen = [c for c in claims if "with percent error generally less than 10%" in c.quote]
    assert {c.id for c in chosen} == {
        "conclusion-linear-beams-mds-disp-under-10pct",
        "conclusion-linear-beams-ml-load-under-10pct",
        "conclusion-linear-beams-mds-velocity-under-20pct"}
    for c in chosen:
        for chk in c.checks:
            m = CHECK_RE.match(chk)
            assert m.group(1).endswith(".norm_pe_median"), (c.id, chk)
            assert float(m.group(3)) == (20.0 if "velocity" in c.id else 10.0)


def test_a_finding_is_shown_in_the_findings_table(tmp_path):
    """The optional one-line `finding` fills the table's 'explained by' column; claims
    without one show a dash, and a file without any keeps the three-column table."""
    from podbench.report.study import findings_markdown

    claims, _ = _claims(tmp_path, """
[[claims]]
id = "one"
source = "§x"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05"]
finding = "MDS is exact here"
[[claims]]
id = "two"
source = "§y"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["POVR.total_error < 0.05"]
""")
    text = findings_markdown(evaluate_claims(claims, TABLE), [], "claims.toml")
    assert "| claim | source | verdict | explained by (measured) |" in text
    assert "| [one](#one) | §x | reproduced | MDS is exact here |" in text
    assert "| [two](#two) | §y | not reproduced | — |" in text
    assert "*In one line:* MDS is exact here" in text
    plain = findings_markdown(evaluate_claims(claims[1:], TABLE), [], "claims.toml")
    assert "| claim | source | verdict |\n|---|---|---|\n" in plain


def test_text_claims_are_counted_once_and_variants_apart(tmp_path):
    """Issue 24 item 4: a claim and its `part_of` entry count once (not reproduced when a
    part fails), a `variant` is listed under "also judged" and not counted, a claim with
    `checkable = false` is "not checkable under the literal reading" whatever its checks."""
    from podbench.report.study import findings_markdown

    claims, remarks = _claims(tmp_path, """
[[claims]]
id = "main-a"
source = "§x"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05"]
[[claims]]
id = "main-a-on-b"
source = "§x"
quote = "q"
part_of = "main-a"
scenario = "s"
structure = "b"
target = "t"
checks = ["MDS.total_error < 0.05"]
[[claims]]
id = "main-c"
source = "§x"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["POVR.total_error > 0.1"]
[[claims]]
id = "main-c-variant"
source = "§x"
quote = "q"
variant = "another reading"
scenario = "s"
structure = "a"
target = "t"
checks = ["POVR.total_error < 0.1"]
[[claims]]
id = "literal"
source = "§x"
quote = "q"
checkable = false
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05"]
""")
    ev = evaluate_claims(claims, TABLE)
    text = findings_markdown(ev, remarks, "claims.toml")
    head = text.split("## Also judged")[0]
    assert ("**The text's claims: 3, each counted once under its best-supported reading: 1 "
            "reproduced, 1 not reproduced, 0 not measured, 1 not checkable under the literal "
            "reading.**") in head
    assert "[main-a](#main-a) + [main-a-on-b](#main-a-on-b) | §x | not reproduced" in head
    assert "main-c-variant" not in head
    also = text.split("## Also judged")[1].split("## Every entry")[0]
    assert "1 entries judge the same sentences" in also and "main-c-variant" in also
    assert "— another reading | §x | not reproduced" in also
    with pytest.raises(ScenarioFileError, match="part_of"):
        _claims(tmp_path, """
[[claims]]
id = "x"
source = "§x"
quote = "q"
part_of = "nope"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05"]
""")
