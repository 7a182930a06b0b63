"""Claim checks: the grammar, the verdicts on a known table, and the decomposition helpers."""

import math

import numpy as np
import pandas as pd
import pytest

from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.harness.metrics import decompose, norm_summaries
from podbench.study.claims import evaluate_claims, load_claims, load_claims_file

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
    v = {e.claim.id: e.verdict for e in evaluate_claims(claims, TABLE)}
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

    path = bundled_scenarios() / "chapter4" / "claims.toml"
    claims, _ = load_claims(path)
    chosen = [c for c in claims if "with percent error generally less than 10%" in c.quote]
    assert {c.id for c in chosen} == {
        "conclusion-linear-beams-mds-disp-under-10pct",
        "conclusion-linear-beams-ml-load-under-10pct",
        "conclusion-linear-beams-mds-velocity-under-20pct"}
    for c in chosen:
        for chk in c.checks:
            assert chk.left.metric == "norm_pe_median" and chk.right.is_number, (c.id, chk)
            assert chk.right.number == (20.0 if "velocity" in c.id else 10.0)


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
checks = ["MDS.total_error < 0.06"]
""")
    ev = evaluate_claims(claims, TABLE)
    text = findings_markdown(ev, remarks, "claims.toml")
    head = text.split("## Also judged")[0]
    assert ("**The text's claims: 3, each counted once under its best-supported reading: 1 "
            "reproduced, 1 not reproduced, 1 not checkable under the literal reading.**") in head
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


def test_one_precedence_rule_for_checks_scenarios_and_parts():
    """A failing part outranks a missing value, which outranks a tie; none: reproduced.
    The same rule combines a claim's checks, its scenarios and a claim with its parts."""
    from podbench.study.claims import Outcome, Verdict, combine

    assert combine([]) is Verdict.REPRODUCED
    assert combine([Outcome.HOLDS, Outcome.TIE]) is Verdict.TIE
    assert combine([Outcome.TIE, Outcome.NOT_MEASURED]) is Verdict.NOT_MEASURED
    assert combine([Outcome.NOT_MEASURED, Outcome.FAILS, Outcome.TIE]) is Verdict.NOT_REPRODUCED
    assert combine(["reproduced", "tie within the noise seeds' spread"]) is Verdict.TIE
    assert Verdict.TIE == "tie within the noise seeds' spread"
    assert f"{Verdict.TIE}" == Verdict.TIE.value


def test_a_check_is_parsed_once_into_its_operands():
    from podbench.study.claims import Check

    c = Check.parse("ML-tls.norm_pe_median <= 1.1*clean/b/t:ML-tls.norm_pe_median + 10")
    assert (c.left.label, c.left.metric, c.op) == ("ML-tls", "norm_pe_median", "<=")
    r = c.right
    assert (r.scenario, r.structure, r.target, r.label, r.factor, r.offset) == (
        "clean", "b", "t", "ML-tls", 1.1, 10.0)
    assert c.is_comparison and not Check.parse("A.x < 2").is_comparison
    assert c.rows("s", "a", "u") == [("s", "a", "u", "ML-tls", "norm_pe_median"),
                                     ("clean", "b", "t", "ML-tls", "norm_pe_median")]
    rows = {"ML-tls": {"norm_pe_median": 25.0}}
    a, b, shown = c.values(lambda sc, st, tg: rows if sc == "s" else
                           {"ML-tls": {"norm_pe_median": 10.0}}, "s", "a", "u")
    assert (a, b) == (25.0, pytest.approx(21.0)) and not c.holds(a, b)


def test_a_restatement_is_judged_once_with_its_claim(tmp_path):
    """Two counted entries with the same checks on the same rows are refused (one line
    naming the field); the later sentence is the claim's `restated`, quoted in FINDINGS."""
    from podbench.report.study import findings_markdown

    one = """
[[claims]]
id = "{id}"
source = "§x"
quote = "{q}"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05"]
"""
    extra = ("\n[[claims]]\nid = \"v\"\nsource = \"§x\"\nquote = \"q\"\nvariant = \"r\"\n"
             "scenario = \"s\"\nstructure = \"a\"\ntarget = \"t\"\n"
             "checks = [\"MDS.total_error < 0.05\"]\n")
    with pytest.raises(ScenarioFileError, match=r"claims\[1\].checks`: the same checks on the same "
                                                r"rows as claim \"first\"") as exc:
        _claims(tmp_path, one.format(id="first", q="q1") + one.format(id="again", q="q2")
                + extra)
    assert "\n" not in str(exc.value)
    body = one.format(id="first", q="q1").replace(
        'checks =', 'restated = [{ source = "§y", quote = "q2" }]\nchecks =') + extra
    claims, _ = _claims(tmp_path, body)
    assert claims[0].restated == (("§y", "q2"),)
    text = findings_markdown(evaluate_claims(claims, TABLE), [], "claims.toml")
    assert "*Restated (§y)*: “q2”" in text and "The text's claims: 1," in text


def test_a_claim_over_the_noise_series_is_counted_at_the_suggested_level(tmp_path):
    """[noise_levels]: the counted verdict is the one at the suggested level; the verdicts
    at every level (and where the claim stops holding) go to the last column."""
    from podbench.study.claims import noise_points
    from podbench.study.sensitivity import noise_verdicts

    claims, _ = _claims(tmp_path, """
[noise_levels]
levels = { n0 = 0.0, n01 = 0.001, n5 = 0.05 }
suggested = 0.001
source = "appendix"
quote = "tol = 1000"
reading = "r"

[[claims]]
id = "c"
source = "§x"
quote = "q"
scenario = ["n0", "n01", "n5", "other"]
structure = "b"
target = "t"
checks = ["A.total_error < 0.3"]
""")
    f = load_claims_file(tmp_path / "claims.toml")
    table = pd.DataFrame([{"scenario": s, "structure": "b", "method": "A", "target": "t",
                           "total_error": e}
                          for s, e in (("n0", 0.2), ("n01", 0.21), ("n5", 0.5), ("other", 0.1))])
    e = evaluate_claims(claims, table, noise_levels=f.noise_levels)[0]
    assert e.verdict == "reproduced" and e.verdict_all == "not reproduced"
    assert [(p["value"], p["verdict"]) for p in noise_points(e, f.noise_levels)] == [
        (0.0, "reproduced"), (0.001, "reproduced"), (0.05, "not reproduced")]
    (kind, text, _), = noise_verdicts([e], f.noise_levels)["c"]
    assert kind == "depends on the unstated noise level"
    assert text.startswith("holds at 0 %–0.1 %, stops holding at 5 %")
    assert "at 0.1 %, the level of the appendix's “tol = 1000”: reproduced" in text
    # a failure outside the noise series still counts
    e = evaluate_claims(claims, table.assign(total_error=[0.2, 0.21, 0.5, 0.9]),
                        noise_levels=f.noise_levels)[0]
    assert e.verdict == "not reproduced"
