"""The command line: run writes complete outputs, bad input is one line and exit code 2,
regress catches a perturbed baseline, an interrupted run leaves results/ untouched."""

import pandas as pd
import pytest
from conftest import CHAIN_FORCED, CHAIN_FREE

from podbench import api, cli
from podbench.report import study as report

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


@pytest.fixture
def study(write_scenario, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_scenario(CHAIN_FREE, "chain_free")
    write_scenario(CHAIN_FORCED, "chain_forced")
    return tmp_path / "scenarios"


@pytest.mark.usefixtures("pool_at_once")
def test_run_writes_tables_figures_and_is_byte_identical_when_repeated(study, tmp_path, capsys):
    out = tmp_path / "results" / "small"
    args = ["run", str(study), "--out", str(out), "-q", "--no-cache"]
    assert cli.main(args) == 0
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert "summary.csv" in files and "summary.md" in files
    # two prediction figures, the calibration plot, each scenario's stacked-bar error
    # decomposition and the modes' MAC figure
    figs = sorted(f for f in files if f.startswith("figures/") and f.endswith(".png"))
    assert figs == ["figures/calibration.png", "figures/chain_forced__chain_coupled__f6.png",
                    "figures/chain_forced__decomposition.png",
                    "figures/chain_free__chain_coupled__x6.png",
                    "figures/chain_free__decomposition.png", "figures/modes_mac.png"]
    assert "CALIBRATION.md" in files and "calibration.csv" in files
    timing = pd.read_csv(out / "timing.csv")  # wall clock per method, one row per fit
    assert list(timing.columns) == ["scenario", "structure", "method", "fit_seconds", "seconds"]
    assert len(timing) == 4 and (timing.seconds >= timing.fit_seconds).all()
    assert (timing.fit_seconds > 0).all()
    out_lines = capsys.readouterr().out.strip().splitlines()
    slowest = timing.groupby("method").seconds.sum()
    assert out_lines[-1].startswith("report: ")  # the last line stays the report's path
    assert out_lines[-2].startswith("slowest method: " + slowest.idxmax() + ", ")
    df = pd.read_csv(out / "summary.csv")
    assert list(df.columns[:15]) == [
        "scenario", "structure", "method", "target", "n_modes", "total_error",
        "projection_error", "diagonalization_error", "linearization_error", "residual_error",
        "subspace_error", "twin_error", "own_linearization_error",
        "linear_diagonalization_error", "norm_pe_median"]
    assert {"norm_pe_p90", "error_estimate", "coverage", "status"} <= set(df.columns)
    assert len(df) == 4 and (df.status == "ok").all()
    first = (out / "summary.csv").read_bytes(), (out / "summary.md").read_bytes()
    cal = (out / "calibration.csv").read_bytes()
    assert cli.main(args + ["--jobs", "2"]) == 0
    assert ((out / "summary.csv").read_bytes(), (out / "summary.md").read_bytes()) == first
    assert (out / "calibration.csv").read_bytes() == cal
    assert not [p for p in (tmp_path / "results").iterdir() if p.name.startswith(".")]


def test_an_interrupted_run_leaves_the_previous_results(study, tmp_path, monkeypatch):
    out = tmp_path / "results" / "small"
    assert cli.main(["run", str(study), "--out", str(out), "-q", "--no-figures"]) == 0
    before = (out / "summary.csv").read_bytes()

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "draw_figure", boom)
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


# ---------------------------------------------------------------------------- early, one line
def _one_line_error(capsys, code=2):
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def _nothing_done(tmp_path):
    """No cache entry (nothing simulated) and no output folder (nothing written)."""
    cache = tmp_path / "cache"
    assert not cache.exists() or not any(cache.rglob("*"))
    assert not (tmp_path / "out").exists()


def test_a_load_off_the_beam_names_file_case_and_field_before_any_simulation(
        write_scenario, tmp_path, capsys, monkeypatch):
    from conftest import NL_BEAM

    monkeypatch.chdir(tmp_path)
    p = write_scenario(NL_BEAM.replace("[[8.0, -300.0]]", "[[30.0, -300.0]]"), "nl")
    args = ["run", str(p), "--cache", str(tmp_path / "cache"), "--out", str(tmp_path / "out")]
    assert cli.main(args + ["-q"]) == 2
    err = _one_line_error(capsys)
    assert "nl.toml: field `cases.w2.initial_displacement.loads[0]` on lti_beam:" in err
    assert "30.0 in is off the structure 'lti_beam' (sensor positions 0 … 24 in)" in err
    _nothing_done(tmp_path)


