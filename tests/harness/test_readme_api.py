"""The Python blocks of the README and of docs/python-api.md run as plain scripts (a fresh
Python in an empty folder, no `if __name__ == "__main__":` guard: worker processes would run
the script again, so podbench computes in the script's own process there), and
`podbench.run` writes what `podbench run` writes (the same tables, byte for byte)."""

import json
import math
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from podbench import api as pb_api
from podbench import cli

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (docs/testing.md)

ROOT = Path(__file__).resolve().parents[2]


def _block(doc: str, first_line: str) -> str:
    """The one ```python block of ``doc`` starting with ``first_line``."""
    text = (ROOT / doc).read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, re.S)
              if b.startswith(first_line)]
    assert len(blocks) == 1, (doc, first_line, len(blocks))
    return blocks[0]


README_CHECKS = """
import json as _json
_json.dump({"out": str(res.out), "rows": len(res.summary),
            "methods": sorted(set(res.summary.method)),
            "estimate": float(band.error_estimate),
            "band_ok": bool((band.lower <= band.upper).all())}, open("readme.json", "w"))
"""

API_CHECKS = """
import json as _json
_row = res.summary.query("structure == 'lti_beam' and method == 'ML' and target == 'load5'")
_json.dump({
    "out": str(res.out), "rows": len(res.summary), "methods": sorted(set(res.summary.method)),
    "figures": sorted(p.name for p in res.figures), "fig_axes": len(fig.axes),
    "html": open("beam_forced.html", encoding="utf-8").read(15),
    "f1": float(f1), "error": float(error), "row_error": float(_row.total_error.iloc[0]),
    "half": float(np.linalg.norm(half - 0.5 * r.W) / np.linalg.norm(0.5 * r.W)),
    "condition": float(ml.diagnostics_["condition_number"]),
}, open("api.json", "w"))
"""


def _run_script(folder: Path, name: str, body: str) -> subprocess.CompletedProcess:
    """``body`` written to ``folder/name`` and run there as ``python name``."""
    (folder / name).write_text(body, encoding="utf-8")
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    r = subprocess.run([sys.executable, name], cwd=folder, env=env, capture_output=True,
                       text=True, timeout=1200)
    assert r.returncode == 0, f"{name}: exit {r.returncode}\n{r.stderr[-3000:]}"
    assert "BrokenProcessPool" not in r.stderr and "bootstrapping" not in r.stderr
    # a warning at most once per script: it computed in its own process, not a broken pool
    assert r.stderr.count("computing in this process alone") <= 1, r.stderr[-2000:]
    return r


@pytest.fixture(scope="module")
def scripts(tmp_path_factory):
    """Both blocks run one after the other in one empty folder (the second one finds the
    first one's truth cache)."""
    folder = tmp_path_factory.mktemp("api_scripts")
    _run_script(folder, "readme_block.py",
                _block("README.md", "import podbench as pb") + textwrap.dedent(README_CHECKS))
    readme = json.loads((folder / "readme.json").read_text())
    _run_script(folder, "api_block.py",
                _block("docs/python-api.md", "import numpy as np") + textwrap.dedent(API_CHECKS))
    api = json.loads((folder / "api.json").read_text())
    return folder, readme, api


def test_the_readme_python_block_runs_as_a_plain_script(scripts):
    folder, got, _ = scripts
    assert got["out"] == str(Path("results") / "beam_forced")
    assert got["rows"] == 12 and got["methods"] == ["ML", "SL"]
    assert got["band_ok"] and 0.0 < got["estimate"] < 1.0


def test_the_python_api_page_block_runs_as_a_plain_script(scripts):
    folder, _, got = scripts
    assert got["out"] == str(Path("results") / "beam_forced")
    assert (folder / "results" / "beam_forced" / "summary.csv").is_file()
    assert got["rows"] == 12 and got["methods"] == ["ML", "SL"]
    assert got["html"].startswith("<!DOCTYPE")
    # 6 targets' figures, the error decomposition, the calibration plot and the modes' MAC
    assert got["fig_axes"] > 0
    figures = got["figures"]
    assert [f for f in figures if not f.startswith("beam_forced__")] == ["calibration.png",
                                                                          "modes_mac.png"]
    assert len(figures) == 9 and figures.count("beam_forced__decomposition.png") == 1
    # the numbers the block's comments state
    assert got["f1"] == pytest.approx(41.376, abs=1e-3)
    assert got["error"] == pytest.approx(0.033, abs=5e-4)  # = the study's ML load5 row
    assert got["error"] == pytest.approx(got["row_error"], rel=1e-5)
    assert got["half"] == pytest.approx(0.0083, abs=5e-4)  # POVR is linear in w0; 3 POMs
    assert math.isfinite(got["condition"])


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
