"""The peers (ERA/OKID, DMDc, OpInf) against exact LTI truth and python-control."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import numpy as np
import pytest

from podbench import Record, load_structure, simulate
from podbench.dynamics.excitations import excitation_from_dict
from podbench.errors import InputError
from podbench.sysid.methods import BUILTIN_METHODS, MultipleLoad
from podbench.sysid.methods.peers import ERA, DMDc, OpInf
from podbench.sysid.methods.peers.era import okid_markov

from ._cases import D, forced_case
from ._contract import MethodContract
from ._truth import rel_err

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _records(k=None):
    fc = forced_case("coupled")
    k = len(fc.W) if k is None else k
    recs = [Record(W=fc.W[j], F=fc.F[j], dt=fc.dt) for j in range(k)]
    return fc, recs, Record(W=fc.W_new, F=fc.F_new, dt=fc.dt)


def _peer_case(params, bad_param):
    fc, recs, target = _records(3)
    return SimpleNamespace(
        params=params,
        fit=lambda model, basis=None: model.fit(recs, basis=basis),
        predict_train=lambda model: [(model.predict(r), r.W) for r in recs],
        predict_new=lambda model: model.predict(target),
        bad_param=bad_param,
        records=recs,
        target=target,
    )


class _PeerContract(MethodContract):
    def test_reproduces_training_to_projection_error(self):
        """Peers are not exact below k = m (a model order, not a full kernel): instead, the
        prediction lies in span(U), and with k = m every training record is reproduced."""
        c, model, _ = self.fitted()
        U = model.modes_
        for W_pred, _ in c.predict_train(model):
            np.testing.assert_allclose(W_pred, U @ (U.T @ W_pred), atol=1e-12)
        _, recs, _ = _records()
        full = self.method(**{**c.params, **self.full_params}).fit(recs)
        for r in recs:
            assert rel_err(full.predict(r), r.W) < 1e-8

    def test_record_form_equals_array_form(self):  # the peers have only the record form
        import pickle

        c, model, _ = self.fitted()
        again = pickle.loads(pickle.dumps(model))
        np.testing.assert_array_equal(again.predict(c.target), model.predict(c.target))

    def test_diagnostics_name_the_rule_choice(self):
        c, model, _ = self.fitted()
        diag = model.diagnostics_
        assert diag["n_modes"] == 3
        assert set(diag) >= {self.choice, "fit_residual", "spectral_radius"}

    def test_builtin_name(self):
        assert BUILTIN_METHODS[self.method.abbreviation] is self.method


class TestERAContract(_PeerContract):
    method = ERA
    full_params = dict(n_modes=D, order=2 * D)
    choice = "order"

    def case(self):
        return _peer_case(dict(n_modes=3, order=6), ("holdout", 0.9))


class TestDMDcContract(_PeerContract):
    method = DMDc
    full_params = dict(n_modes=D, svd_rank=2 * D)
    choice = "rank"

    def case(self):
        pytest.importorskip("pydmd")
        return _peer_case(dict(n_modes=3, svd_rank=6), ("delays", 0))


class TestOpInfContract(_PeerContract):
    method = OpInf
    full_params = dict(n_modes=D, regularizer=0.0)
    choice = "regularizer"

    def case(self):
        pytest.importorskip("opinf")
        return _peer_case(dict(n_modes=3, regularizer=1e-6), ("regularizer", -1.0))


# ------------------------------------------------------------------ exactness
def test_era_is_exact_on_the_coupled_chain_at_the_true_order():
    """5-DOF chain (state dimension 10 under Newmark, direct term D ≠ 0), 5 pulse records,
    k = m = 5: OKID + ERA of order 10 predicts a new smooth load on every DOF.
    Measured: 5e-14."""
    fc, recs, target = _records()
    model = ERA(n_modes=D, order=2 * D).fit(recs)
    assert rel_err(model.predict(target), fc.W_new) < 1e-8
    # one order too few is not exact: the test can fail
    assert rel_err(ERA(n_modes=D, order=2 * D - 2).fit(recs).predict(target), fc.W_new) > 1e-4


def test_era_order_rule_finds_the_state_dimension():
    """The hold-out rule (training records only) picks order 10 on the noise-free chain;
    measured hold-out error 2e-13."""
    fc, recs, target = _records()
    model = ERA(n_modes=D).fit(recs)
    assert model.order_ == 2 * D
    assert model.diagnostics_["order"] == 2 * D
    assert model.diagnostics_["lags"] == 8  # ceil(max_order / k) = ceil(40 / 5)
    assert rel_err(model.predict(target), fc.W_new) < 1e-8


def test_era_markov_parameters_are_mls_kernel():
    """OKID's system Markov parameters equal Δt·C(t_j), ML's kernel in the same basis (both
    are the discrete impulse response); measured agreement 1e-13 relative."""
    fc, recs, _ = _records()
    era = ERA(n_modes=D, order=2 * D).fit(recs)
    ml = MultipleLoad(solver="block").fit(recs, basis=era.modes_)
    L = 50
    expected = fc.dt * ml.kernel_[:, :, :L].transpose(2, 0, 1)
    np.testing.assert_allclose(era.markov_[:L], expected, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("cls, params", [(DMDc, dict(svd_rank=2 * D)),
                                         (OpInf, dict(regularizer=0.0))])
def test_delay_models_are_exact_on_the_chain(cls, params):
    """With two delays the Newmark chain is an exact linear map of ``[y_j; y_{j−1}]`` and
    ``[u_{j+1}; u_j; u_{j−1}]`` when k = m; measured 1e-10 (DMDc), 1e-12 (OpInf)."""
    pytest.importorskip("pydmd" if cls is DMDc else "opinf")
    fc, recs, target = _records()
    model = cls(n_modes=D, **params).fit(recs)
    assert rel_err(model.predict(target), fc.W_new) < 1e-8
    # a displacement-only state (one delay) cannot carry the oscillation: measured ~1
    one = cls(n_modes=D, delays=1, **params if cls is OpInf else dict(svd_rank=D)).fit(recs)
    assert rel_err(one.predict(target), fc.W_new) > 0.5


# ------------------------------------------------------------------ python-control
def _control_mimo():
    """python-control's ERA test system (modelsimp_test.py::testERASignature, MIMO part):
    a 2-DOF spring-mass-damper, sampled with a zero-order hold at dt = 0.1 s."""
    ct = pytest.importorskip("control")
    m1, k1, c1 = 1.0, 4.0, 1.0
    m2, k2, c2 = 2.0, 2.0, 1.0
    k3, c3 = 6.0, 2.0
    A = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                  [-(k1 + k2) / m1, k2 / m1, -(c1 + c2) / m1, c2 / m1],
                  [k2 / m2, -(k2 + k3) / m2, c2 / m2, -(c2 + c3) / m2]])
    B = np.array([[0.0, 0.0], [0.0, 0.0], [1 / m1, 0.0], [0.0, 1 / m2]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    dt = 0.1
    sysd = ct.ss(A, B, C, np.zeros((2, 2))).sample(dt, method="zoh")
    return ct, sysd, dt


def _control_records(ct, sysd, dt, n=100, seeds=(1, 2, 3)):
    recs = []
    T = np.arange(n) * dt
    for s in seeds:
        U = np.random.default_rng(s).standard_normal((2, n))
        U[:, 0] = 0.0  # at rest, first force sample zero (podbench's convention)
        Y = ct.forced_response(sysd, T=T, U=U).outputs
        recs.append(Record(W=Y, F=U, dt=dt))
    return recs, T


def test_era_agrees_with_python_control():
    """On python-control's own ERA test system: our Markov parameters (OKID from three
    random-input records) equal the true impulse response, and our order-4 realization
    predicts a new input as python-control's ``eigensys_realization`` of the true impulse
    response does. Measured: 1e-13 (Markov), 1e-12 (predictions)."""
    ct, sysd, dt = _control_mimo()
    recs, T = _control_records(ct, sysd, dt)
    model = ERA(n_modes=2, order=4).fit(recs, basis=np.eye(2))
    ir = ct.impulse_response(sysd, T=T)  # outputs (2, 2, n): [output, input, time]
    h_true = np.moveaxis(ir.outputs, 2, 0) * dt  # python-control: unit-area impulse (1/Δt)
    np.testing.assert_allclose(model.markov_[:40], h_true[:40], atol=1e-9)
    sys_est, _ = ct.eigensys_realization(ir, r=4, dt=dt)
    U_new = np.zeros((2, 100))
    U_new[0, 1:30] = np.sin(np.linspace(0, np.pi, 29))
    U_new[1, 10:20] = -1.0
    y_control = ct.forced_response(sys_est, T=T, U=U_new).outputs
    y_true = ct.forced_response(sysd, T=T, U=U_new).outputs
    y_ours = model.predict(Record(W=np.zeros((2, 100)), F=U_new, dt=dt))
    np.testing.assert_allclose(y_ours, y_control, atol=1e-8 * np.abs(y_true).max())
    np.testing.assert_allclose(y_ours, y_true, atol=1e-8 * np.abs(y_true).max())
    # the same system poles
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(model.A_)),
                               np.sort_complex(np.linalg.eigvals(sysd.A)), atol=1e-9)


def test_okid_agrees_with_control_markov_on_one_record():
    """``control.markov`` takes one record and fits a finite impulse response (its Markov
    parameters ``h_0 … h_{L−1}`` with ``h_j = 0`` beyond, scaled by 1/Δt); with L = the
    record length that is exact for a single-input channel. OKID with 4 lags (a deadbeat
    observer of the order-4 system) on the same record gives the same parameters.
    Measured: 1e-13 relative."""
    ct, sysd, dt = _control_mimo()
    siso = sysd[0, 0]
    n = 200
    T = np.arange(n) * dt
    u = np.random.default_rng(7).standard_normal((1, n))  # u_0 ≠ 0: nonsingular Toeplitz
    y = ct.forced_response(siso, T=T, U=u).outputs.reshape(1, n)
    data = ct.TimeResponseData(time=T, outputs=y, inputs=u)
    H = np.asarray(ct.markov(data, n, dt=dt)).reshape(-1) * dt  # undo the 1/Δt scaling
    h, residual = okid_markov(y[None], u[None], lags=4, n_markov=60)
    assert residual < 1e-10
    np.testing.assert_allclose(h[:, 0, 0], H[:60], atol=1e-9 * np.abs(H).max())


# ------------------------------------------------------------------ the optional extra
@pytest.mark.parametrize("cls, module, words", [(DMDc, "pydmd", "DMDc needs PyDMD"),
                                                (OpInf, "opinf", "OpInf needs opinf")])
def test_missing_extra_is_one_line_naming_it(monkeypatch, cls, module, words):
    for name in list(sys.modules):
        if name == module or name.startswith(module + "."):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, module, None)  # the import now fails
    with pytest.raises(InputError, match=rf"^{words}: pip install 'podbench\[peers\]'$"):
        cls()._validate_params()


def test_era_needs_no_extra(monkeypatch):
    for module in ("pydmd", "opinf", "control"):
        monkeypatch.setitem(sys.modules, module, None)
    ERA()._validate_params()


@pytest.mark.parametrize("cls, name, value", [(ERA, "order", 0), (ERA, "max_order", None),
                                              (ERA, "lags", 2.5), (DMDc, "svd_rank", 1.5),
                                              (OpInf, "delays", None)])
def test_bad_parameter_is_one_line_naming_it(cls, name, value):
    with pytest.raises(InputError, match=rf"^Parameter `{name}`") as info:
        cls(**{name: value})._validate_params()
    assert "\n" not in str(info.value)


def test_era_order_and_hankel_values_do_not_depend_on_round_off():
    """OKID's least squares keeps only directions above OKID_RCOND = 1e-8 of the largest
    singular value: a 1e-15 relative perturbation of the records (what another BLAS kernel
    does) leaves the chosen order and the Hankel singular values in place (1.8e-6 relative
    on these 300-sample records). With a cut below round-off (rcond 1e-17) the same
    perturbation moves them by 10 % and the chosen order from 34 to 12."""
    beam = load_structure("ltv_beam")
    recs = []
    for x in (2.0, 7.0, 11.0, 16.0):
        force = excitation_from_dict({"kind": "pulse", "location": x, "amplitude": 500.0,
                                      "duration": 5e-4})
        r = simulate(beam, n_samples=300, dt=1e-4, force=force)
        recs.append(Record(W=r.W, F=r.F, dt=r.dt))
    rng = np.random.default_rng(1)
    bent = [Record(W=r.W * (1 + 1e-15 * rng.standard_normal(r.W.shape)), F=r.F, dt=r.dt)
            for r in recs]

    def fits(rcond):
        return [ERA(rcond=rcond).fit(rs) for rs in (recs, bent)]

    a, b = fits(1e-8)
    assert a.order_ == b.order_
    top = a.order_ + 1
    assert np.allclose(a.hankel_sv_[:top], b.hankel_sv_[:top], rtol=1e-4, atol=0)
    # the round-off cut lets the perturbation through (the test can fail)
    c, d = fits(1e-17)
    assert not np.allclose(c.hankel_sv_[:top], d.hankel_sv_[:top], rtol=1e-6, atol=0)
