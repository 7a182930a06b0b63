"""The target terms of the error estimate (podbench.sysid.methods.band_target) against
independent computations: a linear method's prediction is the combination of its training
responses that the terms are built from, the leverage and blind spot by hand, and a
method fitted on one design without a model-form term says it cannot estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest
from podbench.methods import MDS, MultipleLoad

from podbench import Record
from podbench.sysid.methods import band_target

from ._cases import forced_case, free_case
from ._truth import coupled_chain, newmark


def _free_records():
    case = free_case("coupled", "displacement")
    recs = [Record(W=W, w0=x, dt=case.dt) for W, x in zip(case.W, case.x0, strict=True)]
    return case, recs


def test_mds_terms_by_hand():
    """MDS with k = m = 5 (exact): c = (UᵀX0)⁻¹ Uᵀw̃0; Λ² = Σ c_l²‖UᵀW_l‖²/‖Σ c_l UᵀW_l‖²
    and the prediction is U Σ c_l UᵀW_l; nothing is outside the basis (Δ = ρ = 0)."""
    case, recs = _free_records()
    model = MDS().fit(recs)
    U = model.modes_
    target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    ex = band_target.excitations(model, recs, U)
    t = band_target.target_terms(model, ex, target, U)
    X0 = np.column_stack(case.x0)
    c = np.linalg.solve(U.T @ X0, U.T @ case.x0_new)
    V = [U.T @ W for W in case.W]
    combo = sum(cl * Vl for cl, Vl in zip(c, V, strict=True))
    np.testing.assert_allclose(U @ combo, model.predict(target), rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(case.W_new)))
    lev2 = sum(cl ** 2 * np.sum(Vl ** 2) for cl, Vl in zip(c, V, strict=True)) \
        / np.sum(combo ** 2)
    assert t.leverage2 == np.float64(lev2) or math.isclose(t.leverage2, lev2, rel_tol=1e-9)
    assert t.blind2 < 1e-20 and t.rho < 1e-12
    # a target equal to a training record is that record: leverage 1, no blind spot
    own = band_target.target_terms(model, ex, recs[2], U)
    assert math.isclose(own.leverage2, 1.0, rel_tol=1e-9)


def test_mds_blind_spot_and_projection_share_in_fewer_modes():
    """k = 3 of 5: ρ = ‖(I − UUᵀ)w̃0‖/‖w̃0‖ and Δ² = ‖w̃0 − Σ c_l w0_l‖²/‖Uᵀw̃0‖² with the
    least-squares c over the five records (by hand)."""
    case, recs = _free_records()
    model = MDS(n_modes=3).fit(recs)
    U = model.modes_
    target = Record(W=case.W_new, w0=case.x0_new, dt=case.dt)
    t = band_target.target_terms(model, band_target.excitations(model, recs, U), target, U)
    x = case.x0_new
    assert math.isclose(t.rho, np.linalg.norm(x - U @ (U.T @ x)) / np.linalg.norm(x),
                        rel_tol=1e-9)
    X0 = np.column_stack(case.x0)
    c = np.linalg.pinv(U.T @ X0) @ (U.T @ x)
    blind2 = np.sum((x - X0 @ c) ** 2) / np.sum((U.T @ x) ** 2)
    assert math.isclose(t.blind2, blind2, rel_tol=1e-8)
    assert t.blind2 > 0


def test_ml_leverage_of_a_combination_of_training_loads():
    """ML (k = N = m, exact chain): a target load 2·F₁ − F₃ is expressed through the
    training loads with c = (2, 0, −1, 0, 0) at every frequency, so its leverage is
    (4‖V₁‖² + ‖V₃‖²)/‖2V₁ − V₃‖² over the frequency bins and its blind spot 0; a
    training load's own is 1. (For any other load the frequency-domain combination is the
    ML prediction only approximately: the records are finite, ML's convolution is
    truncated at their length.)"""
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(solver="block").fit(recs)
    U = model.modes_
    ex = band_target.excitations(model, recs, U)
    target = Record(W=2 * case.W[1] - case.W[3], F=2 * case.F[1] - case.F[3], dt=case.dt)
    t = band_target.target_terms(model, ex, target, U)
    V1, V3 = (np.fft.rfft(U.T @ case.W[i], n=ex.nfft, axis=1) for i in (1, 3))
    power = lambda X: float(np.sum(np.abs(X) ** 2))  # noqa: E731
    lev2 = (4 * power(V1) + power(V3)) / power(2 * V1 - V3)
    assert math.isclose(t.leverage2, lev2, rel_tol=1e-6)
    assert t.blind2 < 1e-12 and t.rho is None
    own = band_target.target_terms(model, ex, recs[4], U)
    assert math.isclose(own.leverage2, 1.0, rel_tol=1e-6)


def test_a_method_without_a_model_form_term_gives_no_estimate():
    """MR takes exactly three records: none can be left out; its band has no model-form
    part, so error_estimate is NaN and the note says why."""
    from podbench.methods import MixedResponse

    from ._cases import mixed_case

    case = mixed_case("coupled")
    recs = [Record(W=W, w0=a, v0=b, F=F, dt=case.dt)
            for W, a, b, F in zip(case.W, case.w0, case.v0, case.F, strict=True)]
    model = MixedResponse(n_modes=3, solver="block").fit(recs)
    p = model.predict(Record(W=case.W_w0, w0=case.w0_new, v0=np.zeros_like(case.w0_new),
                             F=np.zeros_like(case.W_w0), dt=case.dt), coverage=0.9)
    assert math.isnan(p.error_estimate)
    assert "no error estimate" in p.note and "left out" in p.note


def test_one_row_coefficients_match_the_svd_and_lstsq():
    """One excitation row per bin (one input): the closed form E_bᴴ e_b/‖E_b‖² gives the
    numbers of the batched SVD and of a per-bin minimum-norm least squares, bins below
    RCOND × the largest norm dropped (zero) in all three."""
    rng = np.random.default_rng(7)
    B, N = 40, 4
    E = rng.standard_normal((B, 1, N)) + 1j * rng.standard_normal((B, 1, N))
    E[5] *= 1e-9  # below RCOND × the largest: dropped
    E[9] = 0.0
    e = rng.standard_normal((B, 1)) + 1j * rng.standard_normal((B, 1))
    closed = band_target._coefficients(E, e)
    svd = band_target._coefficients_svd(E, e)
    np.testing.assert_allclose(closed, svd, rtol=1e-12, atol=1e-14)
    top = max(np.linalg.norm(E[b]) for b in range(B))
    for b in range(B):
        if np.linalg.norm(E[b]) > band_target.RCOND * top:
            ref = np.linalg.lstsq(E[b], e[b], rcond=None)[0]
        else:
            ref = np.zeros(N)
        np.testing.assert_allclose(closed[b], ref, rtol=1e-12, atol=1e-14)
    assert np.all(closed[5] == 0) and np.all(closed[9] == 0)
    # the target's own row gives c with E_b c = e_b exactly wherever kept
    kept = [b for b in range(B) if b not in (5, 9)]
    np.testing.assert_allclose(np.einsum("bn,bn->b", E[kept, 0], closed[kept]),
                               e[kept, 0], rtol=1e-12)
    # real rows (a free response in one mode) stay real
    Er, er = E.real.copy(), e.real.copy()
    cr = band_target._coefficients(Er, er)
    assert cr.dtype == np.float64
    np.testing.assert_allclose(cr, band_target._coefficients_svd(Er, er), rtol=1e-12,
                               atol=1e-14)


def _svd_route(monkeypatch):
    monkeypatch.setattr(band_target, "_coefficients_qr", lambda E, e: None)


@pytest.mark.parametrize("p, N, dtype", [(3, 5, complex), (5, 3, complex), (4, 4, float)])
def test_qr_coefficients_match_the_svd_and_lstsq(p, N, dtype):
    """Several excitation rows per bin (wide, tall, square): the QR route gives the batched
    SVD's minimum-norm c and a per-bin least squares to round-off, bins below RCOND × the
    largest (by norm) exactly zero in both; a bin of lower rank than min(p, N) is left to
    the SVD (the QR route declines, the result is the SVD's exactly)."""
    rng = np.random.default_rng(11)
    B = 60

    def draw(*shape):
        x = rng.standard_normal(shape)
        return x + 1j * rng.standard_normal(shape) if dtype is complex else x

    E, e = draw(B, p, N), draw(B, p)
    E[7] *= 1e-9  # far below the cut: c = 0
    E[8] = 0.0
    r = min(p, N)  # a bin of condition number 1e3
    E[20] = (np.linalg.qr(draw(p, r))[0] * 10.0 ** -np.arange(r)) @ \
        np.conj(np.linalg.qr(draw(N, r))[0].T) * np.linalg.norm(E[3])
    qr = band_target._coefficients_qr(E, e)
    svd = band_target._coefficients_svd(E, e)
    assert qr is not None and qr.dtype == svd.dtype
    np.testing.assert_allclose(qr, svd, rtol=1e-12, atol=1e-12 * np.max(np.abs(svd)))
    assert np.all(qr[7] == 0) and np.all(qr[8] == 0)
    for b in (0, 20, 41):
        ref = np.linalg.lstsq(E[b], e[b], rcond=None)[0]
        np.testing.assert_allclose(qr[b], ref, rtol=1e-10)
    low = E.copy()
    if p <= N:  # a repeated row (wide) or column (tall): rank min(p, N) − 1
        low[30, -1] = low[30, 0]
    else:
        low[30, :, -1] = low[30, :, 0]
    assert band_target._coefficients_qr(low, e) is None
    np.testing.assert_array_equal(band_target._coefficients(low, e),
                                  band_target._coefficients_svd(low, e))


def test_the_terms_of_the_qr_route_are_the_svds(monkeypatch):
    """ML in two modes on five pulse records: every fold's and a target's leverage and
    blind spot through the QR coefficients equal the SVD route's to 1e-12."""
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]
    model = MultipleLoad(n_modes=2, solver="cgls").fit(recs)
    U = model.modes_
    ex = band_target.excitations(model, recs, U)
    assert band_target._coefficients_qr(ex.E, ex.E[..., 0]) is not None  # the QR route
    monkeypatch.setattr(band_target, "COEFFICIENT_ROUTE", "qr")
    target = Record(W=case.W_new, F=case.F_new, dt=case.dt)
    fast = band_target.fold_terms(model, recs, U) + [band_target.target_terms(model, ex,
                                                                              target, U)]
    _svd_route(monkeypatch)
    slow = band_target.fold_terms(model, recs, U) + [band_target.target_terms(model, ex,
                                                                              target, U)]
    for a, b in zip(fast, slow, strict=True):
        assert math.isclose(a.leverage2, b.leverage2, rel_tol=1e-12)
        assert math.isclose(a.blind2, b.blind2, rel_tol=1e-12, abs_tol=1e-15)


