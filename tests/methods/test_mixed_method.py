"""MixedResponse (§3.4) against an independent Newmark truth (``_truth``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg

from podbench import Record
from podbench.deconvolution import convolution_matrix
from podbench.methods import MixedResponse

from ._cases import D, mixed_case
from ._contract import MethodContract
from ._truth import eigenmodes, ideal_chain, newmark, pulse, rel_err


def _mr_case(scaling="ratio"):
    mc = mixed_case("coupled")
    return SimpleNamespace(
        params=dict(n_modes=3, velocity_scaling=scaling),
        fit=lambda model, basis=None: model.fit(mc.W, w0=mc.w0, v0=mc.v0, F=mc.F, dt=mc.dt,
                                                basis=basis),
        predict_train=lambda model: [
            (model.predict(w0=mc.w0[j], v0=mc.v0[j], F=mc.F[j]), mc.W[j]) for j in range(3)
        ],
        predict_new=lambda model: model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new),
        bad_param=("velocity_scaling", "spline"),
        records=[Record(W=mc.W[j], F=mc.F[j], w0=mc.w0[j], v0=mc.v0[j], dt=mc.dt)
                 for j in range(3)],
        target=Record(W=mc.W_all, F=mc.F_new, w0=mc.w0_new, v0=mc.v0_new, dt=mc.dt),
    )


class TestMixedResponseContract(MethodContract):
    method = MixedResponse

    def case(self):
        return _mr_case()


def _parts(model, mc):
    return {
        "w0": rel_err(model.predict(w0=mc.w0_new), mc.W_w0),
        "v0": rel_err(model.predict(v0=mc.v0_new), mc.W_v0),
        "F": rel_err(model.predict(F=mc.F_new), mc.W_F),
        "all": rel_err(model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new), mc.W_all),
    }


def _fit(mc, **kw):
    basis = kw.pop("basis", None)
    return MixedResponse(**kw).fit(mc.W, w0=mc.w0, v0=mc.v0, F=mc.F, dt=mc.dt, basis=basis)


def test_mr_is_exact_in_the_eigenmode_basis_of_the_ideal_chain():
    """Diagonal Φ11, Φ12, C hold exactly in the eigenmode basis: every part is exact."""
    mc = mixed_case("ideal")
    errs = _parts(_fit(mc, basis=eigenmodes(mc.M, mc.K)), mc)
    assert max(errs.values()) < 1e-9, errs


SEEDS = range(10)


def _median_parts(name):
    errs = [_parts(_fit(mixed_case(name, seed), n_modes=D), mixed_case(name, seed))
            for seed in SEEDS]
    return {key: float(np.median([e[key] for e in errs])) for key in errs[0]}


def test_mr_with_poms_is_better_on_the_ideal_than_on_the_coupled_chain():
    """POMs of case a (k = m = 5), ten random excitation sets per chain.

    Measured medians (worst): ideal w0 0.11 (0.29), v0 0.16 (1.35), F 0.19 (1.03);
    coupled w0 0.43 (0.98), v0 0.80 (5.2), F 0.83 (16.7). MR is far more sensitive to the
    POMs not being eigenmodes than POVR or SL (see the next test); it is exact when they are.
    """
    ideal, coupled = _median_parts("ideal"), _median_parts("coupled")
    for key in ("w0", "v0", "F"):
        assert ideal[key] < 0.25, ideal
        assert ideal[key] < coupled[key], (ideal, coupled)


def test_mr_error_grows_linearly_with_the_basis_departure_from_eigenmodes():
    """Basis = eigenmodes rotated by expm(ε A): error ≈ g·ε, with a gain g ≈ 5–12 here
    (measured: ε = 1e-4 → 5e-4, 5e-4, 1.2e-3 for w0, v0, F; ×10 at ε = 1e-3)."""
    mc = mixed_case("ideal")
    Phi = eigenmodes(mc.M, mc.K)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((D, D))
    A = A - A.T
    errs = {}
    for eps in (1e-4, 1e-3):
        basis = Phi @ scipy.linalg.expm(eps * A)
        errs[eps] = _parts(_fit(mc, basis=basis), mc)
    for key in ("w0", "v0", "F"):
        assert errs[1e-4][key] < 5e-3
        assert errs[1e-3][key] / errs[1e-4][key] == pytest.approx(10, rel=0.2)


def test_displacement_history_starts_at_the_initial_coordinate():
    """D[0] = u_iᵀw0_a and V[0] = 0, so scaling by u_iᵀw̃0/u_iᵀw0_a (Eq. 3.58) equals the
    MATLAB's u_iᵀw̃0 / D[0]."""
    mc = mixed_case("coupled")
    model = _fit(mc, n_modes=3)
    a = model.initial_displacement_coordinates_
    np.testing.assert_allclose(model.disp_histories_[:, 0], a, rtol=1e-10)
    np.testing.assert_allclose(model.vel_histories_[:, 0], 0, atol=1e-12 * np.abs(a).max())
    # Eqs. 3.62-3.63 only split D and V into POV × unit POC
    np.testing.assert_allclose(np.linalg.norm(model.pocs_disp_, axis=0), 1)
    np.testing.assert_allclose(model.pocs_disp_ * model.povs_disp_, model.disp_histories_.T)
    np.testing.assert_allclose(model.pocs_vel_ * model.povs_vel_, model.vel_histories_.T)