@pytest.mark.parametrize("edit, field", [
    (('reference = "lti_beam" }}\n[cases.w1]', 'reference = "lti_bem" }}\n[cases.w1]'),
     "cases.w0.initial_displacement.reference"),
    (('[[24.0, 100.0]], reference = "lti_beam"', '[[24.0, 100.0]], reference = 3'),
     "cases.w1.initial_displacement.reference"),
    (('[[24.0, 100.0]], reference = "lti_beam"', '[[24.0, 100.0]], reference = "chain_ideal"'),
     "cases.w1.initial_displacement.reference"),             # 5 DOFs, the beams have 48
    (('kind = "static_displacement", loads = [[8.0',
      'kind = "impulse_velocity", loads = [[8.0'), "cases.w2.initial_displacement.kind"),
])
def test_a_bad_reference_or_kind_names_its_own_field(write_scenario, tmp_path, capsys,
                                                     monkeypatch, edit, field):
    from conftest import NL_BEAM

    monkeypatch.chdir(tmp_path)
    text = NL_BEAM.replace(*edit)
    assert text != NL_BEAM
    p = write_scenario(text, "nl")
    assert cli.main(["run", str(p), "-q", "--cache", str(tmp_path / "cache"),
                     "--out", str(tmp_path / "out")]) == 2
    assert f"nl.toml: field `{field}`" in _one_line_error(capsys)
    _nothing_done(tmp_path)


@pytest.mark.parametrize("force, field, needle", [
    ('{ kind = "pulse", location = 2, amplitude = 1.0, duration = 0.02, by = "dof", '
     'start = 9.0 }', "cases.f1.force.start", "after the record's last sample at 0.476 s"),
    ('{ kind = "pulse", location = 2, amplitude = 1.0, duration = 1e-4, by = "dof" }',
     "cases.f1.force.duration", "loads no sample"),
    ('[{ kind = "pulse", location = 2, amplitude = 1.0, duration = 0.02, by = "dof" }, '
     '{ kind = "force_history", F = [[1.0, 2.0]] }]', "cases.f1.force[1].F",
     "expected shape (5, 120)"),
    ('{ kind = "combined", parts = [{ kind = "pulse", location = "m9", amplitude = 1.0, '
     'duration = 0.02 }] }', "cases.f1.force.parts[0].location", "'m9'"),
])
def test_forces_are_checked_against_the_record_at_plan_time(write_scenario, tmp_path, capsys,
                                                            monkeypatch, force, field, needle):
    monkeypatch.chdir(tmp_path)
    old = ('force = {{ kind = "pulse", location = 4, amplitude = 1.0, duration = 0.02, '
           'by = "dof" }}')
    assert old in CHAIN_FORCED
    p = write_scenario(CHAIN_FORCED.replace(old, "force = " + force.replace("{", "{{")
                                            .replace("}", "}}")), "cf")
    assert cli.main(["run", str(p), "-q", "--cache", str(tmp_path / "cache"),
                     "--out", str(tmp_path / "out")]) == 2
    err = _one_line_error(capsys)
    assert f"cf.toml: field `{field}` on chain_coupled" in err and needle in err
    _nothing_done(tmp_path)


@pytest.mark.parametrize("option", ["--cache", "--out"])
@pytest.mark.parametrize("where", ["file", "under_file", "foreign_folder"])
def test_cache_and_out_are_checked_before_any_work(study, tmp_path, capsys, option, where):
    blocker = tmp_path / "a_file.txt"
    blocker.write_text("precious\n")
    foreign = tmp_path / "home"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("precious\n")
    path = {"file": blocker, "under_file": blocker / "sub", "foreign_folder": foreign}[where]
    args = {"--cache": str(tmp_path / "cache"), "--out": str(tmp_path / "out"), option: str(path)}
    code = cli.main(["run", str(study), "-q", "--no-figures", "--cache", args["--cache"],
                     "--out", args["--out"]])
    if option == "--cache" and where == "foreign_folder":
        assert code == 0  # a cache may live in any folder; it only adds entries
        return
    assert code == 2
    err = _one_line_error(capsys)
    assert f"{option}: {path}" in err
    assert blocker.read_text() == "precious\n" and (foreign / "notes.txt").read_text() == (
        "precious\n") and sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]
    _nothing_done(tmp_path)


