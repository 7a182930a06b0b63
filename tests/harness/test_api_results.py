"""Each function of podbench.api returns one type, and its errors name the Python parameter
(the command line names the flag)."""

import inspect
import typing
from pathlib import Path

import pytest

import podbench as pb
from podbench import api, cli
from podbench.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def test_every_api_function_declares_one_return_type():
    for name in ("run", "regress", "sweep", "experiment", "predict"):
        annotation = inspect.signature(getattr(api, name)).return_annotation
        assert "|" not in str(annotation) and typing.get_origin(annotation) is None, name


def test_regress_returns_its_result_object():
    baseline = ROOT / "results" / "baseline.csv"
    got = api.regress(table=baseline, baseline=baseline)
    assert isinstance(got, api.RegressResult) and not got.updated and not got.failed
    assert got.rows > 100 and got.comparison is not None and got.baseline == baseline


def test_python_errors_name_the_parameter_and_the_command_line_the_flag(tmp_path, capsys):
    with pytest.raises(InputError, match=r"^Parameter `jobs`: expected a positive integer"):
        pb.run("chapter4", jobs=0)
    afile = tmp_path / "a_file"
    afile.write_text("")
    with pytest.raises(InputError, match=r"^Parameter `out`: .*exists and is not a folder"):
        pb.run("chapter4", out=afile)
    assert cli.main(["run", "chapter4", "--out", str(afile)]) == 2
    assert capsys.readouterr().err.startswith("podbench run: error: --out: ")