def test_mr_is_the_matlab_elimination():
    """Transcription of the appendix's loop (inv(Q) replaced by pinv: Q is singular when the
    forces start with a zero sample; the MATLAB's inv would fail there)."""
    mc = mixed_case("coupled")
    k, dt = 3, mc.dt
    model = _fit(mc, n_modes=k)
    Ua = np.linalg.svd(mc.W[0], full_matrices=False)[0][:, :k]
    Ua = Ua * np.sign(np.sum(Ua * model.modes_, axis=0))
    Va, Vb, Vc = ((Ua.T @ W).T for W in mc.W)
    qa, qb, qc = (Ua.T @ F for F in mc.F)
    for i in range(k):
        u = Ua[:, i]
        rbad = (u @ mc.w0[1]) / (u @ mc.w0[0])
        rbav = (u @ mc.v0[1]) / (u @ mc.v0[0])
        rcad = (u @ mc.w0[2]) / (u @ mc.w0[0])
        rcav = (u @ mc.v0[2]) / (u @ mc.v0[0])
        Rcb = (rcav - rcad) / (rbav - rbad)
        Qa, Qb, Qc = (np.tril(np.array([[q[i, r - c] if r >= c else 0 for c in range(mc.n)]
                                        for r in range(mc.n)])) for q in (qa, qb, qc))
        Q = Qc - rcad * Qa - Rcb * (Qb - rbad * Qa)
        dtC = np.linalg.pinv(Q) @ (Vc[:, i] - rcad * Va[:, i] - Rcb * (Vb[:, i] - rbad * Va[:, i]))
        V_iv = (Vb[:, i] - rbad * Va[:, i] - (Qb - rbad * Qa) @ dtC) / (rbav - rbad)
        V_id = Va[:, i] - V_iv - Qa @ dtC
        tol = 1e-8 * np.abs(Va[:, i]).max()
        np.testing.assert_allclose(model.vel_histories_[i], V_iv, atol=tol)
        np.testing.assert_allclose(model.disp_histories_[i], V_id, atol=tol)
        np.testing.assert_allclose(model.pov_ratios_[i], [rbad, rbav, rcad, rcav], rtol=1e-10)
        # the MATLAB's dtCbar is Δt times our kernel (Eq. 3.39 keeps Δt); compare its effect
        q_new = Ua[:, i] @ mc.F_new
        np.testing.assert_allclose(
            convolution_matrix(q_new, dt) @ model.kernel_[i, i],
            convolution_matrix(q_new, 1.0) @ dtC, atol=tol)


def _one_dof_fd_ratio(omega, c, dt):
    """(w1 − w0)/Δt of a unit-mass oscillator started with unit velocity (_truth Newmark)."""
    W, _ = newmark(np.eye(1), np.array([[c]]), np.array([[omega**2]]), dt, 2, v0=[1.0])
    return (W[0, 1] - W[0, 0]) / dt


