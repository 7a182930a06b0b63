"""A study names the extras its committed tables need (``requires`` in ``[study]`` or
``[scenario]``); without them ``podbench run`` refuses in one line, before any work, naming
the extra and its install command, and leaves the results folder untouched."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import podbench as pb
from podbench import cli
from podbench.core import extras
from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.study.own_runner import load_own_study
from podbench.study.scenarios import load_scenario

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]


def _without(monkeypatch, *missing: str) -> None:
    monkeypatch.setattr(extras, "_installed", lambda d: d not in missing)


def test_the_extras_are_pyprojects_optional_dependencies():
    with (ROOT / "pyproject.toml").open("rb") as fh:
        declared = tomllib.load(fh)["project"]["optional-dependencies"]
    known = extras.known_extras()
    if not known:
        pytest.skip("podbench is not installed (no metadata)")
    assert known["mdof"] == ["mdof"]
    assert sorted(known["peers"]) == sorted(r.split(">")[0] for r in declared["peers"])
    assert set(known) >= set(declared) - {"dev"}


def test_painter_street_declares_mdof():
    study = load_own_study(bundled_scenarios() / "painter_street" / "painter_street.toml",
                           ["painter_street"])
    assert study.requires == ("mdof",)
    with (bundled_scenarios() / "peers" / "peers_forced.toml").open("rb") as fh:
        assert tomllib.load(fh)["scenario"]["requires"] == ["peers"]  # DMDc, OpInf


def test_run_without_the_extra_refuses_in_one_line_before_any_work(monkeypatch, tmp_path,
                                                                    capsys):
    _without(monkeypatch, "mdof")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results" / "painter_street").mkdir(parents=True)
    committed = tmp_path / "results" / "painter_street" / "summary.csv"
    committed.write_text("committed\n", encoding="utf-8")
    code = cli.main(["run", "painter_street", "--jobs", "1"])
    err = capsys.readouterr().err.strip()
    assert code != 0 and len(err.splitlines()) == 1
    assert "painter_street.toml: field `study.requires`" in err
    assert 'extra "mdof" (mdof not installed)' in err
    assert 'pip install -e ".[mdof]"' in err
    assert committed.read_text(encoding="utf-8") == "committed\n"
    assert sorted(p.name for p in committed.parent.iterdir()) == ["summary.csv"]


def test_a_scenario_requires_is_read_at_load_inherited_and_checked_when_run(monkeypatch,
                                                                           tmp_path):
    base = bundled_scenarios() / "chapter4" / "beam_free_displacement.toml"
    f = tmp_path / "mine.toml"
    f.write_text(f'[scenario]\nname = "mine"\nbase = "{base.as_posix()}"\n'
                 'requires = ["peers", "measured"]\n', encoding="utf-8")
    assert load_scenario(f).requires == ("peers", "measured")
    child = tmp_path / "child.toml"
    child.write_text('[scenario]\nname = "child"\nbase = "mine.toml"\n', encoding="utf-8")
    assert load_scenario(child).requires == ("peers", "measured")
    _without(monkeypatch, "pyuff")
    assert load_scenario(f).requires == ("peers", "measured")  # reading needs no extra
    with pytest.raises(ScenarioFileError, match=r'mine.toml: field `scenario.requires`: .*'
                       r'extra "measured" \(pyuff not installed\).*\[measured\]'):
        pb.run(str(f), out=tmp_path / "out", quiet=True, figures=False)
    assert not (tmp_path / "out").exists()


def test_an_unknown_extra_is_named_with_the_closest(tmp_path):
    if not extras.known_extras():
        pytest.skip("podbench is not installed (no metadata)")
    f = tmp_path / "study.toml"
    f.write_text('[study]\nrunner = "painter_street"\nrequires = ["mdfo"]\n'
                 '[painter_street]\ndata = "."\n', encoding="utf-8")
    with pytest.raises(ScenarioFileError, match=r'field `study.requires\[0\]`: unknown extra '
                       r'"mdfo"; did you mean \'mdof\'\?'):
        load_own_study(f, ["painter_street"])
