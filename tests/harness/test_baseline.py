"""The committed baseline (results/baseline.csv) matches a fresh run of this commit.

The quick test re-runs the five cheaper Chapter 4 scenarios (a few seconds); the slow test
runs `podbench regress` on both studies (Chapter 4 and 5), as the nightly workflow does."""

from pathlib import Path

import pytest

from podbench import api, cli
from podbench.core.resources import bundled_scenarios
from podbench.harness.regress import compare, read_table
from podbench.harness.runner import run_study
from podbench.harness.tables import summary_table

ROOT = Path(__file__).resolve().parents[2]
CH4 = bundled_scenarios() / "chapter4"
QUICK = ["beam_free_displacement", "beam_free_velocity", "truss_free_displacement",
         "truss_free_velocity", "truss_forced"]


@pytest.mark.heavy
def test_quick_scenarios_reproduce_the_committed_baseline(tmp_path):
    base = read_table(ROOT / "results" / "baseline.csv")
    base = base[base.scenario.isin(QUICK)]
    assert len(base) > 0
    new = summary_table(run_study([CH4 / f"{n}.toml" for n in QUICK], cache_dir=tmp_path))
    cmp = compare(new, base)
    assert not cmp.failed, cmp.report(0.01, 1e-6)
    assert not cmp.better and not cmp.added, "baseline is stale: podbench regress --update"


@pytest.mark.slow
def test_whole_study_regress_passes(monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    assert cli.main(["regress", "-q", "--no-cache"]) == 0, capsys.readouterr().out


def test_baseline_holds_the_studies_regress_runs_by_default():
    """`podbench regress` without a PATH re-runs chapter4 and chapter5; the committed
    baseline has rows of every scenario of both (and of nothing else)."""
    resolved, files = api.resolve_study([], api.REGRESS_STUDIES)
    assert [p.name for p in resolved] == ["chapter4", "chapter5"]
    base = read_table(ROOT / "results" / "baseline.csv")
    assert set(base.scenario) == {Path(f).stem for f in files}
    assert {"beam_forced", "linear_beam_noise_5pct", "rubber_band_beam_decomposition"} <= \
        set(base.scenario)
