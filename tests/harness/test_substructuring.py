"""`podbench run substructuring` path on a reduced study file (issue 25)."""

import math
from pathlib import Path

import pandas as pd
import pytest
import tomllib

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
DESIGN = """lti_solver = "realization"
lti_options = { n_pilot = 5000, blocks = 1000 }
lti_records = 4
lti_samples = 5000
passive_fit = "kernel"
"""
"""The study's record design and order rule for time-invariant components
(scenarios/substructuring/substructuring.toml; test_design_matches_the_study checks it)."""
UNSEEN_BOUND = 0.03
"""The issue's 1 %-noise target for the heavy chain, asked of a chain it was not set on (and
missed: the test pins the miss, so that a rule that meets it shows up)."""
HEAVY = _study(2, 20, 'name = "chain_heavy"\nstructure = "chain_coupled"\ncomponent_dof = 4\n',
               DESIGN)
UNSEEN = _study(0, 20, 'name = "chain_unseen"\nstructure = "chain_ideal"\nscale = 0.01\n'
                'component_dof = 4\n',
                DESIGN + 'velocity_components = ["chain_unseen"]\nvelocity_noise = [0.01]\n')

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


def _run(tmp_path, name: str, text: str) -> pd.DataFrame:
    folder = tmp_path / name
    folder.mkdir()
    (folder / "substructuring.toml").write_text(text, encoding="utf-8")
    podbench.run(str(folder), out=tmp_path / f"{name}_out", figures=False)
    return pd.read_csv(tmp_path / f"{name}_out" / "summary.csv")


def test_design_matches_the_study():
    study = tomllib.loads(Path("scenarios/substructuring/substructuring.toml")
                          .read_text(encoding="utf-8"))["substructuring"]["identification"]
    for key, value in tomllib.loads(DESIGN).items():
        assert study[key] == value, key


def test_passive_kernel_keeps_the_heavy_chain_stable(tmp_path):
    """The heavy chain's kernel from 1 %-noise acceleration records (the study's design:
    4 × 0.5 s records, the realization solver's hold-out order rule), made passive: growth
    factor 1, the 10 000-step run bounded, within the issue's 3 % of the assembled truth."""
    df = _run(tmp_path, "heavy", HEAVY)
    pas = df[(df.scheme == "implicit") & (df.kernel == "lti_passive")].iloc[0]
    assert pas.growth <= 1 + 1e-6 and math.isnan(pas.diverged_at_step)
    assert pas.total_error < 0.03


def test_the_rule_on_a_chain_not_in_the_study(tmp_path):
    """The same design on a chain the study does not contain (chain_ideal × 0.01: equal
    masses 0.01 lbf·s²/in, springs 10 lbf/in, modes 1.4–9.7 Hz against the study chain's
    4–41 Hz), from acceleration and velocity records at 1 % noise: made passive, stable
    over 10 000 steps. Not within the heavy chain's 3 %: the hold-out rule keeps 2 poles here
    (10 would give 1.2 %), 3.6 % from acceleration records; from velocity records 24 %: the lag-0
    term (the interface mass the coupling hinges on) carries 2.3 % of the record's RMS under
    white force against 100 % of an acceleration record's, so 1 % noise buries much of it."""
    df = _run(tmp_path, "unseen", UNSEEN)
    pas = df[(df.scheme == "implicit") & (df.kernel == "lti_passive")]
    assert set(pas.records) == {"acceleration", "velocity"}
    assert (pas.growth <= 1 + 1e-6).all() and pas.diverged_at_step.isna().all()
    acc = pas[pas.records == "acceleration"].total_error.iloc[0]
    vel = pas[pas.records == "velocity"].total_error.iloc[0]
    assert UNSEEN_BOUND < acc < 0.05 and vel < 0.3