def test_out_may_be_new_empty_or_a_previous_output(study, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    for out in (tmp_path / "new" / "deeper", empty, empty):  # the third: a previous output
        assert cli.main(["run", str(study), "-q", "--no-figures", "--no-cache",
                         "--out", str(out)]) == 0
        assert (out / "summary.csv").is_file()


@pytest.mark.skipif(not hasattr(__import__("os"), "geteuid") or __import__("os").geteuid() == 0,
                    reason="root can write anywhere")
def test_an_unwritable_cache_is_refused(study, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert cli.main(["run", str(study), "-q", "--cache", str(ro / "c"),
                         "--out", str(tmp_path / "out")]) == 2
        assert "is not writable" in _one_line_error(capsys)
    finally:
        ro.chmod(0o700)


@pytest.mark.parametrize("argv", [
    ["regress", "--rtol", "-0.01"], ["regress", "--atol", "-1e-6"], ["regress", "--rtol", "nan"],
    ["regress", "--atol", "inf"], ["run", "--jobs", "-2"], ["run", "--jobs", "two"],
    ["sweep", "--noise", "nan"], ["sweep", "--noise", "0.01,0.01"], ["sweep", "--seeds", "-1"],
    ["sweep", "--seeds", "0-99999999"], ["sweep", "--n-modes", "0"], ["sweep", "--n-modes", "3,3"],
    ["sweep", "--jobs", "0"], ["run", "--engine", "euler"],
])
def test_numeric_options_are_validated_before_any_work(study, tmp_path, capsys, argv):
    base = tmp_path / "baseline.csv"
    if argv[0] == "regress":
        assert cli.main(["regress", str(study), "-q", "--baseline", str(base), "--update",
                         "--cache", str(tmp_path / "c0")]) == 0
        capsys.readouterr()
        argv = [*argv, "--baseline", str(base)]
    assert cli.main([*argv, str(study), "-q", "--cache", str(tmp_path / "cache")]) == 2
    err = _one_line_error(capsys)
    assert err.startswith(f"podbench {argv[0]}: error:") and argv[1] in err
    assert not (tmp_path / "cache").exists()


def test_an_unchanged_table_is_no_regression_at_zero_tolerance(study, tmp_path, capsys):
    base = tmp_path / "baseline.csv"
    common = [str(study), "-q", "--baseline", str(base), "--no-cache"]
    assert cli.main(["regress", *common, "--update"]) == 0
    assert cli.main(["regress", "--table", str(base), "--baseline", str(base),
                     "--rtol", "0", "--atol", "0"]) == 0
    assert "no error got worse" in capsys.readouterr().out


def test_os_errors_exit_2_and_bugs_exit_3_on_one_line(study, tmp_path, capsys, monkeypatch):
    def denied(*a, **k):
        raise PermissionError(13, "Permission denied", "/some/where/entry.npz")

    monkeypatch.setattr(api, "run_study", denied)
    args = ["run", str(study), "-q", "--out", str(tmp_path / "out")]
    assert cli.main(args) == 2
    assert "error: /some/where/entry.npz: Permission denied" in _one_line_error(capsys)

    def bug(*a, **k):
        raise ValueError("something podbench did not expect")

    monkeypatch.setattr(api, "run_study", bug)
    assert cli.main(args) == 3
    err = _one_line_error(capsys)
    assert err.startswith("podbench run: internal error: ValueError: something podbench did "
                          "not expect (this is a bug; rerun with --debug")
    assert cli.main([*args, "--debug"]) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "in bug" in err


@pytest.mark.parametrize("content", [b"\xff\xfe not utf-8 \x00", b"", "dir"])
def test_unreadable_scenario_files_are_one_line(tmp_path, capsys, content):
    p = tmp_path / "scen.toml"
    if content == "dir":
        p.mkdir()
        (p / "inner.toml").write_bytes(b"")
    else:
        p.write_bytes(content)
    assert cli.main(["run", str(p), "-q", "--out", str(tmp_path / "out"),
                     "--cache", str(tmp_path / "cache")]) == 2
    err = _one_line_error(capsys)
    assert "scen.toml" in err
    _nothing_done(tmp_path)


def test_a_structure_file_that_is_not_utf8_is_one_line(write_scenario, tmp_path, capsys,
                                                       monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios").mkdir(exist_ok=True)
    (tmp_path / "scenarios" / "bad_structure.toml").write_bytes(b"name = \"\xff\"\n")
    p = write_scenario(CHAIN_FREE.replace('structures = ["chain_coupled"]',
                                          'structures = ["bad_structure.toml"]'), "cf")
    assert cli.main(["run", str(p), "-q", "--out", str(tmp_path / "out"),
                     "--cache", str(tmp_path / "cache")]) == 2
    assert "bad_structure.toml: not UTF-8 text" in _one_line_error(capsys)


def test_sweep_refuses_a_foreign_scenario_folder_under_out(study, tmp_path, capsys):
    foreign = tmp_path / "res" / "chain_free"
    foreign.mkdir(parents=True)
    (foreign / "notes.txt").write_text("precious\n")
    assert cli.main(["sweep", str(study / "chain_free.toml"), "-q", "--out",
                     str(tmp_path / "res"), "--cache", str(tmp_path / "cache")]) == 2
    err = _one_line_error(capsys)
    assert "--out" in err and "not a podbench output (no sweep.csv in it)" in err
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]
    assert not (tmp_path / "cache").exists()
