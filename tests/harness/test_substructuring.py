"""`podbench run substructuring` path on a reduced study file (issue 25)."""

import math

import pandas as pd
import pytest

import podbench
from podbench.api import own_study
from podbench.study.substructuring import load_substructuring

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

STUDY = """
[study]
runner = "substructuring"

[substructuring]
parent = "lti_beam"
interface_dof = 46
dt = 1.0e-4
n_samples = 500
load = { location = 16.0, amplitude = 500.0, duration = 5.0e-4 }
noise = [0.01]
seeds = [0]
horizon = 2

[[substructuring.components]]
name = "tip_mass"
structure = "ltv_beam"
tip_mass = true

[substructuring.identification]
ltv_records = [2]
"""

REQUIRED = ["parent", "component", "scheme", "kernel", "records", "n_records", "noise",
            "total_error", "diverged_at_step", "time_ratio"]


def test_reduced_study_runs_through_podbench_run(tmp_path):
    folder = tmp_path / "sub"
    folder.mkdir()
    (folder / "substructuring.toml").write_text(STUDY, encoding="utf-8")
    assert own_study([folder / "substructuring.toml"]).runner == "substructuring"
    assert load_substructuring(folder / "substructuring.toml").components[0].tip_mass
    res = podbench.run(str(folder), out=tmp_path / "out", figures=False)
    df = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert all(c in df.columns for c in REQUIRED)
    exact = df[(df.kernel == "exact") & (df.scheme == "implicit")]
    assert exact.total_error.iloc[0] <= 1e-10
    two = df[(df.kernel == "exact") & (df.scheme == "two-step")]
    assert math.isnan(two.total_error.iloc[0]) and two.outcome.iloc[0] == "refused"
    ltv = df[(df.kernel == "ltv") & (df.scheme == "implicit")]
    assert ltv.total_error.iloc[0] < 0.02
    assert (tmp_path / "out" / "FINDINGS.md").read_text(encoding="utf-8").count("Chapter 6")
    assert len(res.summary) == len(df)
