"""The low-order realization solver (``"realization"``).

Checked against independent computations: the Markov parameters ``C A^{p−1} B`` of a known
state-space system (simulated by its own state recursion, not by podbench's convolution),
the pole regressors against ``numpy.convolve`` with the basis sequences, and the order rule
against the known state dimension.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import sklearn.base

from podbench.errors import InputError
from podbench.sysid import deconvolution as dc

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _state_space(order=6, k=2, r=2, seed=0):
    """A stable real system of ``order`` states (complex pole pairs of radius 0.93–0.98)."""
    rng = np.random.default_rng(seed)
    blocks = []
    for j in range(order // 2):
        rad, ang = 0.93 + 0.05 * j / max(order // 2 - 1, 1), 0.3 + 0.7 * j
        blocks.append(rad * np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]]))
    A = np.zeros((order, order))
    for j, b in enumerate(blocks):
        A[2 * j:2 * j + 2, 2 * j:2 * j + 2] = b
    T = rng.standard_normal((order, order)) + 3 * np.eye(order)
    A = T @ A @ np.linalg.inv(T)
    return A, rng.standard_normal((order, k)), rng.standard_normal((r, order)), \
        rng.standard_normal((r, k))


def _records(A, B, C, D, n=120, n_cases=2, dt=0.01, seed=1):
    """Forced responses from rest by the state recursion ``x⁺ = A x + B u Δt`` (the Δt of
    Eq. 3.39 folded into the input), ``y = C x + D u Δt``; returns (Qs, Bstack, X_true)."""
    rng = np.random.default_rng(seed)
    k, r = B.shape[1], C.shape[0]
    Qs, Ys = [], []
    for j in range(n_cases):
        # pulse-like: a dominant first sample (a well-conditioned triangular system for the
        # exact pilot), then a decaying random tail
        U = 0.5 * rng.standard_normal((k, n)) * 0.97 ** np.arange(n)
        U[j % k, 0] += 4.0
        x = np.zeros(A.shape[0])
        Y = np.zeros((r, n))
        for s in range(n):
            Y[:, s] = C @ x + D @ U[:, s] * dt
            x = A @ x + B @ U[:, s] * dt
        Qs.append(U)
        Ys.append(Y.T)
    h = [D] + [C @ np.linalg.matrix_power(A, p - 1) @ B for p in range(1, n)]  # (r, k) each
    X = np.stack(h).transpose(2, 0, 1).reshape(k * n, r)  # row i·n + p: h[p][:, i]
    return Qs, np.concatenate(Ys), dt, X


def test_known_system_markov_parameters_recovered():
    A, B, C, D = _state_space()
    Qs, Bs, dt, X = _records(A, B, C, D)
    # the recursion is the convolution of Eq. 3.39 with kernel h[p]: independent check
    np.testing.assert_allclose(dc.convolution_product(Qs, X, dt), Bs, rtol=1e-10, atol=1e-12)
    res = dc.deconvolve(Qs, Bs, dt, dc.Realization(order=6, pilot="block"), return_info=True)
    assert np.max(np.abs(res.X - X)) < 1e-8 * np.max(np.abs(X))
    assert res.info["order"] == 6 and res.info["order_rule"] == "fixed"
    assert res.info["poles"] == 3 and abs(res.info["max_pole"] - 0.98) < 1e-8
    # too low an order cannot: the residual tells
    low = dc.deconvolve(Qs, Bs, dt, dc.Realization(order=4, pilot="block"), return_info=True)
    assert low.info["residual"] > 1e-3


@pytest.mark.parametrize("order", [4, 6, 8])
def test_order_rule_picks_the_true_order_on_exact_data(order):
    A, B, C, D = _state_space(order=order, seed=order)
    Qs, Bs, dt, X = _records(A, B, C, D, n=150, seed=order + 1)
    res = dc.deconvolve(Qs, Bs, dt, dc.Realization(pilot="block", max_order=16),
                        return_info=True)
    assert res.info["order"] == order and res.info["order_rule"] == "holdout"
    assert res.info["holdout_residual"] < 1e-9
    assert np.max(np.abs(res.X - X)) < 1e-8 * np.max(np.abs(X))


def test_realization_averages_noise_better_than_the_pilot():
    A, B, C, D = _state_space(order=4, seed=3)
    Qs, Bs, dt, X = _records(A, B, C, D, n=200, seed=5)
    noisy = Bs + 0.05 * Bs.std() * np.random.default_rng(9).standard_normal(Bs.shape)
    rel = lambda Y: np.linalg.norm(Y - X) / np.linalg.norm(X)  # noqa: E731
    pilot = rel(dc.deconvolve(Qs, noisy, dt, "cgls"))
    res = dc.deconvolve(Qs, noisy, dt, dc.Realization(pilot="cgls", max_order=12),
                        return_info=True)
    assert res.info["order"] == 4
    # measured: 0.013 against the pilot's 0.065 (cgls with GCV)
    assert rel(res.X) < 0.02 and rel(res.X) < 0.3 * pilot


def test_pole_regressors_equal_convolution_with_the_basis():
    rng = np.random.default_rng(2)
    n, dt = 50, 0.02
    G = rng.standard_normal((n, 2, 3))
    poles = np.array([0.9 * np.exp(0.4j), 0.5 + 0j, -0.7 + 0j])
    Phi = dc.pole_basis(poles, n)
    assert Phi.shape == (n, 5)
    p = np.arange(1, n)
    np.testing.assert_allclose(Phi[1:, 1] + 1j * Phi[1:, 2], poles[0] ** (p - 1), rtol=1e-12)
    np.testing.assert_allclose(Phi[1:, 4], (-0.7) ** (p - 1), rtol=1e-12)
    Z = dc.pole_regressors(G, dt, poles)
    for b in range(Phi.shape[1]):
        want = dt * np.stack([[np.convolve(G[:, j, i], Phi[:, b])[:n] for i in range(3)]
                              for j in range(2)]).transpose(2, 0, 1)
        np.testing.assert_allclose(Z[..., b], want, rtol=1e-10, atol=1e-12)


def test_contract_clone_pickle_and_bad_options():
    solver = dc.Realization(order=8, pilot="cgls", holdout=0.3)
    assert dc.get_solver("realization") is dc.Realization and dc.Realization.structured
    twin = sklearn.base.clone(solver)
    assert type(twin) is dc.Realization and twin.get_params() == solver.get_params()
    assert pickle.loads(pickle.dumps(solver)).get_params() == solver.get_params()
    with pytest.raises(InputError, match="`holdout`"):
        dc.make_solver("realization", {"holdout": 1.0})
    with pytest.raises(InputError, match="`pilot`"):
        dc.make_solver("realization", {"pilot": "auto"})
    with pytest.raises(InputError, match="`order`"):
        dc.make_solver("realization", {"order": 0})


def test_normal_equation_path_and_short_rule_window(monkeypatch):
    """Long records: the residues by the normal equations, the order rule on a prefix."""
    import podbench.sysid.deconvolution.realization as rz

    A, B, C, D = _state_space(order=6, seed=4)
    Qs, Bs, dt, X = _records(A, B, C, D, n=160, seed=6)
    monkeypatch.setattr(rz, "_DIRECT_MAX", 0)
    res = dc.deconvolve(Qs, Bs, dt, dc.Realization(pilot="block", n_rule=90, n_pilot=80),
                        return_info=True)
    assert res.info["order"] == 6 and res.info["n_rule"] == 90 and res.info["n_pilot"] == 80
    assert np.max(np.abs(res.X - X)) < 1e-7 * np.max(np.abs(X))


@pytest.mark.slow
def test_ml_records_what_auto_chose():
    """ML in the identity basis (sensors = modes): the modal forces are F, the POCs W."""
    from podbench.sysid.methods import MultipleLoad

    A, B, C, D = _state_space(order=4, k=2, r=2, seed=7)
    Qs, Bs, dt, X = _records(A, B, C, D, n=100, seed=8)
    n = 100
    Ws = [Bs[j * n:(j + 1) * n].T for j in range(2)]
    est = MultipleLoad(solver="auto").fit(Ws, Qs, dt=dt, basis=np.eye(2))
    assert est.diagnostics_["solver_choice"] == "block"
    noisy = [W + 0.02 * W.std() * np.random.default_rng(j).standard_normal(W.shape)
             for j, W in enumerate(Ws)]
    est = MultipleLoad(solver=dc.Auto(robust="realization")).fit(noisy, Qs, dt=dt,
                                                                basis=np.eye(2))
    d = est.diagnostics_
    assert d["solver_choice"] == "realization" and d["solver_order"] == est.solver_info_["order"]
