"""Prediction bands (issue 21): the API and coverage on a case whose answer is known.

Known answer: MDS on the 5-DOF coupled chain with k = m = 5 is exactly identifiable (the
prediction is ``Σ_j W_j c_j`` with ``c = X0⁻¹ x_new``: it does not depend on the basis), so
per-channel Gaussian noise of known std in the training records reaches the prediction
linearly and exactly Gaussian, independently at every sensor and sample. The noise part of
the band (``cross_validate=False``) must then cover the noise-free truth with the nominal
probability: over R noise realizations of m·n samples each, the coverage is binomial with
standard error ``sqrt(c(1 − c)/(R m n))`` (plus the Monte-Carlo error of the propagated
std, which the test bounds by its own draws).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from podbench.methods import MDS, POVR, MultipleLoad, SingleLoad

from podbench import Record
from podbench.errors import InputError
from podbench.sysid.methods.bands import Prediction, interval_score

from ._cases import forced_case, free_case
from ._truth import newmark


def _noisy(W, sig, rng):
    return W + sig[:, None] * rng.standard_normal(W.shape)


def _chain_records(rng, sig, case):
    return [Record(W=_noisy(W, sig, rng), w0=x, dt=case.dt)
            for W, x in zip(case.W, case.x0, strict=True)]


@pytest.mark.parametrize("coverage", [0.9, 0.5])
def test_noise_band_coverage_is_nominal_on_an_exactly_identifiable_chain(coverage):
    case = free_case("coupled", "displacement")
    m, n = case.W[0].shape
    rms = np.sqrt(np.mean(np.stack(case.W) ** 2, axis=(0, 2)))
    sig = 0.01 * rms  # 1 % per-channel noise, known
    target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    covered, reps = [], 8
    for r in range(reps):
        rng = np.random.default_rng(100 + r)
        model = MDS(excitation="displacement").fit(_chain_records(rng, sig, case))
        model.calibrate_band(noise_std=sig, n_draws=30, seed=r, cross_validate=False)
        p = model.predict(target, coverage=coverage)
        covered.append(p.covers(case.W_new))
    se = math.sqrt(coverage * (1 - coverage) / (reps * m * n))
    # 3 binomial standard errors + the Monte-Carlo error of a std from 30 draws smoothed over
    # a window of 10 samples (relative error ≈ 1/sqrt(2·300) → coverage shift ≤ 0.01)
    assert abs(np.mean(covered) - coverage) <= 3 * se + 0.01, (np.mean(covered), covered)


def test_predict_without_coverage_returns_the_array():
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(solver="block").fit(recs)
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    plain = model.predict(target)
    assert isinstance(plain, np.ndarray)
    p = model.predict(target, coverage=0.9)
    assert isinstance(p, Prediction)
    np.testing.assert_array_equal(p.mean, plain)
    assert p.lower.shape == p.upper.shape == plain.shape
    assert np.all(p.lower <= p.mean) and np.all(p.mean <= p.upper)
    assert math.isfinite(p.error_estimate) and p.error_estimate > 0
    df = p.to_pandas()
    assert list(df.columns) == ["sensor", "sample", "time", "mean", "lower", "upper"]
    assert len(df) == plain.size
    assert set(p.to_arrays()) == {"W_hat", "lower", "upper"}
    # a wider coverage gives a wider band
    p99 = model.predict(target, coverage=0.99)
    assert np.all(p99.upper - p99.lower >= p.upper - p.lower - 1e-15)


def test_a_band_with_as_many_records_as_modes_given_explicitly():
    """ML with n_modes = k given and exactly k training records: the band is the one of the
    same model built without n_modes (which takes k from the first record)."""
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    k = len(recs)
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    implied = MultipleLoad(solver="block").fit(recs).predict(target, coverage=0.9)
    given = MultipleLoad(n_modes=k, solver="block").fit(recs).predict(target, coverage=0.9)
    assert given.source == "cross-validation"
    np.testing.assert_allclose(given.upper, implied.upper, rtol=1e-12, atol=0)
    assert given.error_estimate == implied.error_estimate


@pytest.mark.parametrize("bad", [0, 1, 1.5, -0.1, float("nan"), "x"])
def test_bad_coverage_is_one_clear_error(bad):
    case = free_case("coupled", "displacement")
    model = POVR(n_modes=2).fit(Record(W=case.W[0], w0=case.x0[0], dt=case.dt))
    with pytest.raises(InputError, match="coverage"):
        model.predict(Record(W=case.W_new, w0=case.x0_new), coverage=bad)


def test_array_form_fit_has_the_record_forms_band():
    """The array form is read into records (podbench.sysid.methods.arrays), so its model
    keeps its training records and has the same band as the record form's."""
    case = forced_case("coupled")
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    arrays = SingleLoad(n_modes=2, solver="block").fit(case.W[0], case.F[0], dt=case.dt)
    records = SingleLoad(n_modes=2, solver="block").fit(
        Record(W=case.W[0], F=case.F[0], dt=case.dt))
    a, r = arrays.predict(target, coverage=0.9), records.predict(target, coverage=0.9)
    np.testing.assert_array_equal(a.upper, r.upper)
    assert a.error_estimate == r.error_estimate > 0


