"""The README's *Python API* block runs as written, and `podbench.run` writes what
`podbench run` writes (the same tables, byte for byte)."""

import re
from pathlib import Path

import numpy as np
import pytest

from podbench import api as pb_api
from podbench import cli

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

README = Path(__file__).resolve().parents[2] / "README.md"


def _api_block() -> str:
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Python API"):text.index("## Conventions")]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 1
    return blocks[0]


def test_the_readme_python_api_block_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    env: dict = {}
    exec(compile(_api_block(), "README.md (Python API)", "exec"), env)  # noqa: S102
    res = env["res"]
    assert res.out == Path("results") / "beam_forced"
    assert (tmp_path / "results" / "beam_forced" / "summary.csv").is_file()
    assert len(res.summary) == 12 and set(res.summary.method) == {"SL", "ML"}
    assert (tmp_path / "beam_forced.html").read_text(encoding="utf-8").startswith("<!DOCTYPE")
    # 6 targets' figures, the scenario's error decomposition and the bands' calibration plot
    assert env["fig"].axes
    assert sorted(p.name for p in res.figures if not p.name.startswith("beam_forced__")) == \
        ["calibration.png"] and len(res.figures) == 8
    assert sum(p.name == "beam_forced__decomposition.png" for p in res.figures) == 1
    # the numbers the block's comments state
    assert env["f1"] == pytest.approx(41.376, abs=1e-3)
    assert env["error"] == pytest.approx(0.033, abs=5e-4)  # = the study's ML load5 row
    row = res.summary.query("structure == 'lti_beam' and method == 'ML' and target == 'load5'")
    assert env["error"] == pytest.approx(float(row.total_error.iloc[0]), rel=1e-5)
    half, W = env["half"], 0.5 * env["r"].W  # POVR is linear in w0; 3 POMs leave 0.8 %
    assert np.linalg.norm(half - W) / np.linalg.norm(W) == pytest.approx(0.0083, abs=5e-4)
    assert np.isfinite(env["ml"].diagnostics_["condition_number"])


def test_run_and_the_cli_write_the_same_tables(tmp_path, monkeypatch):
    import podbench as pb

    monkeypatch.chdir(tmp_path)
    res = pb.run("chapter4/beam_free_velocity", out="api", figures=False)
    assert cli.main(["run", "chapter4/beam_free_velocity", "--out", "cli", "-q",
                     "--no-figures"]) == 0
    for name in ("summary.csv", "summary.md", "fits.csv", "FINDINGS.md"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert len(res.summary) == len(pb.api.read_table(tmp_path / "cli" / "summary.csv"))


def test_run_refuses_what_the_cli_refuses_with_the_same_line(tmp_path, monkeypatch, capsys):
    import podbench as pb
    from podbench.errors import UnknownNameError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(UnknownNameError, match=r"chapter44: .*did you mean 'chapter4'\?"):
        pb.run("chapter44")
    assert cli.main(["run", "chapter44", "-q"]) == 2
    assert "did you mean 'chapter4'?" in capsys.readouterr().err
    with pytest.raises(pb.errors.InputError, match="Parameter `study`"):
        pb.run(42)


def test_the_first_line_of_a_run_names_the_sensitivity_units_it_adds():
    """`podbench run` (Chapter 4) also runs the claims' sensitivity study: it says so, with
    the number of units, before any work."""
    from podbench.study.claims import load_claims_file

    paths, files = pb_api.resolve_study("chapter4")
    scenarios = pb_api.load_scenarios(files)
    claims = pb_api._claims_path(paths)
    line = pb_api._announcement(files, scenarios, load_claims_file(claims), claims, True)
    assert line == ("podbench: running 7 scenarios (15 units of structure × scenario); then "
                    "the claims' sensitivity study (44 units of scenarios/sensitivity, for "
                    "FINDINGS' verdicts over the unstated parameters); then figures and "
                    "report.html")