def _measured_forces_case(seed: int = 4, n: int = 60, n_records: int = 5):
    """A 3-DOF coupled chain (every DOF a sensor and loaded) with random forces measured at
    all three DOFs: five training records with 5 % per-channel noise on the responses (more
    records than inputs: every frequency bin's 3 × 4 excitation matrix of a fold has exactly
    dependent columns) and a clean target."""
    M, C, K = coupled_chain(3)
    rng = np.random.default_rng(seed)

    def record(sigma):
        F = 100.0 * rng.standard_normal((3, n))
        F[:, 0] = 0.0  # from rest: an exact discrete convolution (_truth)
        W = newmark(M, C, K, 0.002, n, F=F)[0]
        W = W + sigma * np.std(W, axis=1, keepdims=True) * rng.standard_normal(W.shape)
        return Record(W=W, F=F, dt=0.002)

    return [record(0.05) for _ in range(n_records)], record(0.0)


def test_a_round_off_blind_spot_does_not_move_the_estimate(monkeypatch):
    """ML in all three modes of a 3-DOF chain loaded at every DOF: the basis is the whole
    sensor space and the combination that matches a target's modal force matches its force,
    so the blind spot Δ² is 0 up to the round-off of the coefficient solve (about 1e-30).
    The estimate must not depend on that round-off: the SVD and QR coefficient routes (equal
    to 1e-12, tests above) give the same estimate to 1e-6 and a blind spot of exactly 0.
    Without a floor the gains fitted κ_Δ² to the round-off and the two routes' estimates
    differed by a factor of 1.9 on this case (2.19 and 1.13)."""
    train, target = _measured_forces_case()
    estimates, blind2 = {}, {}
    for route in ("svd", "qr"):
        monkeypatch.setattr(band_target, "COEFFICIENT_ROUTE", route)
        model = MultipleLoad(n_modes=3, solver="ls").fit(train)
        U = model.modes_
        ex = band_target.excitations(model, train, U)
        terms = band_target.fold_terms(model, train, U, ex=ex) + \
            [band_target.target_terms(model, ex, target, U)]
        blind2[route] = [t.blind2 for t in terms]
        estimates[route] = model.predict(target, coverage=0.9).error_estimate
    assert math.isfinite(estimates["svd"]) and estimates["svd"] > 0
    assert math.isclose(estimates["qr"], estimates["svd"], rel_tol=1e-6)
    assert blind2["svd"] == blind2["qr"] == [0.0] * 6


