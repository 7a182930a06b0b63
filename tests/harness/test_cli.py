"""The command line: run writes complete outputs, bad input is one line and exit code 2,
regress catches a perturbed baseline, an interrupted run leaves results/ untouched."""

import pandas as pd
import pytest
from conftest import CHAIN_FORCED, CHAIN_FREE

from podbench import cli
from podbench.harness import report


@pytest.fixture
def study(write_scenario, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_scenario(CHAIN_FREE, "chain_free")
    write_scenario(CHAIN_FORCED, "chain_forced")
    return tmp_path / "scenarios"


def test_run_writes_tables_figures_and_is_byte_identical_when_repeated(study, tmp_path, capsys):
    out = tmp_path / "results" / "small"
    args = ["run", str(study), "--out", str(out), "-q", "--no-cache"]
    assert cli.main(args) == 0
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert "summary.csv" in files and "summary.md" in files
    assert sum(f.startswith("figures/") and f.endswith(".png") for f in files) == 2
    df = pd.read_csv(out / "summary.csv")
    assert list(df.columns[:15]) == [
        "scenario", "structure", "method", "target", "n_modes", "total_error",
        "projection_error", "diagonalization_error", "linearization_error", "residual_error",
        "subspace_error", "twin_error", "own_linearization_error",
        "linear_diagonalization_error", "norm_pe_median"]
    assert {"norm_pe_p90", "status"} <= set(df.columns)
    assert len(df) == 4 and (df.status == "ok").all()
    first = (out / "summary.csv").read_bytes(), (out / "summary.md").read_bytes()
    assert cli.main(args + ["--jobs", "2"]) == 0
    assert ((out / "summary.csv").read_bytes(), (out / "summary.md").read_bytes()) == first
    assert not [p for p in (tmp_path / "results").iterdir() if p.name.startswith(".")]


def test_an_interrupted_run_leaves_the_previous_results(study, tmp_path, monkeypatch):
    out = tmp_path / "results" / "small"
    assert cli.main(["run", str(study), "--out", str(out), "-q", "--no-figures"]) == 0
    before = (out / "summary.csv").read_bytes()

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "_figure", boom)
    assert cli.main(["run", str(study), "--out", str(out), "-q"]) == 130
    assert (out / "summary.csv").read_bytes() == before
    assert not (out / "figures").exists()
    assert sorted(p.name for p in (tmp_path / "results").iterdir()) == ["small"]


@pytest.mark.parametrize("argv, needle", [
    (["run", "no/such/folder"], "no such file or folder"),
    (["regress", "no/such.toml"], "no such file or folder"),
    (["run", "--jobs", "0", "scenarios"], "--jobs"),
])
def test_bad_paths_are_one_line_and_exit_2(study, capsys, argv, needle):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err


def test_malformed_scenario_is_one_line_and_exit_2(study, capsys):
    p = study / "chain_free.toml"
    p.write_text(p.read_text().replace("n_samples = 300", "n_samples = 'many'"))
    assert cli.main(["run", str(p)]) == 2
    err = capsys.readouterr().err
    assert "chain_free.toml: field `scenario.n_samples`" in err and err.count("\n") == 1


def test_regress_passes_then_catches_a_perturbed_baseline(study, tmp_path, capsys):
    base = tmp_path / "baseline.csv"
    common = [str(study), "-q", "--baseline", str(base)]
    assert cli.main(["regress", *common]) == 2  # no baseline yet
    assert cli.main(["regress", *common, "--update"]) == 0
    assert cli.main(["regress", *common]) == 0
    assert "no error got worse" in capsys.readouterr().out
    df = pd.read_csv(base)
    i = df.index[(df.method == "ML")][0]
    df.loc[i, "total_error"] = df.loc[i, "total_error"] * 0.5 - 1e-5  # baseline "was better"
    df.to_csv(base, index=False)
    assert cli.main(["regress", *common]) == 1
    out = capsys.readouterr().out
    assert "WORSE" in out and "ML" in out and "total_error" in out and "regression" in out
    # within tolerance: a 0.5 % better baseline is not a regression at rtol = 1 %
    df = pd.read_csv(tmp_path / "baseline.csv")
    assert cli.main(["regress", *common, "--update"]) == 0
    df = pd.read_csv(base)
    df["total_error"] = df["total_error"] / 1.005
    df.to_csv(base, index=False)
    assert cli.main(["regress", *common]) == 0
    # a missing row is a regression; a garbage baseline is unusable input
    pd.read_csv(base).iloc[:-1].to_csv(base, index=False)
    assert cli.main(["regress", *common]) == 0  # fewer baseline rows: new row reported only
    df = pd.read_csv(base)
    extra = df.iloc[[0]].copy()
    extra["target"] = "gone"
    pd.concat([df, extra]).to_csv(base, index=False)
    assert cli.main(["regress", *common]) == 1
    base.write_text("just,some\n1,2\n")
    assert cli.main(["regress", *common]) == 2


def test_help_of_every_command_is_complete(capsys):
    for argv in (["--help"], ["run", "--help"], ["regress", "--help"], ["list", "--help"]):
        with pytest.raises(SystemExit) as e:
            cli.main(argv)
        assert e.value.code == 0
        text = capsys.readouterr().out
        assert "Exit codes" in text or argv == ["list", "--help"]
    with pytest.raises(SystemExit):
        cli.main(["regress", "--help"])
    text = capsys.readouterr().out
    for opt in ("--baseline", "--rtol", "--atol", "--update", "--jobs", "--cache"):
        assert opt in text


def test_list_shows_structures_scenarios_methods(capsys, monkeypatch):
    from pathlib import Path

    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("lti_beam", "satellite_truss", "beam_forced", "truss_free_velocity", "POVR",
                 "MR", "module:Class", "tls"):
        assert name in out
