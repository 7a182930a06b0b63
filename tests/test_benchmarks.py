"""The benchmark scripts import and run: the POD group at a tiny size (no timing asserted)."""

import csv
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import groups, measure, report  # noqa: E402

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def test_pod_group_at_a_tiny_size_writes_the_csv_columns_and_positive_ratios(tmp_path):
    lines = []
    rows = groups.bench_pod(False, lines.append, size=(2_000, 100, 5))
    assert [(r["group"], r["solver"], r["status"]) for r in rows] == [
        ("pod", "snapshots", "ok"), ("pod", "svd", "ok")]
    out = tmp_path / "bench.csv"
    report.write_csv(rows, out)
    with open(out, newline="") as fh:
        back = list(csv.DictReader(fh))
    assert tuple(back[0]) == report.FIELDS
    assert report.read_csv(out) == [{f: str(r[f]) for f in report.FIELDS} for r in rows]
    for r in back:
        assert (r["m"], r["n"], r["k"], r["baseline"]) == ("2000", "100", "5", "svd")
        for col in ("time_s", "speedup", "baseline_time_s"):
            x = float(r[col])
            assert math.isfinite(x) and x > 0, (col, r[col])
    # the method of snapshots finds the SVD's leading modes (separated POVs 0.8^i)
    assert float(back[0]["max_rel_diff"]) < 1e-6 and back[1]["max_rel_diff"] == "0 (reference)"
    text = report.table(rows)
    assert "**POD of a tall snapshot matrix**" in text and "| 2000 | 100 | 5 | svd |" in text


def test_measure_returns_the_result_a_time_and_a_peak():
    result, t, peak = measure.measure(lambda: np.ones((500, 500)).sum())
    assert result == 250_000.0 and t > 0 and (math.isnan(peak) or peak >= 0)
    assert measure.speedup(2.0, 0.5) == 4.0
    assert measure.rel_diff(np.array([1.0, 1.0]), np.array([1.0, 0.0])) == pytest.approx(1.0)


def test_a_failing_case_comes_back_as_an_error_message_not_an_exception():
    # 10 × 20 snapshots cannot carry the 40 POVs of the test matrix
    status, msg = measure.run_isolated(groups._pod_task, (10, 20, 30, "svd"), 120)
    assert status == "error" and msg.splitlines()[0].startswith("ValueError: matmul")


@pytest.mark.slow
def test_methods_group_at_a_small_size_times_every_method_against_ml():
    lines = []
    rows = groups.bench_methods(False, lines.append, n=60)
    labels = [label for label, _, _ in groups.METHOD_CASES]
    assert [r["case"] for r in rows] == labels
    ok = {r["case"]: r for r in rows if r["status"] == "ok"}
    assert {"ML", "ML (basis all)", "ML (n_lags auto)", "SL", "ERA"} <= set(ok)
    for r in ok.values():
        assert r["baseline"] == "ML" and float(r["time_s"]) > 0 and float(r["speedup"]) > 0
        assert 0 <= float(r["error_vs_truth"]) < 1.5
    assert ok["ML"]["speedup"] == "1"
    assert "**Identification methods on the same data**" in report.table(rows)


def test_robust_script_runs_a_tiny_size_and_reports_ratios_and_errors():
    """benchmarks/robust.py at n = 200, k = 2: a row per solver, block first (ratio 1),
    errors finite; the clean block prediction is exact up to the POD truncation."""
    from benchmarks import robust

    rows = robust.run(200, 2, ["subspace"], 0.01, seed=0)
    assert [r[2] for r in rows] == ["block", "subspace"]
    assert rows[0][5] == 1.0 and rows[0][3] == 0.0 and rows[1][3] == 0.01
    assert all(np.isfinite(r[6]) for r in rows)
    assert rows[0][6] < 0.05


def test_bands_heldout_scores_one_design_against_its_truth():
    """One MDS design of the held-out band evaluation at 1 % noise: every target is scored,
    the realized error recomputed here from the truth, and the scores are in range."""
    from benchmarks import bands_heldout as H

    d = H.designs("dev", ("LTI",), ("MDS",), 1)[0]
    sims = H.simulate_design(d)
    import pandas as pd

    df = pd.DataFrame(H.run_design(d, 0.01, sims))
    assert len(df) == H.TARGETS and set(df["status"]) == {"ok"}
    model = H.make_method(d).fit([H.noisy_record(r, 0.01, d, f"train{j}")
                                  for j, r in enumerate(sims[0])])
    rec = H.noisy_record(sims[1][0], 0.01, d, "target0")
    truth = np.asarray(sims[1][0].W)
    real = np.linalg.norm(model.predict(rec) - truth) / np.linalg.norm(truth)
    assert df["total_error"].iloc[0] == pytest.approx(real, rel=1e-12)
    s = H.scores(df)
    assert 0 <= s["within_factor_2"] <= 1 and -1 <= s["spearman"] <= 1
    assert s["interval_score_ratio"] > 0 and s["no_estimate"] == 0


