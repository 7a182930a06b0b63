"""SingleLoad and MultipleLoad (§3.3) against an independent Newmark truth (``_truth``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from podbench import Record
from podbench.sysid.methods import MultipleLoad, SingleLoad

from ._cases import D, forced_case
from ._contract import MethodContract
from ._truth import eigenmodes, newmark, pulse, rel_err
from .test_free_methods import _random_system

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _sl_case():
    fc = forced_case("coupled")
    return SimpleNamespace(
        params=dict(n_modes=3),
        fit=lambda model, basis=None: model.fit(fc.W[0], fc.F[0], dt=fc.dt, basis=basis),
        predict_train=lambda model: [(model.predict(fc.F[0]), fc.W[0])],
        predict_new=lambda model: model.predict(fc.F_new),
        bad_param=("solver", "nope"),
        records=[Record(W=fc.W[0], F=fc.F[0], dt=fc.dt)],
        target=Record(W=fc.W_new, F=fc.F_new, dt=fc.dt),
    )


def _ml_case(solver="ls"):
    fc = forced_case("coupled")
    return SimpleNamespace(
        params=dict(n_modes=3, solver=solver),
        fit=lambda model, basis=None: model.fit(fc.W[:3], fc.F[:3], dt=fc.dt, basis=basis),
        predict_train=lambda model: [(model.predict(fc.F[j]), fc.W[j]) for j in range(3)],
        predict_new=lambda model: model.predict(fc.F_new),
        bad_param=("max_cond", 0.5),
        records=[Record(W=fc.W[j], F=fc.F[j], dt=fc.dt) for j in range(3)],
        target=Record(W=fc.W_new, F=fc.F_new, dt=fc.dt),
    )


class TestSingleLoadContract(MethodContract):
    method = SingleLoad

    def case(self):
        return _sl_case()


class TestMultipleLoadContract(MethodContract):
    method = MultipleLoad

    def case(self):
        return _ml_case()


# ------------------------------------------------------------------------- ML
def test_ml_is_exact_on_the_coupled_chain():
    """k = m = 5 load cases, all forces start at sample 1 (F[:, 0] = 0, so every
    convolution matrix has a zero diagonal and the block system is singular but
    consistent). Measured: 3e-15."""
    fc = forced_case("coupled")
    assert all(np.all(F[:, 0] == 0) for F in fc.F + [fc.F_new])
    model = MultipleLoad().fit(fc.W, fc.F, dt=fc.dt)
    assert model.n_modes_ == D
    assert rel_err(model.predict(fc.F_new), fc.W_new) < 1e-9
    assert model.fit_residual_ < 1e-12


def test_ml_kernel_is_the_discrete_impulse_response():
    """C(t_p) = Uᵀ G_p U / Δt, with G_p the Newmark response at sample p + 1 to a unit
    force at sample 1 (the kernel carries the 1/Δt of Eq. 3.39)."""
    fc = forced_case("coupled")
    model = MultipleLoad().fit(fc.W, fc.F, dt=fc.dt)
    U = model.modes_
    G = np.empty((D, D, fc.n - 1))
    for i in range(D):
        F = np.zeros((D, fc.n))
        F[i, 1] = 1.0
        G[:, i, :] = newmark(fc.M, fc.C, fc.K, fc.dt, fc.n, F=F)[0][:, 1:]
    expected = np.einsum("ai,abp,bj->ijp", U, G, U) / fc.dt
    got = model.kernel_[:, :, : fc.n - 1]
    np.testing.assert_allclose(got, expected, atol=1e-9 * np.abs(expected).max())


def test_ml_is_the_matlab_podforce_mloads():
    """Transcription of the appendix (kernel without Δt, pinv) gives the same prediction."""
    fc = forced_case("coupled")
    k, n = 3, fc.n
    model = MultipleLoad().fit(fc.W[:k], fc.F[:k], dt=fc.dt)
    U = np.linalg.svd(fc.W[0], full_matrices=False)[0][:, :k]
    U = U * np.sign(np.sum(U * model.modes_, axis=0))  # same POM signs as podbench
    q = [U.T @ F for F in fc.F[:k]]
    Qbar = np.zeros((k * n, k * n))
    for i in range(k):
        for j in range(k):
            Qbar[i * n:(i + 1) * n, j * n:(j + 1) * n] = np.tril(
                np.array([[q[i][j, r - c] if r >= c else 0 for c in range(n)] for r in range(n)])
            )
    V = np.vstack([(U.T @ W).T for W in fc.W[:k]])
    C = np.linalg.pinv(Qbar) @ V
    qn = U.T @ fc.F_new
    Qbarnew = np.hstack([np.tril(np.array([[qn[i, r - c] if r >= c else 0 for c in range(n)]
                                           for r in range(n)])) for i in range(k)])
    expected = U @ (Qbarnew @ C).T
    np.testing.assert_allclose(model.predict(fc.F_new), expected,
                               atol=1e-8 * np.abs(expected).max())
    # the MATLAB's kernel is Δt times ours (it drops the Δt of Eq. 3.39)
    np.testing.assert_allclose(fc.dt * model.Cbar_[:-1], C[:-1], atol=1e-6 * np.abs(C).max())


@pytest.mark.parametrize(
    "train_start, new_first, floor",
    [(0, 0.0, 0.05),   # measured 0.10: training forces nonzero at t = 0
     (1, 50.0, 0.05),  # measured 0.19: new force nonzero at t = 0
     (0, 50.0, 0.05)],  # measured 0.17: both
)
def test_ml_with_a_nonzero_first_force_sample_is_visibly_wrong(train_start, new_first, floor):
    """Newmark brings f_0 in through a_0 = M⁻¹f_0, not through the convolution kernel."""
    fc = forced_case("coupled", start=train_start)
    F_new = fc.F_new.copy()
    F_new[:, 0] = new_first
    W_new = newmark(fc.M, fc.C, fc.K, fc.dt, fc.n, F=F_new)[0]
    model = MultipleLoad().fit(fc.W, fc.F, dt=fc.dt)
    assert model.fit_residual_ < 1e-12  # the training data are still reproduced
    assert rel_err(model.predict(F_new), W_new) > floor


def test_ml_with_staggered_load_starts_is_wrong_only_at_the_end():
    """Load case j starting at sample 1 + j leaves the last lags of C determined by fewer
    cases than modes: a new load starting at sample 1 is exact except for the last
    (s_max − s_min) = 4 samples."""
    fc = forced_case("coupled")
    F = [pulse(D, fc.n, j, start=1 + j, width=5) for j in range(D)]
    W = [newmark(fc.M, fc.C, fc.K, fc.dt, fc.n, F=Fj)[0] for Fj in F]
    model = MultipleLoad().fit(W, F, dt=fc.dt)
    err = np.linalg.norm(model.predict(fc.F_new) - fc.W_new, axis=0)
    scale = np.linalg.norm(fc.W_new)
    assert err[: fc.n - 4].max() < 1e-9 * scale
    assert err[fc.n - 4:].max() > 1e-4 * scale


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.integers(2, 3))
def test_ml_exact_for_random_lti_systems(seed, d):
    """Property: random SPD M, K, PSD C; pulses at every DOF from sample 1 → ML exact."""
    rng = np.random.default_rng(seed)
    M, C, K, dt = _random_system(rng, d)
    n = 40
    F = [pulse(d, n, j, width=3) for j in range(d)]
    W = [newmark(M, C, K, dt, n, F=Fj)[0] for Fj in F]
    F_new = np.zeros((d, n))
    F_new[:, 1:] = rng.standard_normal((d, n - 1))
    W_new = newmark(M, C, K, dt, n, F=F_new)[0]
    model = MultipleLoad().fit(W, F, dt=dt)
    assert rel_err(model.predict(F_new), W_new) < 1e-6


# ------------------------------------------------------------------------- SL
def test_sl_is_the_matlab_podforce():
    fc = forced_case("coupled")
    k, n = 3, fc.n
    U, S, Vt = np.linalg.svd(fc.W[0], full_matrices=False)
    U, V = U[:, :k], (np.diag(S[:k]) @ Vt[:k]).T
    Qold, Qnew = U.T @ fc.F[0], U.T @ fc.F_new
    Vnew = np.zeros((n, k))
    for i in range(k):
        Qo = np.array([[Qold[i, r - c] if r >= c else 0 for c in range(n)] for r in range(n)])
        Qn = np.array([[Qnew[i, r - c] if r >= c else 0 for c in range(n)] for r in range(n)])
        Vnew[:, i] = Qn @ (np.linalg.pinv(Qo) @ V[:, i])
    expected = U @ Vnew.T
    got = SingleLoad(n_modes=k).fit(fc.W[0], fc.F[0], dt=fc.dt).predict(fc.F_new)
    np.testing.assert_allclose(got, expected, atol=1e-8 * np.abs(expected).max())


def test_sl_is_not_exact_on_the_coupled_chain():
    """k = m: only SL's diagonalization error remains. Measured, per training load case:
    1.82 0.19 0.20 0.18 0.070."""
    fc = forced_case("coupled")
    errs = [rel_err(SingleLoad(n_modes=D).fit(W, F, dt=fc.dt).predict(fc.F_new), fc.W_new)
            for W, F in zip(fc.W, fc.F, strict=True)]
    assert min(errs) > 1e-2
    assert np.median(errs) > 0.1


def test_sl_is_close_on_the_ideal_chain():
    """Measured: 0.0099 0.020 0.013 0.116 0.0076 (median 0.013)."""
    fc = forced_case("ideal")
    errs = [rel_err(SingleLoad(n_modes=D).fit(W, F, dt=fc.dt).predict(fc.F_new), fc.W_new)
            for W, F in zip(fc.W, fc.F, strict=True)]
    assert np.median(errs) < 5e-2


def test_sl_is_exact_in_the_eigenmode_basis_of_the_ideal_chain():
    fc = forced_case("ideal")
    model = SingleLoad().fit(fc.W[0], fc.F[0], dt=fc.dt, basis=eigenmodes(fc.M, fc.K))
    assert rel_err(model.predict(fc.F_new), fc.W_new) < 1e-9
    off = model.kernel_ * (1 - np.eye(D))[:, :, None]
    assert np.all(off == 0)


def test_ml_twin_in_sl_basis_removes_the_diagonalization_error():
    fc = forced_case("coupled")
    sl = SingleLoad(n_modes=D).fit(fc.W[0], fc.F[0], dt=fc.dt)
    twin = MultipleLoad().fit(fc.W, fc.F, dt=fc.dt, basis=sl.modes_)
    assert rel_err(twin.predict(fc.F_new), fc.W_new) < 1e-9


@pytest.mark.parametrize("method", [SingleLoad(n_modes=3), MultipleLoad(n_modes=3)])
def test_shorter_force_predicts_the_first_samples(method):
    fc = forced_case("coupled")
    if isinstance(method, SingleLoad):
        method.fit(fc.W[0], fc.F[0], dt=fc.dt)
    else:
        method.fit(fc.W[:3], fc.F[:3], dt=fc.dt)
    full = method.predict(fc.F_new)
    part = method.predict(fc.F_new[:, :50])
    assert part.shape == (D, 50)
    np.testing.assert_allclose(part, full[:, :50], atol=1e-12 * np.abs(full).max())


@pytest.mark.parametrize("solver", ["ls", "tls-dt"])
def test_tls_on_clean_data_matches_ls(solver):
    fc = forced_case("coupled")
    model = MultipleLoad(solver=solver).fit(fc.W, fc.F, dt=fc.dt)
    assert rel_err(model.predict(fc.F_new), fc.W_new) < 1e-8
