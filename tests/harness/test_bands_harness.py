"""Band columns of the study tables, their regression and the calibration section (issue 21)."""

import math

import numpy as np
import pandas as pd
from conftest import CHAIN_FREE

from podbench.harness.regress import compare
from podbench.harness.runner import COLUMNS, run_unit
from podbench.report.calibration import (
    calibration_markdown,
    calibration_rows,
    calibration_summary,
)


def test_every_row_gets_an_error_estimate_and_a_coverage(write_scenario, monkeypatch):
    from podbench.sysid.methods import bands

    p = write_scenario(CHAIN_FREE)
    res = run_unit(p, "chain_coupled")
    assert {"error_estimate", "coverage"} <= set(COLUMNS)
    rows = {r["method"]: r for r in res.rows}
    for m in ("POVR", "MDS"):
        assert 0.0 <= rows[m]["coverage"] <= 1.0
        assert math.isfinite(rows[m]["error_estimate"]) and rows[m]["error_estimate"] >= 0
    # POVR on the coupled chain: one record; its in-sample residual cannot see the diagonal
    # assumption (coverage < 0.85 without the diagonal term), the split of the target's
    # modal excitation into the training pattern and the rest (bands.diagonal_split) can
    assert rows["POVR"]["coverage"] >= 0.85
    assert {s["source"] for s in res.band_stats} == {"in-sample", "cross-validation"}
    # without that term one record shows no model-form error: no estimate is made (NaN in
    # both columns; Prediction.note says why) instead of printing the in-sample residual's
    monkeypatch.setattr(bands, "DIAGONAL_TERM", False)
    off = {r["method"]: r for r in run_unit(p, "chain_coupled").rows}
    assert math.isnan(off["POVR"]["error_estimate"]) and math.isnan(off["POVR"]["coverage"])
    assert math.isfinite(off["MDS"]["error_estimate"])


def test_a_sweep_point_computes_no_band(write_scenario):
    p = write_scenario(CHAIN_FREE)
    res = run_unit(p, "chain_coupled", overrides={"n_modes": 5})
    assert all("coverage" not in r for r in res.rows)


def _table(cov, est, tot=0.1):
    return pd.DataFrame([{"scenario": "s", "structure": "b", "method": "ML", "target": "t",
                          "total_error": tot, "error_estimate": est, "coverage": cov,
                          "status": "ok"}])


def test_regress_compares_calibration():
    base = _table(0.9, 0.1)
    assert not compare(_table(0.905, 0.101), base).failed
    worse = compare(_table(0.7, 0.1), base)
    assert worse.failed and worse.worse[0][1] == "coverage_gap"
    worse = compare(_table(0.9, 0.5), base)
    assert worse.failed and worse.worse[0][1] == "estimate_log_ratio"
    # a baseline written before the band columns existed compares errors only
    old = base.drop(columns=["coverage", "error_estimate"])
    assert not compare(_table(0.2, 9.0), old).failed


def test_calibration_summary_scores():
    rng = np.random.default_rng(0)
    tot = np.exp(rng.uniform(-5, 0, 40))
    df = pd.DataFrame({"scenario": "s", "structure": "lti_beam", "method": "ML",
                       "target": [f"t{i}" for i in range(40)], "total_error": tot,
                       "error_estimate": tot * np.exp(rng.uniform(-0.5, 0.5, 40)),
                       "coverage": 0.9})
    rows = calibration_rows(df, [], {})
    s = calibration_summary(rows)
    assert s["predictions"] == 40 and s["spearman"] > 0.9 and s["within_factor_2"] == 1.0
    assert "LTI" in calibration_markdown(rows, "x")


def test_target_scores_count_misses_and_bound_by_one_constant_per_model():
    from podbench.report.calibration import target_scores

    tot = np.array([0.01, 0.02, 0.04, 0.08, 0.1, 0.2, 0.3, 0.4])
    # model A: every estimate 3x its error (none within x2; one constant brings all four);
    # model B: ratios 1, 1, 8 and no estimate (two within x2; a constant keeps two, the
    # window of width ln 4 cannot hold both 1 and 8; the missing estimate stays a miss)
    est = np.r_[3 * tot[:4], tot[4], tot[5], 8 * tot[6], np.nan]
    df = pd.DataFrame({"scenario": "s", "structure": "lti_beam",
                       "method": ["A"] * 4 + ["B"] * 4, "target": [f"t{i}" for i in range(8)],
                       "total_error": tot, "error_estimate": est,
                       "coverage": [0.9, 0.9, 0.8, 0.78, 0.86, 0.94, 0.96, 0.9]})
    t = target_scores(calibration_rows(df, [], {}))
    assert t["within_factor_2"] == 2 / 8 and t["no_estimate"] == 1
    assert t["oracle_model_constant"] == (4 + 2) / 8 and t["oracle_within_factor_2"] == 2 / 8
    assert (t["cells"], t["cells_in"]) == (2, 1)  # A's mean 0.845, B's 0.915
    assert math.isclose(t["coverage_lo"], 0.845) and math.isclose(t["coverage_hi"], 0.915)
    assert t["within_model_spearman"] == 1.0 and t["models_ranked"] == 2
