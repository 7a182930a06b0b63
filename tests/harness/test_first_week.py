"""A user's first week: regress judges one study, names are forgiving, hints for unit
slips, and the command line starts without the heavy imports."""

from pathlib import Path

import pandas as pd
import pytest

from podbench import cli

ROOT = Path(__file__).resolve().parents[2]
BASELINE = ROOT / "results" / "baseline.csv"
CH4 = ROOT / "results" / "chapter4" / "summary.csv"


@pytest.mark.parametrize("argv", [["regress", "chapter4", "--table", str(CH4)],
                                  ["regress", "--table", str(CH4)]])
def test_regress_of_one_study_judges_only_its_rows(argv, capsys):
    assert cli.main([*argv, "--baseline", str(BASELINE)]) == 0
    out = capsys.readouterr().out
    n4 = len(pd.read_csv(CH4))
    assert f"compared {n4} rows" in out
    assert "not produced by this run" not in out and "no error got worse" in out


def test_regress_of_one_study_still_catches_its_own_regression(tmp_path, capsys):
    base = pd.read_csv(BASELINE)
    ch4 = pd.read_csv(CH4)
    worse = ch4.copy()
    worse.loc[0, "total_error"] = worse.loc[0, "total_error"] * 1.5 + 1.0
    (tmp_path / "t.csv").write_text(worse.to_csv(index=False))
    assert cli.main(["regress", "chapter4", "--table", str(tmp_path / "t.csv"),
                     "--baseline", str(BASELINE)]) == 1
    assert "WORSE (1)" in capsys.readouterr().out
    # a chapter4 row dropped from the table is missing; a chapter5 row never is
    ch4.iloc[1:].to_csv(tmp_path / "short.csv", index=False)
    assert cli.main(["regress", "chapter4", "--table", str(tmp_path / "short.csv"),
                     "--baseline", str(BASELINE)]) == 1
    out = capsys.readouterr().out
    assert out.count("not produced by this run") == 1
    # --update of one study keeps the other studies' rows
    b2 = tmp_path / "b.csv"
    b2.write_text(BASELINE.read_text())
    assert cli.main(["regress", "chapter4", "--table", str(tmp_path / "t.csv"),
                     "--baseline", str(b2), "--update"]) == 0
    new = pd.read_csv(b2)
    assert len(new) == len(base)
    assert set(new["scenario"]) == set(base["scenario"])
