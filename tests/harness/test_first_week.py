"""A user's first week: regress judges one study, names are forgiving, hints for unit
slips, and the command line starts without the heavy imports."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
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
    from podbench.study.scenarios import load_scenario
    n = len(load_scenario(ROOT / "scenarios" / "chapter5" / "linear_beam_noise_1pct.toml").methods)
    assert n > 6 and f"{n} methods: SL-ls, SL-tls" in line and line.count(",") < 8
    # a scenario inheriting its fields (scenario.base) shows its base's structures
    line = next(ln for ln in out.splitlines() if ln.startswith("  beam_forced_noise1pct:"))
    assert "[lti_beam, ltv_beam, nl_beam; SL, ML6, ML4]" in line


def _documented(field: str) -> list[str]:
    """The quoted values of a field's row(s) in the scenario reference's tables."""
    text = (ROOT / "docs" / "reference" / "scenarios.md").read_text(encoding="utf-8")
    rows = [ln for ln in text.splitlines() if ln.startswith(f"| `{field}` |")]
    assert rows, field
    return sorted({v for ln in rows for v in re.findall(r'`"(\w+)"`', ln.split("|")[2])})


def test_every_documented_pulse_shape_and_location_reading_is_accepted():
    import podbench as pb
    from podbench.dynamics.excitations import excitation_from_dict

    s = pb.load_structure("lti_beam")
    shapes = _documented("shape")
    assert shapes == ["half_sine", "rectangular", "triangle"]
    for shape in shapes:
        f = excitation_from_dict({"kind": "pulse", "location": 23.0, "amplitude": 500.0,
                                  "duration": 1e-3, "shape": shape})
        h = f.history(20, 1e-4)  # t = 0 … 1.9 ms; the pulse lasts 1 ms from t = 0
        peak = {"rectangular": 500.0, "half_sine": 500.0 * np.sin(np.pi * 0.5),
                "triangle": 500.0}[shape]
        assert h.max() == pytest.approx(peak) and h[15] == 0.0
        assert f.sample(s, 20, 1e-4).shape == (s.n_sensors, 20)
    for by in _documented("by"):
        excitation_from_dict({"kind": "pulse", "location": 2 if by == "dof" else 23.0,
                              "amplitude": 1.0, "duration": 1e-3, "by": by})


def test_a_wrong_sensor_label_lists_the_valid_ones():
    import podbench as pb
    from podbench.dynamics.excitations import resolve_sensor
    from podbench.errors import InputError

    s = pb.load_structure("chain_ideal")
    assert resolve_sensor(s, "mass3") == 3
    with pytest.raises(InputError, match=r"did you mean 'mass0'\? \(sensors: mass0, mass1, "
                                         r"mass2, mass3, mass4\)"):
        resolve_sensor(s, "Mass0")


@pytest.mark.parametrize("method", ["ml", "Ml", "era", "ml-tc", "fir-ls"])
def test_method_names_ignore_letter_case_on_the_command_line(method):
    from podbench.sysid import registry

    entry = registry.lookup(method)
    assert entry.name.lower() == method.lower()


def test_a_percentage_for_a_fraction_gets_a_hint(tmp_path, capsys):
    from podbench.errors import InputError
    from podbench.sysid.methods import ERA

    with pytest.raises(InputError, match=r"got 25; a percentage\? 25 % is 0.25"):
        ERA(holdout=25).fit([])
    with pytest.raises(InputError, match=r"got 0.7$"):
        ERA(holdout=0.7).fit([])
    data = ROOT / "scenarios" / "examples" / "measured" / "data"
    argv = ["predict", "--method", "ml", "--train", str(data / "f1.npz"), str(data / "f5.npz"),
            str(data / "f2.mat"), "--target", str(data / "f6.csv"), "--out",
            str(tmp_path / "p"), "--coverage", "90"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--coverage" in err and "a percentage? 90 % is 0.9" in err


def _ignored(path: str) -> bool:
    r = subprocess.run(["git", "check-ignore", "-q", path], cwd=ROOT)
    assert r.returncode in (0, 1)
    return r.returncode == 0


@pytest.mark.skipif(not (ROOT / ".git").exists(), reason="not a git checkout")
def test_example_outputs_are_ignored_and_every_committed_output_is_not():
    import tomllib

    manifest = tomllib.loads((ROOT / "results" / "MANIFEST.toml").read_text(encoding="utf-8"))
    paths = [p for table in manifest.values() for p in table.get("paths", [])]
    assert paths and not [p for p in paths if _ignored(p + ("/summary.csv" if Path(
        p).suffix == "" else ""))]
    for example in ("results/beam_forced/summary.csv", "results/measured_chain/summary.md",
                    "results/my_study/fits.csv"):
        assert _ignored(example)


@pytest.mark.parametrize("suffix", [".npz", ".mat"])
def test_an_empty_record_file_is_one_line_naming_it(suffix, tmp_path, capsys):
    empty = tmp_path / f"empty{suffix}"
    empty.write_bytes(b"")
    data = ROOT / "scenarios" / "examples" / "measured" / "data"
    argv = ["predict", "--method", "ML", "--train", str(data / "f1.npz"), str(data / "f5.npz"),
            str(empty), "--target", str(data / "f6.csv"), "--out", str(tmp_path / "p")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(empty) in err and "empty file (0 bytes)" in err
    assert not (tmp_path / "p").exists()


def test_more_modes_than_load_cases_is_refused_before_any_fit(tmp_path):
    from podbench.errors import InputError
    from podbench.study.scenarios import load_scenario

    text = (ROOT / "scenarios" / "chapter4" / "beam_forced.toml").read_text(encoding="utf-8")
    assert 'method = "ML"' in text
    bad = text.replace('method = "ML"', 'method = "ML"\nn_modes = 6', 1)
    f = tmp_path / "beam_forced.toml"
    f.write_text(bad, encoding="utf-8")
    with pytest.raises(InputError, match=r"beam_forced.toml.*n_modes.*6 modes from 4 training "
                                         r"cases: ML .* k ≤ 4"):
        load_scenario(f)


def _beam_forced(tmp_path, *edits) -> Path:
    """scenarios/chapter4/beam_forced.toml on lti_beam alone, with ``edits`` (old, new)."""
    text = (ROOT / "scenarios" / "chapter4" / "beam_forced.toml").read_text(encoding="utf-8")
    for old, new in (('"lti_beam", "ltv_beam", "nl_beam"', '"lti_beam"'), *edits):
        assert old in text
        text = text.replace(old, new, 1)
    f = tmp_path / "beam_forced.toml"
    f.write_text(text, encoding="utf-8")
    return f


CUT_HALF_SINE = ('duration = 1.5e-3, shape = "half_sine"', 'duration = 1.5e-4, shape = "half_sine"')
"""On a record of 2 or 3 samples the 1.5-ms half-sine would be cut by the record's end and
refused first (Pulse.check); 0.15 ms loads one or two samples and fits."""


@pytest.mark.parametrize("edits, words", [
    ([("n_modes = 4", "n_modes = 40")], "40 modes, but SL's POMs number at most 25 (25 sensors)"),
    ([("n_samples = 500", "n_samples = 3"), CUT_HALF_SINE],
     "4 modes, but SL's POMs number at most 3 (1 training record of scenario.n_samples = 3)"),
])
def test_more_pod_modes_than_sensors_or_samples_is_refused_before_any_simulation(
        edits, words, tmp_path):
    from podbench.errors import ScenarioFileError
    from podbench.harness.runner import plan

    f = _beam_forced(tmp_path, *edits)
    with pytest.raises(ScenarioFileError) as info:
        plan([f])  # validates; simulates nothing
    msg = str(info.value)
    assert "beam_forced.toml: field `methods[0].n_modes` on lti_beam: " in msg
    assert msg.endswith(words) and "\n" not in msg
    # ERA's n_modes is an order (2 n_modes), not POMs: 40 on 25 sensors is not refused here
    era = _beam_forced(tmp_path, ('method = "SL"\nn_modes = 4', 'method = "ERA"\nn_modes = 40'),
                       ('options = { solver = "block" }\ntwin = "ML"', ""))
    assert len(plan([era])) == 1


def test_a_run_whose_every_row_failed_is_an_error_not_a_table(tmp_path, capsys):
    # 2 samples from rest: each record has rank 1, so every fit of 2 modes fails
    f = _beam_forced(tmp_path, ("n_samples = 500", "n_samples = 2"), ("n_modes = 4", "n_modes = 2"),
                     CUT_HALF_SINE)
    out = tmp_path / "out"
    argv = ["run", str(f), "--out", str(out), "--no-figures", "--no-cache", "-q", "--jobs", "1"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "every row failed, nothing was measured" in err
    assert "numerical rank 1" in err and f"{out}/summary.md" in err


def test_a_noise_level_above_one_is_refused_with_the_percentage_hint(tmp_path, capsys):
    from podbench.errors import ScenarioFileError
    from podbench.study.scenarios import load_scenario

    # the command line: before any scenario is read or simulated
    assert cli.main(["sweep", "chapter4/beam_forced", "--noise", "0,1,5", "--out",
                     str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not (tmp_path / "s").exists()
    assert err.endswith("--noise: expected levels in [0, 1] (std = level × each channel's "
                        "RMS), got 5 in '0,1,5'; a percentage? 5 % is 0.05\n")
    assert cli.main(["sweep", "chapter4/beam_forced", "--noise", "250", "--out",
                     str(tmp_path / "s")]) == 2
    assert capsys.readouterr().err.endswith("got 250 in '250'\n")  # no hint past 100
    # the scenario file: [sweep] noise and scenario.training_noise
    src = ROOT / "scenarios" / "calibration" / "beam_forced_noise1pct.toml"
    text = src.read_text(encoding="utf-8")
    assert "training_noise = 0.01" in text
    f = tmp_path / src.name
    f.write_text(text.replace("training_noise = 0.01", "training_noise = 2", 1)
                 .replace('base = "', 'base = "' + str(src.parent) + "/", 1), encoding="utf-8")
    with pytest.raises(ScenarioFileError, match=r"beam_forced_noise1pct.toml: field "
                       r"`scenario.training_noise`: .* got 2; a percentage\? 2 % is 0.02$"):
        load_scenario(f)
    sweep = (ROOT / "scenarios" / "sweeps" / "beam_forced_noise.toml").read_text(
        encoding="utf-8").replace("noise = [0.0, 0.001, 0.01, 0.03, 0.05]",
                                  "noise = [0, 0.1, 1, 3, 5]", 1)
    g = tmp_path / "beam_forced_noise.toml"
    g.write_text(sweep, encoding="utf-8")
    with pytest.raises(ScenarioFileError, match=r"field `sweep.noise\[3\]`: .* got 3; a "
                                                r"percentage\? 3 % is 0.03$"):
        load_scenario(g)


@pytest.mark.parametrize("argv, said", [
    (["run", "chapter4", "--out", "elsewhere"], "interrupted; elsewhere/ was left as it was"),
    (["run", "chapter4"], "interrupted; nothing was left half-written"),
])
def test_an_interruption_names_only_the_folder_the_command_writes(argv, said, monkeypatch,
                                                                  capsys):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "cmd_run", interrupted)
    assert cli.main(argv) == 130
    assert capsys.readouterr().err == f"podbench run: {said}\n"


@pytest.mark.parametrize("old, new, words", [
    ('checks = ["MDS.norm_pe_p90 < 5"]', 'checks = ["MDS.norm_pe_p99 < 5"]',
     "field `claims[0].checks[0]`: `MDS.norm_pe_p99`: \"norm_pe_p99\" is not a column of "
     "summary.csv"),
    ('checks = ["MDS.norm_pe_p90 < 5"]', 'checks = ["MSD.norm_pe_p90 < 5"]',
     "field `claims[0].checks[0]`: `MSD.norm_pe_p90`: no method labelled \"MSD\" in scenario "
     "beam_free_displacement (POVR, MDS); did you mean 'MDS'?"),
    ('target = "w3"', 'target = "w33"', "field `claims[0].target`: \"w33\" is not a target of "
     "scenario beam_free_displacement (w3, w3_x3); did you mean 'w3'?"),
])
def test_a_claim_naming_no_row_of_its_scenario_is_refused_before_any_work(old, new, words,
                                                                         tmp_path):
    from podbench import api
    from podbench.errors import ScenarioFileError
    from podbench.harness.bands import BAND_COLUMNS
    from podbench.harness.metrics import ERROR_COLUMNS, NORM_COLUMNS
    from podbench.study.claims import check_claims, load_claims_file

    paths, files = api.resolve_study(["chapter4"])
    scenarios = api.load_scenarios(files)
    metrics = ("n_modes", *ERROR_COLUMNS, *NORM_COLUMNS, *BAND_COLUMNS)
    src = ROOT / "scenarios" / "chapter4" / "claims.toml"
    check_claims(load_claims_file(src), scenarios, metrics)  # the committed file passes
    text = src.read_text(encoding="utf-8").replace('sensitivity = "../sensitivity"\n', "")
    assert old in text  # the first claim's
    f = tmp_path / "claims.toml"
    f.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(ScenarioFileError) as info:
        check_claims(load_claims_file(f), scenarios, metrics)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_podbench_run_checks_the_claims_before_any_simulation(tmp_path, capsys):
    import shutil

    study = tmp_path / "my4"
    shutil.copytree(ROOT / "scenarios" / "chapter4", study)
    claims = study / "claims.toml"
    text = claims.read_text(encoding="utf-8").replace('sensitivity = "../sensitivity"\n', "")
    claims.write_text(text.replace('target = "w3"', 'target = "w33"', 1), encoding="utf-8")
    out = tmp_path / "out"
    assert cli.main(["run", str(study), "--out", str(out), "--no-cache", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "field `claims[0].target`: \"w33\"" in err
    assert not out.exists()


def test_an_option_of_another_command_is_named_with_the_command_that_takes_it(capsys):
    argv = ["fit", "--method", "ML", "--train", "a.npz", "--out", "m", "--coverage", "0.9"]
    assert cli.main(argv) == 2
    assert capsys.readouterr().err == (
        "podbench fit: error: unrecognized arguments: --coverage 0.9 (--coverage is an option "
        "of podbench predict) (see podbench fit --help)\n")
    assert cli.main(["list", "--bogus"]) == 2
    assert capsys.readouterr().err == ("podbench list: error: unrecognized arguments: --bogus "
                                       "(see podbench list --help)\n")
