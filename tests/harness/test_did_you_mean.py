"""A misspelt study, structure, method, solver or option name: one line, exit 2, and the
closest known name ("did you mean …")."""

import pytest

from podbench import cli
from podbench.core.hints import did_you_mean
from podbench.core.resources import resolve_bundled


def test_did_you_mean_finds_the_closest_name_letter_case_aside():
    assert did_you_mean("SLL", ["POVR", "SL", "ML"]) == "; did you mean 'SL'?"
    assert did_you_mean("sl", ["POVR", "SL", "ML"]) == "; did you mean 'SL'?"
    assert did_you_mean("wiener", ["ls", "tls-dt"]) == ""


@pytest.fixture
def beam_forced():
    return (resolve_bundled("chapter4") / "beam_forced.toml").read_text()


@pytest.mark.parametrize("old, new, extra, command, needle", [
    ('"lti_beam", "ltv_beam"', '"lti_bem", "ltv_beam"', "", "run", "did you mean 'lti_beam'?"),
    ('method = "SL"', 'method = "SIL"', "", "run", "unknown method \"SIL\"; did you mean 'SL'?"),
    ('solver = "block"', 'solver = "blok"', "", "run", "did you mean 'block'?"),
    ('solver = "block"', 'solver = "cgls", solver_options = { maxiter = 50 }', "", "run",
     "unknown option 'maxiter' for solver 'cgls' (its options: reg, tol, max_iter); "
     "did you mean 'max_iter'?"),
    ("", "", '[sweep]\nsolvers = ["lss"]', "sweep", "did you mean 'ls'?"),
    ("", "", '[sweep]\nsolvers = [{solver = "tls-dt", options = {rcnd = 1e-2}}]', "sweep",
     "did you mean 'rcond'?"),
    ('shape = "half_sine"', 'shape = "halfsine"', "", "run",
     "field `cases.load5_half_sine.force`: Parameter `shape`: 'halfsine' is not one of "
     "'rectangular', 'half_sine', 'triangle'; did you mean 'half_sine'?"),
    ('"lti_beam", "ltv_beam"', '"stiff", "ltv_beam"',
     '[variants.stiff]\nstructure = "lti_bem"\nset = { "E" = 1.0 }', "run",
     "did you mean 'lti_beam'?"),
])
def test_a_misspelt_name_gets_the_closest_one(beam_forced, tmp_path, capsys, old, new, extra,
                                              command, needle):
    text = beam_forced.replace(old, new, 1) if old else beam_forced
    text += "\n" + extra + "\n" if extra else ""
    assert text != beam_forced
    folder = tmp_path / "study"
    folder.mkdir()
    (folder / "beam_forced.toml").write_text(text)
    code = cli.main([command, str(folder), "--out", str(tmp_path / "out"), "-q", "--no-cache"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and needle in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, needle", [
    (["run", "chapter44"], "did you mean 'chapter4'?"),
    (["sweep", "--solvers", "lss"], "unknown solver 'lss'; did you mean 'ls'? (solvers: ls,"),
])
def test_a_misspelt_study_or_solver_option_gets_the_closest_name(capsys, argv, needle):
    assert cli.main([*argv, "-q", "--no-cache"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err


def test_python_api_names_get_the_closest_one():
    import podbench as pb
    from podbench.errors import UnknownNameError

    with pytest.raises(UnknownNameError, match=r"Unknown structure 'chain_coupld'; did you "
                                               r"mean 'chain_coupled'\? \(searched "):
        pb.load_structure("chain_coupld")
    chain = pb.load_structure("chain_coupled")
    with pytest.raises(UnknownNameError, match=r"unknown engine 'Exudyn'; did you mean "
                                               r"'exudyn'\? \(known engines: newmark, exudyn\)"):
        pb.simulate(chain, 10, 0.01, engine="Exudyn")