def _unfloored(ex, j, N):
    """Fold ``j``'s blind spot computed without the floor, and the floor."""
    keep = [i for i in range(N) if i != j]
    E, X, e, x = ex.E[..., keep], ex.X[..., keep], ex.E[..., j], ex.X[..., j]
    c = band_target._coefficients(E, e)
    inside = float(np.sum(np.abs(e) ** 2))
    left = x - (X @ c[..., None])[..., 0]
    return (float(np.sum(np.abs(left) ** 2)) / inside,
            band_target.roundoff_floor(E.shape[1], X, c, x, inside, ex.nfft))


@pytest.mark.parametrize("route", ["svd", "qr"])
def test_the_round_off_floor_bounds_the_round_off_and_not_a_blind_spot(monkeypatch, route):
    """The floor (τε)² Σ_b (‖X_b‖‖c_b‖ + ‖x_b‖)²/Σ_b ‖e_b‖² lies above the round-off of the
    blind spot it floors (ML in all 3 modes of the 3-DOF chain: the exact Δ² is 0; the
    computed one, measured 0.0005–0.05 × the floor over eight designs, at most a tenth of
    it here) and far below a blind spot that exists (the same records in 2 modes: the third
    mode's share of the load, measured 4e27 × the floor): it zeroes only what the solve
    cannot resolve."""
    monkeypatch.setattr(band_target, "COEFFICIENT_ROUTE", route)
    train, _ = _measured_forces_case()
    for k, lo, hi in ((3, 0.0, 0.1), (2, 1e20, math.inf)):
        model = MultipleLoad(n_modes=k, solver="ls").fit(train)
        ex = band_target.excitations(model, train, model.modes_)
        for j in range(len(train)):
            blind2, floor = _unfloored(ex, j, len(train))
            assert floor > 0 and lo * floor <= blind2 <= hi * floor
        terms = band_target.fold_terms(model, train, model.modes_, ex=ex)
        assert all((t.blind2 == 0.0) == (k == 3) for t in terms)


def test_gains_without_a_blind_spot_rest_on_the_leverage():
    """Every fold's Δ² = 0 (the floor above): κ_Δ² = 0 and κ_Λ² is the geometric mean of
    e_j²/(Λ_j² + 1) over the folds (the log-space fit with one gain), by hand."""
    from podbench.sysid.methods import bands

    errors = [0.1, 0.4, 0.2]
    terms = [band_target.TargetTerms(lev, 0.0) for lev in (0.5, 3.0, 1.0)]
    a, b = bands.fit_gains(errors, terms, [1.0, 1.0, 1.0])
    expected = math.exp(np.mean(np.log([0.01 / 1.5, 0.16 / 4.0, 0.04 / 2.0])))
    assert b == 0.0 and math.isclose(a, expected, rel_tol=1e-12)
    assert math.isclose(bands.estimate((a, b), band_target.TargetTerms(8.0, 0.0)),
                        math.sqrt(expected * 9.0), rel_tol=1e-12)
