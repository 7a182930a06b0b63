"""podbench outside its checkout, and the checkout after the README's first command.

Both slow (they build a wheel, or regenerate the whole Chapter 4 study in a clone).
"""

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd, cwd, env=None, timeout=900):
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True,
                       timeout=timeout)
    assert r.returncode == 0, f"{cmd}: exit {r.returncode}\n{r.stdout}\n{r.stderr}"
    return r


def _clean_env():
    env = dict(os.environ)
    for k in ("PYTHONPATH", "PODBENCH_STRUCTURES"):
        env.pop(k, None)
    return env


@pytest.mark.slow
def test_a_wheel_installed_in_a_fresh_venv_runs_a_bundled_scenario_from_an_empty_folder(
        tmp_path):
    # the wheel, built from the checkout as pip builds any project
    wheels = tmp_path / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", wheels, ROOT],
         cwd=tmp_path)
    (wheel,) = wheels.glob("podbench-*.whl")

    # a fresh venv: the wheel alone (no deps), the current venv's packages behind it (.pth)
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=tmp_path)
    py = venv / "bin" / "python"
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=tmp_path).stdout.strip())
    (site / "zz_current_venv.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "-q", wheel],
         cwd=tmp_path, env=_clean_env())

    empty = tmp_path / "somewhere"
    empty.mkdir()
    env = _clean_env()
    where = _run([py, "-c", "import podbench; print(podbench.__file__)"], cwd=empty, env=env)
    assert Path(where.stdout.strip()).is_relative_to(site)  # the wheel, not the checkout

    podbench = venv / "bin" / "podbench"
    out = _run([podbench, "list"], cwd=empty, env=env).stdout
    assert "structures bundled with podbench (structures):" in out
    assert "  satellite_truss" in out and "  beam_forced_noise:" in out
    assert "scenarios bundled with podbench: chapter4" in out

    r = _run([podbench, "run", "chapter4/truss_free_displacement", "--cache", tmp_path / "c"],
             cwd=empty, env=env)
    res = empty / "results" / "truss_free_displacement"
    assert f"-> {Path('results') / 'truss_free_displacement'}/summary.csv" in r.stdout
    assert "claims: " in r.stdout
    assert sorted(p.name for p in res.iterdir()) == [
        "CALIBRATION.md", "FINDINGS.md", "calibration.csv", "figures", "fits.csv", "report.html",
        "summary.csv", "summary.md"]
    assert "<img" in (res / "report.html").read_text(encoding="utf-8")  # the study's report
    assert sorted(p.name for p in (res / "figures").glob("*.png")) == [
        "calibration.png", "truss_free_displacement__decomposition.png",
        "truss_free_displacement__satellite_truss__w6.png"]
    findings = (res / "FINDINGS.md").read_text(encoding="utf-8")
    assert "`scenarios/chapter4/claims.toml`" in findings
    # the same numbers as the committed study
    mine = (res / "summary.csv").read_text(encoding="utf-8").splitlines()
    ref = (ROOT / "results" / "chapter4" / "summary.csv").read_text(encoding="utf-8")
    ref = ref.splitlines()
    assert mine == ref[:1] + [ln for ln in ref if ln.startswith("truss_free_displacement,")]
    assert len(mine) == 3
    assert sorted(p.name for p in empty.iterdir()) == ["results"]  # the cache went elsewhere

    version = _run([py, "-m", "podbench", "--version"], cwd=empty, env=env).stdout
    assert version.startswith("podbench ")


@pytest.mark.slow
def test_the_readme_first_command_leaves_a_clean_clone(tmp_path):
    """`podbench run` in a fresh clone regenerates results/chapter4 byte-identically (tables,
    fits, findings; the figures are not tracked): `git status --porcelain` stays empty."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert ".venv/bin/podbench run\n" in readme.split("\n\n")[1] + "\n"
    clone = tmp_path / "clone"
    _run(["git", "clone", "-q", ROOT, clone], cwd=tmp_path)
    env = _clean_env()
    env["PYTHONPATH"] = str(clone)
    r = _run([sys.executable, "-m", "podbench", "run", "-q"], cwd=clone, env=env)
    assert f"-> {Path('results') / 'chapter4'}/summary.csv" in r.stdout
    # 31 targets' figures, 7 scenarios' error decompositions and the bands' calibration plot
    assert len(list((clone / "results" / "chapter4" / "figures").glob("*.png"))) == 39
    status = _run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=clone)
    assert status.stdout == ""
