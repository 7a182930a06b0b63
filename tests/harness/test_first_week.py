"""A user's first week: regress judges one study, names are forgiving, hints for unit
slips, and the command line starts without the heavy imports."""

import subprocess
import sys
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


def test_the_command_line_imports_no_heavy_module_until_a_command_needs_it():
    code = ("import sys, podbench, podbench.cli\n"
            "print(sorted(m for m in ('scipy', 'pandas', 'matplotlib', 'numpy') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
    # every public name still imports (lazily) and is the object at its home
    import podbench
    from podbench.dynamics import simulate
    from podbench.sysid import methods
    assert podbench.simulate is simulate and podbench.methods is methods
    for name in podbench.__all__:
        assert getattr(podbench, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        podbench.nope  # noqa: B018


def test_list_shows_each_structure_once_and_summarises_long_method_lists(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)  # the checkout: ./structures is the bundled folder
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n  lti_beam\n") == 1 and "structures in ./structures" not in out
    line = next(ln for ln in out.splitlines() if ln.startswith("  linear_beam_noise_1pct:"))
    assert "14 methods: SL-ls, SL-tls" in line and line.count(",") < 8
    # a scenario inheriting its fields (scenario.base) shows its base's structures
    line = next(ln for ln in out.splitlines() if ln.startswith("  beam_forced_noise1pct:"))
    assert "[lti_beam, ltv_beam, nl_beam; SL, ML6, ML4]" in line