def test_one_record_methods_say_what_the_band_rests_on():
    case = free_case("coupled", "displacement")
    model = POVR(n_modes=3).fit(Record(W=case.W[0], w0=case.x0[0], dt=case.dt))
    p = model.predict(Record(W=case.W_new, w0=case.x0_new, dt=case.dt), coverage=0.9)
    assert p.source == "in-sample"
    assert np.all(np.isfinite(p.lower)) and np.all(np.isfinite(p.upper))


def test_interval_score_rewards_cover_and_sharpness():
    W = np.zeros((2, 4))
    lo, up = -np.ones((2, 4)), np.ones((2, 4))
    assert interval_score(W, lo, up, 0.9) == pytest.approx(2.0)
    assert interval_score(W + 2, lo, up, 0.9) == pytest.approx(2.0 + 20.0)


def test_the_folds_reuse_the_full_fits_regularization():
    """ML with Tikhonov CGLS (reg by GCV): frozen_params fixes the GCV choice, a model fitted
    with it equals the GCV fit (same reg, same kernel), and the band's refits run at that
    reg (the fold's solver reports reg_rule 'fixed' and the same reg) instead of a new
    GCV search; reuse_choices=False restores the search."""
    from podbench.sysid.methods import bands

    case = forced_case("coupled")
    rng = np.random.default_rng(3)
    recs = [Record(W=W + 1e-3 * np.std(W) * rng.standard_normal(W.shape), F=F, dt=case.dt)
            for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(n_modes=3, solver="cgls").fit(recs)
    info = model.solver_info_
    assert info["reg_rule"] == "gcv" and info["reg"] > 0
    frozen = model.frozen_params()
    assert frozen == {"solver": "cgls", "solver_options": {"reg": info["reg"]}}
    again = MultipleLoad(n_modes=3, **frozen).fit(recs)
    assert again.solver_info_["reg_rule"] == "fixed"
    np.testing.assert_allclose(again.kernel_, model.kernel_, rtol=1e-6,
                               atol=1e-6 * np.max(np.abs(model.kernel_)))
    fold = bands._refit(model, recs[1:], basis=model.modes_, frozen=frozen)
    assert fold.solver_info_["reg_rule"] == "fixed"
    assert fold.solver_info_["reg"] == info["reg"]
    free = bands._refit(model, recs[1:], basis=model.modes_)
    assert free.solver_info_["reg_rule"] == "gcv"
    p = model.predict(Record(W=case.W_new, F=case.F_new, dt=case.dt), coverage=0.9)
    assert p.source == "cross-validation" and np.isfinite(p.error_estimate)


def test_frozen_solver_rules():
    from podbench.sysid.methods.base import frozen_solver

    assert frozen_solver("ls", None, {"rank": 4}) is None
    assert frozen_solver("cgls", {"tol": 1e-8}, {"reg": 0.01, "reg_rule": "fixed"}) is None
    assert frozen_solver("fft", {"pad": 3.0}, {"reg": 0.02, "reg_rule": "gcv"}) == \
        ("fft", {"pad": 3.0, "reg": 0.02})
    assert frozen_solver("realization", None, {"order": 8, "order_rule": "holdout"}) == \
        ("realization", {"order": 8})
    assert frozen_solver("auto", None, {"choice": "block"}) == ("block", {})
    assert frozen_solver("auto", {"kernel": "tc", "threshold": 3.0},
                         {"choice": "kernel", "reg_rule": "evidence", "lam": 0.9,
                          "rho": 0.5, "gamma": 2.0}) == \
        ("kernel", {"kernel": "tc", "lam": 0.9, "rho": 0.5, "gamma": 2.0})


def test_diagonal_inconsistency_by_hand():
    from podbench.sysid.methods.bands import diagonal_inconsistency

    u = np.array([1.0, 1.0])
    # s = q'/u = (1, 0), weights (1/2, 1/2): s̄ = 1/2, spread sqrt(2 · ½ · ¼) = 1/2 → D = 1
    assert diagonal_inconsistency(u, np.array([1.0, 0.0])) == pytest.approx(1.0)
    # a target with the training pattern, any time history: D = 0
    f = np.sin(np.linspace(0, 3, 40))
    u3 = np.array([0.3, -1.2, 0.5])
    assert diagonal_inconsistency(u3, -4.0 * np.outer(u3, f)) == pytest.approx(0, abs=1e-12)
    # scale-free in the pattern and in the target
    q = np.array([[0.1, 2.0], [1.0, 0.0], [0.4, -0.2]])
    assert diagonal_inconsistency(7 * u3, 1e-3 * q) == pytest.approx(
        diagonal_inconsistency(u3, q), rel=1e-12)


def test_single_load_split_is_exact_on_the_training_pattern():
    """SL (k = m, exact ``"block"`` deconvolution) on the coupled chain, trained on a pulse at
    one DOF (modal forces ``UᵀF = a ⊗ g``): the method is exact on any load with the
    training pattern, so ``Ŵ − Ŵ_⊥`` (:func:`diagonal_split`) is the true response to the
    load's part with that pattern, ``F_∥ = U â âᵀUᵀF'`` (simulated independently), and the
    prediction's error is exactly ``Ŵ_⊥ − W_⊥`` with ``W_⊥`` the true response to the rest."""
    case = forced_case("coupled")
    model = SingleLoad(n_modes=5, solver="block").fit(
        Record(W=case.W[2], F=case.F[2], dt=case.dt))
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    W_hat = model.predict(target)
    W_perp, T2 = model.diagonal_parts(target)
    U = model.modes_
    a = model.force_pattern_ / np.linalg.norm(model.force_pattern_)
    F_par = U @ np.outer(a, a @ (U.T @ case.F_new))
    W_par = newmark(case.M, case.C, case.K, case.dt, case.n, F=F_par)[0]
    scale = np.linalg.norm(case.W_new)
    assert np.linalg.norm(W_hat - W_perp - W_par) <= 1e-8 * scale
    W_rest = newmark(case.M, case.C, case.K, case.dt, case.n, F=case.F_new - F_par)[0]
    assert np.linalg.norm((W_hat - case.W_new) - (W_perp - W_rest)) <= 1e-8 * scale
    # the diagonal assumption is broken on this chain: the unexplained part is not small,
    # and the bound T is the response to each mode's unexplained force in the training
    # pattern (its square summed over the modes)
    assert np.linalg.norm(W_perp) > 0.1 * scale and np.all(T2 >= 0)
    q_perp = U.T @ (case.F_new - F_par)
    T2_hand = sum((U @ model._modal_response(model.kernel_, np.outer(a, row))) ** 2
                  for row in q_perp)
    np.testing.assert_allclose(T2, T2_hand, rtol=1e-10, atol=1e-30)


def test_povr_split_by_hand():
    """POVR with k = m on the coupled chain: the part of a new initial displacement with
    the training pattern is ``c·x0`` (``c = aᵀb/aᵀa`` with ``a = Uᵀx0``, ``b = Uᵀx0'``),
    whose true response is ``c·W`` (linearity): ``Ŵ − Ŵ_⊥ = c·W`` exactly; a target with
    the training pattern has nothing unexplained."""
    case = free_case("coupled", "displacement")
    model = POVR(n_modes=5).fit(Record(W=case.W[0], w0=case.x0[0], dt=case.dt))
    target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    W_perp, T2 = model.diagonal_parts(target)
    a, b = model.modes_.T @ case.x0[0], model.modes_.T @ case.x0_new
    c = float(a @ b / (a @ a))
    np.testing.assert_allclose(model.predict(target) - W_perp, c * case.W[0],
                               atol=1e-10 * np.abs(case.W[0]).max())
    same = Record(W=-2 * case.W[0], w0=-2 * case.x0[0], dt=case.dt)
    W_perp0, T20 = model.diagonal_parts(same)
    peak = np.abs(case.W[0]).max()
    assert np.abs(W_perp0).max() <= 1e-12 * peak and T20.max() <= (1e-12 * peak) ** 2


def test_single_load_band_carries_the_diagonal_term(monkeypatch):
    """SL on the coupled chain (its diagonal assumption is broken): a target loaded where
    the training load was (same modal pattern, other amplitude) has nothing unexplained and
    the in-sample band; a target loaded elsewhere gets the split's wider band, an estimate
    relative to the truth's norm the record supports (``‖Ŵ − Ŵ_⊥‖² + ‖Ŵ_⊥‖‖T‖``), and a band
    that covers the truth. The ``"tangent"`` variant carries :func:`diagonal_inconsistency`."""
    from podbench.sysid.methods import bands

    case = forced_case("coupled")
    train = Record(W=case.W[2], F=case.F[2], dt=case.dt)
    model = SingleLoad(n_modes=3, solver="block").fit(train)
    same = Record(W=3.0 * case.W[2], F=3.0 * case.F[2], dt=case.dt)
    other = Record(W=case.W[4], F=case.F[4], dt=case.dt)
    q = model.predict(same, coverage=0.9)
    assert q.details["diagonal_unexplained"] == pytest.approx(0.0, abs=1e-9)
    p = model.predict(other, coverage=0.9)
    W_perp, T2 = model.diagonal_parts(other)
    Wh = p.mean
    assert p.details["diagonal_unexplained"] == pytest.approx(
        np.linalg.norm(W_perp) / np.linalg.norm(Wh))
    # the truth's norm: the explained part plus ‖W_⊥‖, read as the geometric mean of the
    # method's own ‖Ŵ_⊥‖ and the training pattern's gain ‖T‖ (bands.DIAGONAL_NORM)
    ref = math.sqrt(np.sum((Wh - W_perp) ** 2)
                    + math.sqrt(np.sum(W_perp ** 2) * np.sum(T2)))
    assert p.error_estimate >= math.sqrt(np.sum(W_perp ** 2) + np.sum(T2)) / ref * 0.999
    assert p.covers(case.W[4]) >= 0.85
    assert q.error_estimate < 0.5 * p.error_estimate
    monkeypatch.setattr(bands, "DIAGONAL_RULE", "tangent")
    D = model.diagonal_inconsistency(other)
    assert D == pytest.approx(bands.diagonal_inconsistency(model.force_pattern_,
                                                           model.modes_.T @ case.F[4]))
    t = model.predict(other, coverage=0.9)
    assert t.details["diagonal_inconsistency"] == pytest.approx(D)
    assert t.error_estimate >= D * 0.999


@pytest.mark.heavy
@pytest.mark.parametrize("rule", ["gains", "folds"])
def test_extrapolation_widens_a_cross_validated_band_with_the_prediction_amplitude(
        monkeypatch, rule):
    """ML on the coupled chain (exact): a target 10× a training load gets, besides the
    10× prediction, a band widened by how far its RMS lies beyond the training records'
    RMS range (:func:`extrapolation`) to the power the calibration holds:
    ``GAINS_RESPONSE_LEVEL_POWER`` under the ``"gains"`` rule (set to 1 here so that the
    factor is exercised; the default is 0), ``RESPONSE_LEVEL_POWER`` (0: a linear model's
    relative error is the same for 10× the load) under the ``"folds"`` variant."""
    from podbench.sysid.methods import bands

    monkeypatch.setattr(bands, "ESTIMATE_RULE", rule)
    monkeypatch.setattr(bands, "GAINS_RESPONSE_LEVEL_POWER", 1.0)
    power = 1.0 if rule == "gains" else bands.RESPONSE_LEVEL_POWER
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(n_modes=4, solver="ls").fit(recs)
    base = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    big = Record(W=10 * case.W_new, F=10 * case.F_new, dt=case.dt)
    pb_, pg = model.predict(base, coverage=0.9), model.predict(big, coverage=0.9)
    lo, hi = model.band_calibration_.amplitude_range
    rms = lambda X: float(np.sqrt(np.mean(X ** 2)))  # noqa: E731
    d_base = bands.extrapolation(rms(pb_.mean), lo, hi)
    d_big = bands.extrapolation(rms(pg.mean), lo, hi)
    assert d_big > 1
    assert model.band_calibration_.level_power == power
    ratio = (d_big / d_base) ** model.band_calibration_.level_power
    # the estimate's part beyond the projection share scales by d (the terms of the target
    # are scale-free: 10× the load has the same leverage and blind spot)
    rho2 = pb_.details.get("projection_share", 0.0) ** 2
    np.testing.assert_allclose(pg.error_estimate ** 2 - rho2,
                               ratio ** 2 * (pb_.error_estimate ** 2 - rho2), rtol=1e-9)
    # the band is the estimate's absolute error ‖Ŵ‖ e/sqrt(1 + e²) spread over the envelope
    def absolute(p):
        return 1 / math.sqrt(1 + p.error_estimate ** -2)
    np.testing.assert_allclose(pg.half_width, 10 * absolute(pg) / absolute(pb_)
                               * pb_.half_width, rtol=1e-9)
    assert bands.extrapolation(2.0, 1.0, 4.0) == 1.0
    assert bands.extrapolation(8.0, 1.0, 4.0) == 2.0
    # below the training range: not an extrapolation (the linearization error grows with
    # amplitude) unless EXTRAPOLATE_BELOW
    assert bands.extrapolation(0.25, 1.0, 4.0) == (4.0 if bands.EXTRAPOLATE_BELOW else 1.0)


@pytest.mark.heavy
@pytest.mark.parametrize("excitation", ["forced", "displacement"])
def test_peers_bands_reuse_the_chosen_order(excitation):
    """ERA chooses its order by hold-out; the band's folds reuse it (frozen_params holds
    exactly the order, nothing else ERA derives, e.g. its lag count), and the band is
    finite. OpInf likewise freezes its regularizer."""
    from podbench.sysid.methods.peers import ERA, OpInf

    if excitation == "forced":
        case = forced_case("coupled")
        recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
        target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    else:
        case = free_case("coupled", "displacement")
        recs = [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
        target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    era = ERA(excitation=excitation, n_modes=3).fit(recs)
    assert era.frozen_params() == {"order": era.order_}
    p = era.predict(target, coverage=0.9)
    assert p.source == "cross-validation" and np.isfinite(p.error_estimate)
    if excitation == "forced":
        op = OpInf().fit(recs)
        assert op.frozen_params() == {"regularizer": op.regularizer_}
        assert np.isfinite(op.predict(target, coverage=0.9).error_estimate)


def _refit_folds(model, recs, U, cv_modes):
    from podbench.sysid.methods import bands

    frozen = bands._frozen(model)
    return [np.asarray(bands._refit(model, recs[:j] + recs[j + 1:], n_modes=cv_modes,
                                    basis=U, frozen=frozen).predict(recs[j]))
            for j in range(len(recs))]


@pytest.mark.parametrize("make, n_modes", [
    (lambda: MultipleLoad(solver="block"), None),           # k = N: folds in k − 1 modes
    (lambda: MultipleLoad(n_modes=3, solver="cgls"), 3),    # N > k: GCV λ frozen
    (lambda: MDS(excitation="displacement"), None),         # k = N: V̂0 square per fold
    (lambda: MDS(excitation="displacement", n_modes=3), 3), # N > k: pseudo-inverse per fold
])
def test_fold_predictions_equal_the_refits(make, n_modes):
    """The structured leave-one-record-out folds (MDS: linear in the other records'
    projections; ML: the folds' deconvolutions solved together) predict what refitting each
    fold predicts, to round-off."""
    from podbench.sysid.methods import bands

    if isinstance(make(), MDS):
        case = free_case("coupled", "displacement")
        recs = [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
    else:
        case = forced_case("coupled")
        rng = np.random.default_rng(5)
        recs = [Record(W=W + (1e-3 * np.std(W) * rng.standard_normal(W.shape)
                              if n_modes else 0.0), F=F, dt=case.dt)
                for W, F in zip(case.W, case.F, strict=True)]
    model = make().fit(recs)
    U = np.asarray(model.modes_)
    cv_modes = len(recs) - 1 if U.shape[1] > len(recs) - 1 else None
    U_cv = U if cv_modes is None else U[:, :cv_modes]
    fast = model.fold_predictions(recs, U_cv, bands._frozen(model))
    slow = _refit_folds(model, recs, U_cv, cv_modes)
    assert len(fast) == len(slow) == len(recs)
    for a, b in zip(fast, slow, strict=True):
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b)), np.max(np.abs(a - b))
    # and the calibration uses them: its folds' residuals are the refits'
    residuals = bands._residuals(model, recs, U, True, bands._frozen(model))[1]
    for R, b, r in zip(residuals, slow, recs, strict=True):
        inside = U_cv @ (U_cv.T @ r.W) if cv_modes else r.W
        expect = inside - b + ((r.W - U @ (U.T @ r.W)) if cv_modes else 0.0)
        np.testing.assert_allclose(R, expect, rtol=0, atol=1e-9 * np.max(np.abs(r.W)))



def test_fold_models_skip_the_unread_residual(monkeypatch):
    """ML's fold models (:meth:`fold_predictions`) leave ``fit_residual_`` uncomputed — a
    convolution of every record that nothing in the band reads — and predict the same bytes
    as fold models that compute it; the public fit keeps it."""
    from podbench.sysid.methods import bands, forced

    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(n_modes=3, solver="cgls").fit(recs)
    assert np.isfinite(model.fit_residual_)
    seen = []
    orig = forced.MultipleLoad._finish

    def spy(self, *a, residual=True, **k):
        seen.append(residual)
        return orig(self, *a, residual=residual, **k)

    monkeypatch.setattr(forced.MultipleLoad, "_finish", spy)
    U, frozen = np.asarray(model.modes_), bands._frozen(model)
    lean = model.fold_predictions(recs, U, frozen)
    assert seen == [False] * len(recs)
    monkeypatch.setattr(forced.MultipleLoad, "_finish",
                        lambda self, *a, residual=True, **k: orig(self, *a, residual=True, **k))
    full = model.fold_predictions(recs, U, frozen)
    for a, b in zip(lean, full, strict=True):
        assert a.tobytes() == b.tobytes()

def test_block_solve_many_equals_solve_and_falls_back():
    """``"block"``'s batched forward substitution gives each system's own solution and
    diagnostics; systems it cannot batch (another leading-zero count) are solved one by one."""
    from podbench.deconvolution import ConvolutionSystem

    from podbench.sysid.deconvolution.block import BlockSubstitution

    rng = np.random.default_rng(2)
    k, n, dt = 3, 70, 1e-3
    systems = []
    for start in (1, 1, 1, 2):
        Qs = [np.zeros((k, n)) for _ in range(k)]
        decay = 0.7 ** np.arange(n - start)  # a dominant first sample: well conditioned
        for j, Q in enumerate(Qs):
            Q[:, start:] = rng.standard_normal((k, n - start)) * decay
            Q[j, start] += 5.0
        systems.append(ConvolutionSystem(Qs, rng.standard_normal((k * n, k)), dt))
    solver = BlockSubstitution(leaf=8)
    for group in (systems[:3], systems):
        many = solver.solve_many(group)
        for s, res in zip(group, many, strict=True):
            one = solver.solve(s)
            np.testing.assert_allclose(res.X, one.X, rtol=1e-9,
                                       atol=1e-9 * np.max(np.abs(one.X)))
            assert res.info["shift"] == one.info["shift"]
            assert res.info["growth"] == pytest.approx(one.info["growth"], rel=1e-9)


def test_projection_share_is_the_error_at_t0_and_enters_the_estimate():
    """A free-response target's share outside the basis, ρ = ‖(I − UUᵀ)w̃0‖/‖w̃0‖, is the
    prediction's relative error at t = 0 (MDS: Φ(0) = I, so Ŵ(:, 0) = UUᵀw̃0), computed
    from the target's w0 alone; the error estimate is at least ρ."""
    case = free_case("coupled", "displacement")
    recs = [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
    target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    model = MDS(excitation="displacement", n_modes=3).fit(recs)
    rho = model.projection_share(target)
    W_hat = model.predict(target)
    at_t0 = np.linalg.norm(W_hat[:, 0] - case.x0_new) / np.linalg.norm(case.x0_new)
    assert rho == pytest.approx(at_t0, rel=1e-10) and rho > 1e-3
    p = model.predict(target, coverage=0.9)
    assert p.error_estimate >= rho
    realized = np.linalg.norm(W_hat - case.W_new) / np.linalg.norm(case.W_new)
    assert 0.5 <= p.error_estimate / realized <= 2.0, (p.error_estimate, realized)
    assert MDS(excitation="velocity").fit(
        [Record(W=W, v0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
    ).projection_share(Record(W=case.W_new, v0=case.x0_new, dt=case.dt)) is None


def test_folds_leverage_factor_by_hand(monkeypatch):
    """The ``"folds-leverage"`` factor ``max((Λ² + 1)/L_ref, 1)^p``: a target whose leverage
    exceeds every fold's is charged ``((Λ² + 1)/L_ref)^p`` on its error inside the basis,
    one inside the folds' range is not, and the share outside the basis adds in quadrature."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    monkeypatch.setattr(bands, "LEVERAGE_POWER", 0.5)
    s, b = 0.02, 3.0
    inside = TargetTerms(4.0, 3.0, None)          # Λ² + 1 = 5 below L_ref = 10
    beyond = TargetTerms(39.0, 3.0, 0.01)         # Λ² + 1 = 40: 4× L_ref
    assert bands.folds_estimate(s, b, inside, 1.0, 10.0) == pytest.approx(s)
    assert bands.folds_estimate(s, b, inside, 1.0, None) == pytest.approx(s)
    assert bands.folds_estimate(s, b, beyond, 1.0, 10.0) == pytest.approx(
        math.sqrt((s * 2.0) ** 2 + 0.01 ** 2))


def test_folds_gains_rule_by_hand(monkeypatch):
    """``"folds-gains"``: folds whose errors follow ``0.01 sqrt(Λ² + 1)`` exactly (the gains
    fit them: κ_Λ² = 1e-4, κ_Δ² = 0). A target inside the folds' leverage range gets the
    folds' median (no blind spot: the ratio is 1), one beyond it the gains' estimate
    ``0.01 sqrt(Λ² + 1)``, or with the growth option the median times the gains' growth from
    the range's edge, ``sqrt((Λ² + 1)/max_j(Λ_j² + 1))``. The fold of the largest leverage
    is beyond the others' and gets the gains' estimate itself (its own error)."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    monkeypatch.setattr(bands, "ESTIMATE_RULE", "folds-gains")
    lev2 = np.array([0.0, 3.0, 15.0, 63.0])
    terms = [TargetTerms(float(v), 0.0, None) for v in lev2]
    errors = 0.01 * np.sqrt(lev2 + 1.0)
    cal = bands.BandCalibration("cross-validation", np.zeros(0), 0.0,
                                np.ones(bands.N_TIME_BINS), None, 4, 0)
    bands._rule_constants(cal, errors, terms, np.ones(4))
    assert cal.rule == "folds-gains" and cal.fold_leverage == pytest.approx(64.0)
    assert cal.gains[0] == pytest.approx(1e-4) and cal.gains[1] == 0.0
    assert cal.fold_estimates[3] == pytest.approx(errors[3])
    assert cal.fold_estimates[0] == pytest.approx(float(np.median(errors[1:])))
    median = float(np.median(errors))
    assert bands.rule_estimate(cal, TargetTerms(8.0, 0.0, None), 1.0) == pytest.approx(median)
    beyond = TargetTerms(255.0, 0.0, None)
    assert bands.rule_estimate(cal, beyond, 1.0) == pytest.approx(0.16)
    monkeypatch.setattr(bands, "FOLDS_GAINS_GROWTH", True)
    assert bands.rule_estimate(cal, beyond, 1.0) == pytest.approx(median * 2.0)


def test_effective_level_of_a_pooled_fit_by_hand(monkeypatch):
    """The input level's reference (``LEVEL_REFERENCE``): the training levels' mean weighted
    by their input energy, ``Σ a³/Σ a²`` for records of one length (levels 1, 3: 28/10 =
    2.8 N), the excursion both ways; the former rule (``"range"``) is 1 inside the range."""
    from podbench.sysid.methods import bands

    monkeypatch.setattr(bands, "LEVEL_REFERENCE", "effective")
    assert bands.effective_level([1.0, 3.0], [1.0, 9.0]) == pytest.approx(2.8)
    assert bands.input_excursion(1.4, [1.0, 3.0], [1.0, 9.0]) == pytest.approx(2.0)
    assert bands.input_excursion(5.6, [1.0, 3.0], [1.0, 9.0]) == pytest.approx(2.0)
    monkeypatch.setattr(bands, "LEVEL_REFERENCE", "range")
    assert bands.input_excursion(1.4, [1.0, 3.0], [1.0, 9.0]) == 1.0
    assert bands.input_excursion(6.0, [1.0, 3.0], [1.0, 9.0]) == pytest.approx(2.0)


def test_nearest_level_of_a_model_kept_per_level(monkeypatch):
    """A model kept per training level (``levels_``: ML-interp) is compared with the nearest
    training level, both ways: levels 1, 3, 4 N asked at 2 N → 2/1 = 1.5 from 3 is nearer:
    1.5; at 3.5 N: 4/3.5; at 8 N: 2; at 0.5 N: 2. A pooled model keeps LEVEL_REFERENCE."""
    from types import SimpleNamespace

    from podbench.sysid.methods import bands

    monkeypatch.setattr(bands, "LEVEL_REFERENCE", "effective")
    lv, en = [1.0, 3.0, 4.0], [1.0, 9.0, 16.0]
    assert bands.input_excursion(2.0, lv, en, "nearest") == pytest.approx(1.5)
    assert bands.input_excursion(3.5, lv, en, "nearest") == pytest.approx(4.0 / 3.5)
    assert bands.input_excursion(8.0, lv, en, "nearest") == pytest.approx(2.0)
    assert bands.input_excursion(0.5, lv, en, "nearest") == pytest.approx(2.0)
    assert bands.input_excursion(3.0, lv, en, "nearest") == 1.0
    # the effective level (1 + 27 + 64)/26 = 3.538...: 2 N lies 1.77x from it
    assert bands.input_excursion(2.0, lv, en) == pytest.approx(92 / 26 / 2.0)
    assert bands.level_reference(SimpleNamespace(levels_=np.array(lv))) == "nearest"
    assert bands.level_reference(SimpleNamespace()) == "effective"


def test_rule_losses_by_hand():
    """``rule_losses``: each fold estimated without it, the mean squared log ratio. Folds
    whose errors follow ``0.01 sqrt(Λ² + 1)`` exactly are explained by the gains left out
    (loss 0), not by the folds' median (a constant: loss of the log spread about it)."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    lev2 = np.array([0.0, 3.0, 15.0, 63.0])
    terms = [TargetTerms(float(v), 0.0, None) for v in lev2]
    errors = 0.01 * np.sqrt(lev2 + 1.0)
    losses = bands.rule_losses(errors, terms, np.ones(4))
    assert losses["gains"] == pytest.approx(0.0, abs=1e-12)
    own = [float(np.median(np.delete(errors, j))) for j in range(4)]
    assert losses["folds"] == pytest.approx(np.mean((np.log(errors) - np.log(own)) ** 2))


def test_leverage_exponent_chosen_by_the_folds_by_hand(monkeypatch):
    """``GAINS_LEVERAGE_EXPONENTS``: folds whose errors follow ``0.01 (Λ² + 1)^(1/4)``
    exactly (error² ∝ (Λ² + 1)^0.5) choose γ = 0.5 among (1, 0.5) with κ_Λ² = 1e-4 and a
    target at Λ² + 1 = 256 gets 0.01·256^(1/4) = 0.04; with the default (1.0,) the same
    folds give the geometric-mean gain and the target grows as Λ."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.band_target import TargetTerms

    lev2 = np.array([0.0, 3.0, 15.0, 63.0])
    terms = [TargetTerms(float(v), 0.0, None) for v in lev2]
    errors = 0.01 * (lev2 + 1.0) ** 0.25
    target = TargetTerms(255.0, 0.0, None)

    def calibrated():
        cal = bands.BandCalibration("cross-validation", np.zeros(0), 0.0,
                                    np.ones(bands.N_TIME_BINS), None, 4, 0)
        bands._rule_constants(cal, errors, terms, np.ones(4))
        return cal

    monkeypatch.setattr(bands, "GAINS_LEVERAGE_EXPONENTS", (1.0, 0.5))
    cal = calibrated()
    assert cal.leverage_exponent == 0.5
    assert cal.gains[0] == pytest.approx(1e-4, rel=1e-12) and cal.gains[1] == 0.0
    np.testing.assert_allclose(cal.fold_estimates, errors, rtol=1e-12)
    assert bands.rule_estimate(cal, target, 1.0) == pytest.approx(0.04, rel=1e-12)
    monkeypatch.setattr(bands, "GAINS_LEVERAGE_EXPONENTS", (1.0,))
    cal = calibrated()
    kappa = float(np.exp(np.mean(np.log(errors ** 2 / (lev2 + 1.0)))))
    assert cal.leverage_exponent == 1.0
    assert cal.gains[0] == pytest.approx(kappa, rel=1e-12)
    assert bands.rule_estimate(cal, target, 1.0) == pytest.approx(math.sqrt(kappa * 256.0),
                                                                  rel=1e-12)


@pytest.mark.heavy
def test_peers_folds_refit_in_one_mode_fewer_with_as_many_records_as_modes():
    """ERA on modal forces with k = N: a fold's N − 1 records excite N − 1 input
    directions, so the fold is refitted in the first N − 1 modes (as ML's), and its
    residual is its error inside them plus the whole basis's projection error."""
    from podbench.sysid.methods import bands
    from podbench.sysid.methods.peers import ERA

    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    era = ERA(n_modes=len(recs)).fit(recs)
    assert bands.folds_per_mode(era)
    era.predict(Record(W=case.W_new, F=case.F_new, dt=case.dt), coverage=0.9)
    assert era.band_calibration_.cv_modes == len(recs) - 1


def test_grouped_folds_are_refits_on_the_other_groups(monkeypatch):
    """The variant ``MAX_FOLDS = F``: record j is left out in fold j mod F, predicted by a
    fit on the other folds' records, and its terms are taken against those records (an
    independent computation: a fit on those records and the target terms against them)."""
    from podbench.sysid.methods import band_target, bands

    monkeypatch.setattr(bands, "MAX_FOLDS", 2)
    assert bands.fold_groups(5) == [[0, 2, 4], [1, 3]]
    assert bands.fold_groups(2) == [[0], [1]]  # no more records than folds
    assert bands.fold_groups(5, lo=3) == [[j] for j in range(5)]  # 2 left: too few to fit
    # every fold fits on N − ⌈N/F⌉ records: the smaller fold leaves one more out
    assert bands.fold_of([[0, 2, 4], [1, 3]]) == [[1, 3], [0, 2], [1, 3], [0, 2], [1, 3]]
    case = free_case("coupled", "displacement")
    recs = [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
    model = MDS(excitation="displacement", n_modes=2).fit(recs)
    U = np.asarray(model.modes_)
    cal = model.calibrate_band()
    assert cal.source == "cross-validation" and cal.n_folds == 2 and cal.cv_modes is None
    for group, fitted in (([0, 2, 4], [1, 3]), ([1, 3], [0, 2])):
        rest = [recs[i] for i in fitted]
        fit = MDS(excitation="displacement", n_modes=2).fit(rest, basis=U)
        ex = band_target.excitations(fit, rest, U)
        for j in group:
            W = recs[j].W
            err = np.linalg.norm(W - fit.predict(recs[j])) / np.linalg.norm(W)
            assert cal.fold_errors[j] == pytest.approx(err, rel=1e-9)
            t = band_target.target_terms(fit, ex, recs[j], U)
            assert cal.fold_terms[j].leverage2 == pytest.approx(t.leverage2, rel=1e-9)
            assert cal.fold_terms[j].rho == pytest.approx(t.rho, rel=1e-12)
