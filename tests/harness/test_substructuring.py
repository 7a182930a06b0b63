"""`podbench run substructuring` path on a reduced study file (issue 25)."""

import math

import pandas as pd
import pytest

import podbench
from podbench.api import own_study
from podbench.study.substructuring import load_substructuring

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

HEADER = """
[study]
runner = "substructuring"

[substructuring]
parent = "lti_beam"
interface_dof = 46
dt = 1.0e-4
n_samples = 500
load = { location = 16.0, amplitude = 500.0, duration = 5.0e-4 }
noise = [0.01]
"""


def _study(seed: int, horizon: int, component: str, identification: str) -> str:
    """A one-component study file: the shared header, ``seeds = [seed]``, ``horizon``."""
    return (f"{HEADER}seeds = [{seed}]\nhorizon = {horizon}\n\n[[substructuring.components]]\n"
            f"{component}\n[substructuring.identification]\n{identification}")


STUDY = _study(0, 2, 'name = "tip_mass"\nstructure = "ltv_beam"\ntip_mass = true\n',
               "ltv_records = [2]\n")
HEAVY = _study(2, 20, 'name = "chain_heavy"\nstructure = "chain_coupled"\ncomponent_dof = 4\n',
               "lti_records = 4\nlti_samples = 1000\n")

REQUIRED = ["parent", "component", "scheme", "kernel", "records", "n_records", "noise",
            "total_error", "diverged_at_step", "growth"]


def test_reduced_study_runs_through_podbench_run(tmp_path):
    folder = tmp_path / "sub"
    folder.mkdir()
    (folder / "substructuring.toml").write_text(STUDY, encoding="utf-8")
    assert own_study([folder / "substructuring.toml"]).runner == "substructuring"
    assert load_substructuring(folder / "substructuring.toml").components[0].tip_mass
    res = podbench.run(str(folder), out=tmp_path / "out", figures=False)
    df = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert all(c in df.columns for c in REQUIRED)
    assert "time_ratio" not in df.columns  # wall clock: timing.csv, untracked
    timing = pd.read_csv(tmp_path / "out" / "timing.csv")
    assert len(timing) == len(df) and (timing.time_ratio.dropna() > 0).all()
    exact = df[(df.kernel == "exact") & (df.scheme == "implicit")]
    assert exact.total_error.iloc[0] <= 1e-10
    two = df[(df.kernel == "exact") & (df.scheme == "two-step")]
    assert math.isnan(two.total_error.iloc[0]) and two.outcome.iloc[0] == "refused"
    ltv = df[(df.kernel == "ltv") & (df.scheme == "implicit")]
    assert ltv.total_error.iloc[0] < 0.02
    assert (tmp_path / "out" / "FINDINGS.md").read_text(encoding="utf-8").count("Chapter 6")
    assert len(res.summary) == len(df)


def test_passive_kernel_keeps_the_heavy_chain_stable(tmp_path):
    """The heavy chain's kernel from 1 %-noise acceleration records: as fitted it grows
    (growth > 1, the 10 000-step run leaves 10× the truth's peak); made passive its growth
    factor is 1 and the run stays bounded, within 6 % of the assembled truth."""
    folder = tmp_path / "heavy"
    folder.mkdir()
    (folder / "substructuring.toml").write_text(HEAVY, encoding="utf-8")
    podbench.run(str(folder), out=tmp_path / "out", figures=False)
    df = pd.read_csv(tmp_path / "out" / "summary.csv")
    imp = df[(df.scheme == "implicit") & (df.noise == 0.01)]
    raw = imp[imp.kernel == "lti"].iloc[0]
    pas = imp[imp.kernel == "lti_passive"].iloc[0]
    assert raw.growth > 1 + 1e-4 and raw.diverged_at_step > 500
    assert pas.growth <= 1 + 1e-6 and math.isnan(pas.diverged_at_step)
    assert pas.total_error < 0.06
