"""Studies with their own runner: a study file's ``[study] runner`` names a runner of
``podbench.api.RUNNERS`` (the Painter Street Overpass, Chapter 6's substructuring); one
mechanism for both, checked before any work, listed by ``podbench list``."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

import podbench
from podbench import api, cli
from podbench.core.resources import bundled_scenarios, bundled_studies
from podbench.errors import ScenarioFileError
from podbench.harness.painter_street import data_folder
from podbench.study.own_runner import load_own_study, own_study_file
from podbench.study.painter_street import load_painter_street
from podbench.study.scenarios import find_scenarios


@pytest.fixture
def toy(monkeypatch, tmp_path):
    """A registered runner "toy" that records what it is handed and writes a summary."""
    calls = []

    def run(study, out, options):
        calls.append((study, options))
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.csv").write_text("status,error\nok,0.5\n", encoding="utf-8")
        return api.StudyResult(out=out, summary=pd.read_csv(out / "summary.csv"),
                               fits=pd.DataFrame(), claims=None, figures=[], scenarios={},
                               seconds=0.0, simulated=0, cached=0)

    monkeypatch.setitem(api.RUNNERS, "toy", api.Runner("a toy study", run))
    folder = tmp_path / "toy_study"
    folder.mkdir()
    (folder / "toy_study.toml").write_text('[study]\nrunner = "toy"\n\n[toy]\nsize = 3\n',
                                           encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return folder, calls


def test_the_bundled_studies_name_their_runners():
    owns = {}
    for name, folder in bundled_studies().items():
        files = find_scenarios([folder])
        own = api.own_study(files)
        if own is not None:
            assert len(files) == 1 and own.name == name
            owns[name] = own.runner
    # every registered runner has its bundled study, and every such study a runner
    assert owns == {"painter_street": "painter_street", "substructuring": "substructuring",
                    "base_excited": "base_excited", "f16_gvt": "f16_gvt"}
    assert set(owns.values()) == set(api.RUNNERS)
    # the scenario studies are not own-runner studies
    assert api.own_study(find_scenarios([bundled_scenarios() / "chapter4"])) is None


def test_the_painter_street_file_names_the_bundled_records():
    plan = load_painter_street(bundled_scenarios() / "painter_street" / "painter_street.toml")
    assert plan.data == data_folder().resolve() and plan.name == "painter_street"
    assert len(list(plan.data.glob("*.npz"))) == 14


def test_run_hands_the_study_to_its_runner_with_a_canonical_command(toy, tmp_path):
    folder, calls = toy
    res = podbench.run(str(folder), out=tmp_path / "o1", figures=False, figure_format="svg")
    study, options = calls[-1]
    assert study.runner == "toy" and study.name == "toy_study"
    assert study.path == folder / "toy_study.toml"
    assert (options.figures, options.figure_format) == (False, "svg")
    assert options.command == f"podbench run {folder}"
    assert res.summary.error.tolist() == [0.5] and res.seconds >= 0
    # the CLI hands the same command whatever its options (FINDINGS names it)
    assert cli.main(["run", str(folder), "-o", str(tmp_path / "o2"), "-q", "-j", "2"]) == 0
    assert calls[-1][1].command == f"podbench run {folder}"
    # default output folder: results/<study folder>
    podbench.run(str(folder), figures=False)
    assert (tmp_path / "results" / "toy_study" / "summary.csv").is_file()


@pytest.mark.parametrize("text, message", [
    ('[study]\nrunner = "substructurng"\n',
     "field `study.runner`: unknown runner \"substructurng\"; did you mean 'substructuring'? "
     "(runners: painter_street, substructuring"),
    ('[study]\nrunner = 3\n', "field `study.runner`: expected a string, got 3 (integer)"),
    ('[study]\ntitle = "x"\n', "field `study.runner`: missing (this field is required)"),
    ('[study]\nrunner = "substructuring"\ntitel = "x"\n',
     "field `study.titel`: unknown field; did you mean `title`?"),
    ('[substructuring]\nparent = "lti_beam"\n',
     'field `study.runner`: missing (a [substructuring] table is run by its own runner: add '
     '[study] runner = "substructuring")'),
    ('[study]\nrunner = "painter_street"\n[painter_street]\ndata = "nope"\n',
     'field `painter_street.data`: no such folder "nope" (relative to this file)'),
    ('[study]\nrunner = "painter_street"\n[painter_street]\ndata = "."\n',
     'field `painter_street.data`: "." holds no .npz records and events.csv'),
])
def test_a_bad_study_file_is_one_line_naming_the_file_and_field(text, message, tmp_path,
                                                                 monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    assert cli.main(["run", "s.toml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"podbench run: error: s.toml: {message}" in err
    assert not (tmp_path / "results").exists()


def test_an_own_runner_study_runs_alone_and_only_under_run(toy, tmp_path, capsys):
    folder, calls = toy
    other = tmp_path / "x.toml"
    other.write_text("[scenario]\nname = \"x\"\n", encoding="utf-8")
    with pytest.raises(ScenarioFileError, match="is run alone, not with x.toml"):
        own_study_file([folder / "toy_study.toml", other], api.RUNNERS)
    (folder / "x.toml").write_bytes(other.read_bytes())  # a folder of both
    assert cli.main(["run", str(folder), "-q"]) == 2
    assert "toy_study.toml: a study with its own runner ([study] runner) is run alone" \
        in capsys.readouterr().err
    (folder / "x.toml").unlink()
    for argv, command in ((["sweep", str(folder)], "sweep"),
                          (["regress", str(folder), "--baseline", str(other)], "regress")):
        assert cli.main([*argv, "-q"]) == 2
        assert (f"toy_study.toml: a study with its own runner (toy), not scenarios: podbench "
                f"run runs it, podbench {command} does not") in capsys.readouterr().err
    assert cli.main(["run", str(folder), "--engine", "exudyn", "-q"]) == 2
    assert "--engine: " in capsys.readouterr().err
    assert cli.main(["run", str(folder), "-q", "-o", str(tmp_path / "a.txt")]) == 0
    assert not calls[:-1]  # nothing ran before the checks


def test_load_own_study_reads_the_title():
    path = bundled_scenarios() / "substructuring" / "substructuring.toml"
    own = load_own_study(path, api.RUNNERS)
    assert own.runner == "substructuring" and own.title.startswith("Chapter 6")


def test_list_shows_every_bundled_study_and_the_runners(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert ("study bundled with podbench: painter_street (scenarios/painter_street; podbench "
            "run painter_street):\n  painter_street: Painter Street Overpass") in out
    assert "substructuring: Chapter 6: identified components coupled to a finite-element " \
           "beam [its own runner: substructuring]" in out
    runners = out.split("study runners")[1].splitlines()[1:]
    assert sorted(r.split(":")[0].strip() for r in runners) == sorted(api.RUNNERS)


def test_resolve_names_the_painter_street_study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    paths, files = api.resolve_study("painter_street")
    assert files == [bundled_scenarios() / "painter_street" / "painter_street.toml"]
    assert api.default_out(paths) == Path("results/painter_street")