def test_bands_rules_reproduces_the_live_band_offline(monkeypatch):
    """``bands_rules`` applied to the stored ``--features`` rows of one held-out design
    (MDS, LTI, 1 % noise) under the default rule gives back the live band: each target's
    estimate (to the stored 6 digits), coverage (to the width grid's resolution) and
    interval score."""
    import pandas as pd

    from benchmarks import bands_heldout as H
    from benchmarks import bands_rules as R

    monkeypatch.setattr(H, "FEATURES", True)
    d = H.designs("dev", ("LTI",), ("MDS",), 1)[0]
    rows = pd.DataFrame(H.run_design(d, 0.01, H.simulate_design(d)))
    assert set(rows["status"]) == {"ok"}
    est, own, rule = R._model_estimates(rows, "gains")
    assert rule == "gains"
    np.testing.assert_allclose(est, rows["error_estimate"], rtol=1e-4)
    cov, isc, _ = R._band(rows, est, own)
    np.testing.assert_allclose(cov, rows["coverage"], atol=0.005)
    np.testing.assert_allclose(isc, rows["interval_score"], rtol=0.01)


def test_bands_heldout_jackknife_is_the_fold_refits_spread_on_the_target(monkeypatch):
    """The ``--features`` jackknife of one held-out MDS design (LTI, 1 % noise, k = N):
    the fold models refitted here (MDS on the other N − 1 records in N − 1 modes) give the
    band's own fold errors, the target's ``J²`` is ``(N − 1)/N Σ_j ‖Ŵ_(j) − W̄‖²/‖Ŵ‖²`` of
    their predictions, and fold 0's ``J_0`` comes from its N − 2-record refits; the
    rules' ``sqrt(e² + J²)`` is computed from those columns."""
    import pandas as pd

    from benchmarks import bands_heldout as H
    from benchmarks import bands_rules as R
    from podbench.sysid.methods import MDS

    monkeypatch.setattr(H, "FEATURES", True)
    d = H.designs("dev", ("LTI",), ("MDS",), 1)[0]
    sims = H.simulate_design(d)
    rows = pd.DataFrame(H.run_design(d, 0.01, sims))
    recs = [H.noisy_record(r, 0.01, d, f"train{j}") for j, r in enumerate(sims[0])]
    model = H.make_method(d).fit(recs)
    rec = H.noisy_record(sims[1][0], 0.01, d, "target0")
    Wh = np.asarray(model.predict(rec))
    U, N = np.asarray(model.modes_), len(recs)
    assert U.shape[1] == N
    folds = [MDS(n_modes=N - 1).fit(recs[:j] + recs[j + 1:], basis=U[:, :N - 1])
             for j in range(N)]
    errs = []
    for j, f in enumerate(folds):
        W = np.asarray(recs[j].W)
        U1 = U[:, :N - 1]
        R_ = U1 @ (U1.T @ W) - np.asarray(f.predict(recs[j])) + (W - U @ (U.T @ W))
        errs.append(np.linalg.norm(R_) / np.linalg.norm(W))
    np.testing.assert_allclose(errs, R._floats(rows["fold_errors"].iloc[0]), rtol=1e-5)
    P = np.stack([np.asarray(f.predict(rec)) for f in folds])
    J = np.sqrt((N - 1) / N * np.sum((P - P.mean(axis=0)) ** 2) / np.sum(Wh ** 2))
    assert rows["jack"].iloc[0] == pytest.approx(J, rel=1e-9)
    J_full = np.sqrt((N - 1) / N * np.sum((P - Wh) ** 2) / np.sum(Wh ** 2))
    assert rows["jack_full"].iloc[0] == pytest.approx(J_full, rel=1e-9)
    own = np.asarray(folds[0].predict(recs[0]))
    P0 = np.stack([np.asarray(MDS(n_modes=N - 2).fit(
        [recs[m] for m in range(N) if m not in (0, i)], basis=U[:, :N - 2]).predict(recs[0]))
        for i in range(1, N)])
    J0 = np.sqrt((N - 2) / (N - 1) * np.sum((P0 - P0.mean(axis=0)) ** 2) / np.sum(own ** 2))
    assert R._floats(rows["fold_jack"].iloc[0])[0] == pytest.approx(J0, rel=1e-5)
    est, _, fell = R.jack_estimates(rows, "hypot")
    assert not fell
    np.testing.assert_allclose(est, np.hypot(rows["error_estimate"], rows["jack"]))


