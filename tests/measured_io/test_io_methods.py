"""ML, FIR-LS, SL/MR refusals and the peers on input/output records."""

import numpy as np
import pytest

from podbench.core.records import Record, convert
from podbench.errors import InputError
from podbench.sysid.deconvolution.lagged import lag_response, record_grams
from podbench.sysid.methods import ERA, FIRLeastSquares, MixedResponse, MultipleLoad, SingleLoad


def measured_ml(**kw):
    """ML on measured inputs with the lag rule (the former ``MultipleLoadIO``'s defaults)."""
    return MultipleLoad(**{"inputs": "measured", "n_lags": "auto", "solver": "ls", **kw})


def _lti(n_in=2, n_out=3, order=6, seed=1, radius=0.97):
    """A stable discrete system with direct feedthrough (D ≠ 0)."""
    rng = np.random.default_rng(seed)
    poles = radius * np.exp(1j * rng.uniform(0.2, 1.2, order // 2))
    A = np.zeros((order, order))
    for i, p in enumerate(poles):
        A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = [[p.real, -p.imag], [p.imag, p.real]]
    return A, rng.normal(size=(order, n_in)), rng.normal(size=(n_out, order)), \
        rng.normal(size=(n_out, n_in))


def _respond(sys, u):
    A, B, C, D = sys
    x = np.zeros(A.shape[0])
    y = np.empty((C.shape[0], u.shape[1]))
    for j in range(u.shape[1]):
        y[:, j] = C @ x + D @ u[:, j]
        x = A @ x + B @ u[:, j]
    return y


def _records(sys, lengths, seed=2, units="m/s^2"):
    rng = np.random.default_rng(seed)
    out = []
    for j, n in enumerate(lengths):
        u = rng.normal(size=(sys[1].shape[1], n))
        out.append(Record(u=u, y=_respond(sys, u), dt=0.01, input_units=units,
                            output_units=units, name=f"r{j}.npz"))
    return out


@pytest.mark.parametrize("first", [0, 1])
@pytest.mark.parametrize("L", [17, 80, 230])  # lag by lag; by FFT; lags beyond the record
def test_grams_equal_the_explicit_lagged_design(first, L):
    rng = np.random.default_rng(0)
    u, z = rng.normal(size=(3, 200)), rng.normal(size=(2, 200))
    X = np.zeros((200, 3 * L))
    for k in range(L):
        lag = first + k
        if lag < 200:
            X[lag:, 3 * k : 3 * k + 3] = u[:, : 200 - lag].T
    A, B, c = record_grams(u, z, L, first)
    np.testing.assert_allclose(A, X.T @ X, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(B, X.T @ z.T, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(c, np.sum(z**2, axis=1), rtol=1e-14)
    th = rng.normal(size=(3 * L, 2))
    np.testing.assert_allclose(lag_response(th, u, 3, first), (X @ th).T, atol=1e-12)


@pytest.mark.parametrize("n_in", [1, 3])
def test_tc_whitening_equals_the_dense_factor(n_in):
    """The prior's coordinates by cumulative sums equal ``RᵀAR`` and ``RᵀB`` with the dense
    factor ``R`` (``R Rᵀ = P``, the TC prior's kernel)."""
    from podbench.sysid.deconvolution.lagged import tc_prior
    from podbench.sysid.methods.inputs import _tc_factor, _tc_weights, _whiten
    rng = np.random.default_rng(1)
    L, dt, tau = 12, 0.01, 0.05
    X = rng.normal(size=(300, L * n_in))
    A, B = X.T @ X, rng.normal(size=(L * n_in, 2))
    R = _tc_factor(L, n_in, dt, tau)
    np.testing.assert_allclose(R @ R.T, tc_prior(L, n_in, np.exp(-dt / tau)), atol=1e-14)
    M, RB, _ = _whiten([(A, B, np.ones(2))], _tc_weights(L, dt, tau), n_in)[0]
    np.testing.assert_allclose(M, R.T @ A @ R, rtol=1e-12, atol=1e-12 * np.abs(M).max())
    np.testing.assert_allclose(RB, R.T @ B, rtol=1e-12, atol=1e-12 * np.abs(RB).max())


@pytest.mark.heavy
def test_ml_predicts_a_held_out_lti_response_with_feedthrough():
    """Records of different lengths; the true kernel is C A^(p−1) B, D at lag 0: with
    enough lags (the tail below 1e-12) ML reproduces a held-out response to round-off."""
    sys = _lti(radius=0.9)  # 0.9^350 < 1e-15: 350 lags hold the whole kernel
    tr = _records(sys, [900, 1200, 700])
    target = _records(sys, [1500], seed=9)[0]
    ml = measured_ml(n_lags=350).fit(tr)
    assert ml.first_lag_ == 0
    err = np.linalg.norm(ml.predict(target) - target.y) / np.linalg.norm(target.y)
    assert err < 1e-9
    # the identified lag-0 kernel is D (through the POD basis), × 1/Δt (Eq. 3.39's Δt)
    np.testing.assert_allclose(ml.modes_ @ ml.kernel_[:, :, 0] * 0.01, sys[3], atol=1e-9)


def test_ml_full_length_kernel_by_block_deconvolution():
    """n_lags=None: the dissertation's kernel over the whole record, one record per input
    (square block system), solved exactly by 'block'."""
    sys = _lti(n_in=1, n_out=3)
    pulse = 0.6 ** np.arange(400)[None, :]  # minimum phase: the substitution is stable
    tr = [Record(u=pulse, y=_respond(sys, pulse), dt=0.01, input_units="m/s^2",
                   output_units="m/s^2", name="pulse.npz")]
    target = _records(sys, [400], seed=5)[0]
    ml = measured_ml(n_lags=None, solver="block").fit(tr)
    err = np.linalg.norm(ml.predict(target) - target.y) / np.linalg.norm(target.y)
    assert err < 1e-10


def test_ml_with_as_many_modes_as_outputs_is_the_fir_baseline():
    sys = _lti()
    rng = np.random.default_rng(3)
    tr = _records(sys, [300, 350, 420])
    tr = [Record(u=r.u, y=r.y + 0.3 * rng.normal(size=r.y.shape), dt=r.dt,
                   input_units="m/s^2", output_units="m/s^2", name=r.name) for r in tr]
    target = _records(sys, [500], seed=4)[0]
    a = measured_ml(n_lags=25).fit(tr).predict(target)
    b = FIRLeastSquares(n_lags=25).fit(tr).predict(target)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())
    # the lag rule: the same choice for both, by leave-one-record-out on training records
    fa = measured_ml(lag_grid=(0.05, 0.25, 0.5)).fit(tr)
    fb = FIRLeastSquares(lag_grid=(0.05, 0.25, 0.5)).fit(tr)
    assert fa.info_["n_lags"] == fb.info_["n_lags"]


def test_tc_prior_helps_on_noisy_short_records_and_chooses_on_training_only():
    sys = _lti(seed=4)
    rng = np.random.default_rng(6)
    tr = _records(sys, [250, 300, 280, 260], seed=7)
    tr = [Record(u=r.u, y=r.y + 0.5 * np.std(r.y) * rng.normal(size=r.y.shape), dt=r.dt,
                   input_units="m/s^2", output_units="m/s^2", name=r.name) for r in tr]
    target = _records(sys, [400], seed=8)[0]
    from podbench.core.threads import single_blas_thread

    with single_blas_thread():
        ls = measured_ml(n_lags=100).fit(tr)
        tc = measured_ml(n_lags=100, prior="tc").fit(tr)
    e = [np.linalg.norm(m.predict(target) - target.y) / np.linalg.norm(target.y)
         for m in (ls, tc)]
    assert e[1] < 0.9 * e[0]
    assert ("tc", tc.info_["tc_tau"], tc.info_["tc_gamma"]) in tc.cv_errors_


@pytest.mark.heavy
def test_si_and_inch_lbf_give_the_same_prediction_converted():
    sys = _lti()
    tr = _records(sys, [300, 340, 360])
    target = _records(sys, [400], seed=3)[0]
    si = measured_ml(n_lags=60, prior="tc").fit(tr).predict(target)
    ip = measured_ml(n_lags=60, prior="tc").fit([convert(r, "inch-lbf") for r in tr]) \
        .predict(convert(target, "inch-lbf"))
    np.testing.assert_allclose(ip * 0.0254, si, rtol=1e-9, atol=1e-12 * np.abs(si).max())


def test_strain_or_displacement_outputs_start_at_lag_one():
    sys = _lti()
    r = _records(sys, [200, 220])
    r = [Record(u=x.u, y=x.y, dt=x.dt, input_units="m/s^2", output_units="strain",
                  name=x.name) for x in r]
    assert measured_ml(n_lags=10).fit(r).first_lag_ == 1


def test_sl_and_mr_are_refused_with_the_reason():
    sys = _lti()
    tr = _records(sys, [200, 220])
    with pytest.raises(InputError, match="not forces at the output channels"):
        SingleLoad(n_lags=10).fit(tr)
    with pytest.raises(InputError, match="MR: r0.npz: .*free responses .*no initial condition"):
        MixedResponse().fit(tr)


def test_a_training_record_too_short_is_named():
    sys = _lti()
    tr = _records(sys, [200, 40])
    with pytest.raises(InputError, match="r1.npz: field `inputs`: 40 samples"):
        measured_ml(n_lags=50).fit(tr)


@pytest.mark.heavy
def test_the_peers_take_the_same_records():

    sys = _lti(n_in=3, n_out=3, order=6)
    tr = _records(sys, [600, 600, 600])  # one length: no zero padding
    target = _records(sys, [600], seed=11)[0]
    era = ERA(inputs="measured", max_order=10, blocks=0.3).fit(tr)
    err = np.linalg.norm(era.predict(target) - target.y) / np.linalg.norm(target.y)
    assert era.info_["order"] == 6 and err < 1e-6


def _ringing_records(zeta: float, n_rec: int = 4, n: int = 3000, dt: float = 0.01):
    """A single mode at 2 Hz with damping ratio ``zeta`` (decay time 1/(ζω)), driven by white
    noise: exact discrete recursion, outputs the displacement."""
    from podbench.core.records import Record

    w = 2 * np.pi * 2.0
    r, th = np.exp(-zeta * w * dt), w * np.sqrt(1 - zeta**2) * dt
    a1, a2 = 2 * r * np.cos(th), -r * r
    rng = np.random.default_rng(7)
    recs = []
    for j in range(n_rec):
        u = rng.normal(size=n)
        y = np.zeros(n)
        for s in range(2, n):
            y[s] = a1 * y[s - 1] + a2 * y[s - 2] + dt * u[s - 1]
        recs.append(Record(u=u[None, :], y=y[None, :], dt=dt, input_units="lbf",
                           output_units="in", name=f"r{j}.npz"))
    return recs


def test_auto_lags_lengthen_past_the_grid_while_the_held_out_error_falls():
    from podbench.sysid.methods import MultipleLoad
    from podbench.sysid.methods.inputs import LAG_GAIN, LAG_GROWTH

    # ζ = 5 % at 2 Hz: decay time 1/(ζω) = 1.6 s, far beyond the grid's 0.4 s (40 lags)
    est = MultipleLoad(inputs="measured", n_lags="auto", solver="ls", lag_grid=(0.2, 0.4))
    est.fit(_ringing_records(0.05))
    L = est.info_["n_lags"]
    cv = {k[1]: v for k, v in est.cv_errors_.items() if k[0] == "lags"}
    steps = [40]
    while steps[-1] < L:
        steps.append(int(np.ceil(LAG_GROWTH * steps[-1])))
    assert L > 40 and steps[-1] == L  # lengthened by the stated factor
    for a, b in zip(steps, steps[1:], strict=False):
        assert cv[a] - cv[b] >= LAG_GAIN * cv[40]  # each step kept brought the stated fall
    assert cv[L] < 0.1 * cv[40]  # the long memory is what the grid missed
    # ζ = 30 % (decay 0.27 s): a grid reaching 2 s (7 decay times) holds the memory
    short = MultipleLoad(inputs="measured", n_lags="auto", solver="ls", lag_grid=(1.0, 2.0))
    assert short.fit(_ringing_records(0.3)).info_["n_lags"] in (100, 200)


@pytest.mark.heavy
def test_pole_basis_holds_a_memory_longer_than_its_pilot():
    from podbench.sysid.realize import to_statespace

    # ζ = 5 % at 2 Hz: decay time 1/(ζω) = 1.6 s; the pilot FIR kernel has 1 s of lags
    recs = _ringing_records(0.05, n_rec=5)
    train, target = recs[:4], recs[4]
    w, dt = 2 * np.pi * 2.0, 0.01
    true = np.exp(complex(-0.05 * w, w * np.sqrt(1 - 0.05**2)) * dt)
    fir = measured_ml(n_lags=100).fit(train)
    est = measured_ml(n_lags=100, kernel="poles").fit(train)
    assert est.info_["kernel"] == "poles"
    np.testing.assert_array_equal(est.theta_, fir.theta_)  # the pilot is the FIR kernel
    lam = np.linalg.eigvals(est.model_[0])
    assert np.min(np.abs(lam - true)) < 0.1 * (1 - abs(true))  # ζ within 10 %
    rel = {m: np.linalg.norm(m.predict(target) - target.y) / np.linalg.norm(target.y)
           for m in (fir, est)}
    assert rel[est] < 0.1 * rel[fir]
    # it predicts with the state space it realizes as (ŷ = U (C x + D u))
    ss = to_statespace(est)
    np.testing.assert_allclose(ss.respond(target.u), est.predict(target), rtol=1e-9,
                               atol=1e-12 * np.abs(target.y).max())
    assert est.frozen_params() == {"pole_order": est.info_["pole_order"]}


def test_pole_refinement_gradient_is_the_projected_errors_derivative():
    # variable projection: Kaufman's Jᵀr is the exact gradient of ½‖P⊥Z‖² (the dropped
    # term of the Jacobian is orthogonal to the residual), here against central differences
    from podbench.sysid.methods.pole_basis import _at, _gauss_newton

    sys = _lti(n_in=2, n_out=3, order=6)
    recs = _records(sys, [300, 300])
    rng = np.random.default_rng(3)
    us = [r.u for r in recs]
    zs = [r.y + 0.05 * rng.normal(size=r.y.shape) for r in recs]
    lam = np.linalg.eigvals(sys[0])
    lam = lam[lam.imag > 0] * np.exp(0.02j) * 0.99  # off the optimum
    p = np.r_[np.log(-np.log(np.abs(lam))), np.angle(lam)]
    lam_r = np.array([0.3])
    lc, Phi, W, Z, th, G, sc, cost = _at(p, lam_r, us, zs, 0)
    _, g = _gauss_newton(th, G, sc, Phi, W, Z, lc, np.exp(p[:3]), 1, 2)
    zz = float(np.sum(Z * Z))
    for c in range(p.size):
        e = np.zeros_like(p)
        e[c] = 1e-6
        fd = (_at(p + e, lam_r, us, zs, 0)[-1] - _at(p - e, lam_r, us, zs, 0)[-1]) / 2e-6
        np.testing.assert_allclose(-0.5 * zz * fd, g[c], rtol=1e-4, atol=1e-8 * abs(g).max())


def test_pole_refinement_recovers_exact_poles_from_perturbed_ones():
    from podbench.sysid.methods.pole_basis import refine_poles

    sys = _lti(n_in=2, n_out=3, order=6, radius=0.995)  # rings for ~200 samples
    recs = _records(sys, [1500, 1500, 1500])
    true = np.linalg.eigvals(sys[0])
    true = np.sort_complex(true[true.imag > 0])
    start = true * np.exp(0.004j) * 0.998  # 0.4 % in frequency, σ from 0.005 to 0.007
    lam, info = refine_poles(start, recs, np.eye(3), 0)
    np.testing.assert_allclose(np.sort_complex(lam), true, atol=1e-9)
    assert info["refine_error"] < 1e-8 < info["refine_error_start"]


def test_pole_basis_is_refused_where_it_does_not_apply():
    recs = _ringing_records(0.05, n_rec=2, n=400)
    with pytest.raises(InputError, match="`kernel`: needs a truncated kernel"):
        MultipleLoad(inputs="measured", n_lags=None, kernel="poles").fit(recs)
    with pytest.raises(InputError, match="`kernel`: 'poles' chooses its order"):
        measured_ml(n_lags=20, kernel="poles").fit(recs[:1])