def test_finite_difference_derivative_is_the_newmark_one_step_difference():
    """Eq. 3.64 in the eigenmode basis: V̇(0) = u_iᵀv0_a · (w1 − w0)/Δt of the modal
    oscillator (ω_i, modal damping α + β ω_i²), an independent one-DOF computation."""
    mc = mixed_case("ideal")
    Phi = eigenmodes(mc.M, mc.K)
    model = _fit(mc, basis=Phi, velocity_scaling="finite_difference")
    omega = np.sqrt(np.diag(Phi.T @ mc.K @ Phi))
    cmod = np.diag(Phi.T @ mc.C @ Phi)
    expected = np.array([_one_dof_fd_ratio(w, c, mc.dt) for w, c in zip(omega, cmod,
                                                                          strict=True)])
    np.testing.assert_allclose(
        model.velocity_derivative_ / model.initial_velocity_coordinates_, expected, rtol=1e-8)
    assert expected.min() < 0.6  # at ω Δt ≈ 1.9 the one-sided difference is far off


def test_velocity_scaling_ratio_vs_finite_difference():
    """Both options on the same data (eigenmode basis, so only the scaling differs):
    ratio exact; finite differences biased, the bias shrinking with Δt.
    Measured FD errors: 0.117 (Δt = 0.01 s), 0.0048 (Δt = 0.002 s)."""
    M, C, K = ideal_chain(D)
    Phi = eigenmodes(M, K)
    fd_err = {}
    for dt in (0.01, 0.002):
        n = 400
        rng = np.random.default_rng(14)
        w0 = [0.01 * rng.standard_normal(D) for _ in range(3)]
        v0 = [rng.standard_normal(D) for _ in range(3)]
        F = [pulse(D, n, j, width=3) for j in (4, 2, 0)]
        W = [newmark(M, C, K, dt, n, w0=a, v0=b, F=c)[0] for a, b, c in zip(w0, v0, F,
                                                                           strict=True)]
        v_new = rng.standard_normal(D)
        W_new = newmark(M, C, K, dt, n, v0=v_new)[0]
        for scaling in ("ratio", "finite_difference"):
            model = MixedResponse(velocity_scaling=scaling).fit(W, w0=w0, v0=v0, F=F, dt=dt,
                                                                 basis=Phi)
            err = rel_err(model.predict(v0=v_new), W_new)
            if scaling == "ratio":
                assert err < 1e-9
            else:
                fd_err[dt] = err
    assert fd_err[0.01] > 0.05
    assert fd_err[0.002] < 0.2 * fd_err[0.01]


def test_predict_parts_superpose_and_shorter_force():
    mc = mixed_case("coupled")
    model = _fit(mc, n_modes=3)
    total = model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new)
    parts = model.predict(w0=mc.w0_new) + model.predict(v0=mc.v0_new) + model.predict(F=mc.F_new)
    np.testing.assert_allclose(total, parts, atol=1e-12 * np.abs(total).max())
    short = model.predict(w0=mc.w0_new, F=mc.F_new[:, :30])
    assert short.shape == (D, 30)
    np.testing.assert_allclose(short, model.predict(w0=mc.w0_new, F=mc.F_new)[:, :30],
                               atol=1e-12 * np.abs(total).max())


def test_default_w0_is_first_column():
    mc = mixed_case("coupled")
    a = MixedResponse(n_modes=3).fit(mc.W, v0=mc.v0, F=mc.F, dt=mc.dt)
    b = _fit(mc, n_modes=3)
    np.testing.assert_allclose(a.predict(w0=mc.w0_new), b.predict(w0=mc.w0_new), rtol=1e-12)


@pytest.mark.parametrize("solver", ["ls", "tls"])
def test_solvers_agree_on_clean_data(solver):
    mc = mixed_case("ideal")
    errs = _parts(_fit(mc, basis=eigenmodes(mc.M, mc.K), solver=solver), mc)
    assert max(errs.values()) < 1e-8, errs