def test_bands_learning_step_matches_the_band_folds_and_explicit_refits():
    """``bands_learning.learning_step`` on one held-out MDS design (LTI, 1 % noise, k = N):
    its leave-one-out errors are the band's own fold errors, and each leave-two-out error
    is the record predicted by MDS refitted here on the other N − 2 records in N − 2 modes
    (its error inside those modes plus the full basis's projection error); the step is
    their geometric-mean ratio."""
    from benchmarks import bands_heldout as H
    from benchmarks.bands_learning import correction, learning_step
    from podbench.sysid.methods import MDS

    d = H.designs("dev", ("LTI",), ("MDS",), 1)[0]
    recs = [H.noisy_record(r, 0.01, d, f"train{j}") for j, r in enumerate(H.simulate_design(d)[0])]
    model = H.make_method(d).fit(recs)
    out = learning_step(model, recs)
    N = len(recs)
    e1 = np.array([float(x) for x in out["e1_all"].split(";")])
    np.testing.assert_allclose(e1, model.calibrate_band().fold_errors, rtol=1e-5)
    U = model.modes_
    U2 = U[:, :N - 2]
    e2 = np.zeros((N, N))
    for j in range(N):
        for l in range(N):
            if l != j:
                m = MDS(n_modes=N - 2).fit([recs[i] for i in range(N) if i not in (j, l)],
                                           basis=U2)
                W = np.asarray(recs[j].W, float)
                R = U2 @ (U2.T @ W) - np.asarray(m.predict(recs[j])) + (W - U @ (U.T @ W))
                e2[j, l] = np.linalg.norm(R) / np.linalg.norm(W)
    g2 = np.exp([np.mean(np.log(np.delete(e2[j], j))) for j in range(N)])
    np.testing.assert_allclose([float(x) for x in out["e2_all"].split(";")], g2, rtol=1e-5)
    assert out["step"] == pytest.approx(np.exp(np.mean(np.log(e1 / g2))), rel=1e-5)
    pairs = np.sort([float(x) for x in out["pair_errors"].split(";")])
    np.testing.assert_allclose(pairs, np.sort(e2[~np.eye(N, dtype=bool)]), rtol=1e-5)
    # the power law through (N − 2, e2) and (N − 1, e1), one record further
    p = -np.log(out["step"]) / np.log((N - 1) / (N - 2))
    assert correction(out["step"], N, "power") == pytest.approx(((N - 1) / N) ** p)
    assert correction(out["step"], N, "step") == out["step"]


def test_bands_rules_mondrian_quantile_is_the_category_folds_own():
    """The offline conformal quantile from the folds' stored coverage curves is the
    ⌈0.9(N + 1)⌉-th smallest of the pooled scores r/c (to the width grid's step), and a
    Mondrian category's is that of its own folds' scores alone."""
    from benchmarks import bands_rules as R

    rng = np.random.default_rng(3)
    scores = [rng.lognormal(0.0, 0.5, 400), 3.0 * rng.lognormal(0.0, 0.5, 600)]
    c = np.array([0.5, 2.0])
    n = np.array([s.size for s in scores], float)
    cdfs = [np.searchsorted(np.sort(s * cj), R.SCALE_GRID, side="right") / s.size
            for s, cj in zip(scores, c, strict=True)]
    step = np.log(R.SCALE_GRID[1] / R.SCALE_GRID[0])

    def exact(parts):
        pooled = np.sort(np.concatenate(parts))
        return pooled[int(np.ceil(0.9 * (pooled.size + 1))) - 1]

    q = R._log_quantile(n, c, cdfs, 0.9)
    assert abs(q - np.log(exact(scores))) < step
    q1 = R._log_quantile(n[1:], c[1:], cdfs[1:], 0.9)
    assert abs(q1 - np.log(exact(scores[1:]))) < step
    assert q1 > q  # the second fold's scores are the larger


def test_bands_amplitude_load_levels_by_quadrature():
    """A pulse's peak, impulse ∫|F| dt and energy ∫F² dt (hits included) against a fine
    quadrature of its shape: half-sine 500 lbf, 1.5 ms, one 0.4 rebound."""
    from types import SimpleNamespace

    from benchmarks.bands_amplitude import load_level

    p = SimpleNamespace(amplitude=-500.0, duration=1.5e-3, shape="half_sine",
                        hits=[[0.01, 0.4]])
    t = np.linspace(0.0, p.duration, 200001)
    f = 500.0 * np.sin(np.pi * t / p.duration)
    impulse = np.trapezoid(f, t) * 1.4
    energy = np.trapezoid(f ** 2, t) * (1.0 + 0.4 ** 2)
    assert load_level(p, "peak") == (500.0, pytest.approx(energy, rel=1e-8))
    assert load_level(p, "impulse")[0] == pytest.approx(impulse, rel=1e-8)
    assert load_level(p, "rms")[0] == pytest.approx(np.sqrt(energy), rel=1e-8)
    tri = SimpleNamespace(amplitude=2.0, duration=1.0, shape="triangle", hits=[])
    t = np.linspace(0.0, 1.0, 200001)
    f = 2.0 * (1.0 - np.abs(2.0 * t - 1.0))
    assert load_level(tri, "impulse")[0] == pytest.approx(np.trapezoid(f, t), rel=1e-8)
    assert load_level(tri, "peak")[1] == pytest.approx(np.trapezoid(f ** 2, t), rel=1e-8)


def test_f16_time_schedules_tasks_as_the_executor_hands_them_out():
    from benchmarks.f16_time import makespan

    # in the given order, each task to the process that frees first
    assert makespan([5.0, 4.0, 3.0, 3.0], 2) == 8.0  # 5+3 | 4+3
    assert makespan([1.0, 1.0, 4.0], 2) == 5.0  # 1+4 | 1: the order matters
    assert makespan([2.0, 3.0], 1) == 5.0
