"""POVR and MDS (§3.2) against an independent Newmark truth (``_truth``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from podbench import Record
from podbench.sysid.methods import MDS, POVR
from podbench.sysid.pod import snapshot_svd

from ._cases import D, free_case
from ._contract import MethodContract
from ._truth import eigenmodes, newmark, rel_err

EXCITATIONS = ("displacement", "velocity")
X0 = {"displacement": "w0", "velocity": "v0"}


def _povr_case(excitation):
    fc = free_case("coupled", excitation)
    return SimpleNamespace(
        params=dict(n_modes=3, excitation=excitation),
        fit=lambda model, basis=None: model.fit(fc.W[0], fc.x0[0], basis=basis),
        predict_train=lambda model: [(model.predict(fc.x0[0]), fc.W[0])],
        predict_new=lambda model: model.predict(fc.x0_new),
        bad_param=("excitation", "acceleration") if excitation == "displacement"
        else ("tol", 2.0),
        records=[Record(W=fc.W[0], **{X0[excitation]: fc.x0[0]})],
        target=Record(W=np.zeros_like(fc.W[0]), **{X0[excitation]: fc.x0_new}),
    )


def _mds_case(excitation):
    fc = free_case("coupled", excitation)
    return SimpleNamespace(
        params=dict(excitation=excitation, n_modes=3),
        fit=lambda model, basis=None: model.fit(fc.W[:3], fc.x0[:3], basis=basis),
        predict_train=lambda model: [(model.predict(fc.x0[j]), fc.W[j]) for j in range(3)],
        predict_new=lambda model: model.predict(fc.x0_new),
        bad_param=("max_cond", 0.5),
        records=[Record(W=fc.W[j], **{X0[excitation]: fc.x0[j]}) for j in range(3)],
        target=Record(W=np.zeros_like(fc.W[0]), **{X0[excitation]: fc.x0_new}),
    )


class TestPOVRDisplacementContract(MethodContract):
    method = POVR

    def case(self):
        return _povr_case("displacement")


class TestPOVRVelocityContract(MethodContract):
    method = POVR

    def case(self):
        return _povr_case("velocity")


class TestMDSDisplacementContract(MethodContract):
    method = MDS

    def case(self):
        return _mds_case("displacement")


class TestMDSVelocityContract(MethodContract):
    method = MDS

    def case(self):
        return _mds_case("velocity")


# ------------------------------------------------------------------------- POVR
@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_povr_is_eq_3_13_and_3_17(excitation):
    """The new POVs equal a transcription of the dissertation's formulas (and MATLAB)."""
    fc = free_case("coupled", excitation)
    k = 3
    U, s, Vt = np.linalg.svd(fc.W[0], full_matrices=False)
    U, s, V = U[:, :k], s[:k], Vt[:k].T
    if excitation == "displacement":
        s_new = (U.T @ fc.x0_new) / V[0]  # Eq. 3.13
    else:
        vdot0 = (U.T @ fc.x0[0]) / s  # Eq. 3.18
        s_new = (U.T @ fc.x0_new) / vdot0  # Eq. 3.17
    model = POVR(n_modes=k, excitation=excitation).fit(fc.W[0], fc.x0[0])
    # POVs are sign-invariant (the sign of u_j and v_j flips together)
    np.testing.assert_allclose(model.new_povs(fc.x0_new), s_new, rtol=1e-10)
    np.testing.assert_allclose(model.predict(fc.x0_new), U @ np.diag(s_new) @ V.T, atol=1e-14)


def test_povr_displacement_default_profile_is_first_column():
    fc = free_case("coupled", "displacement")
    a = POVR(n_modes=3).fit(fc.W[0]).predict(fc.x0_new)
    b = POVR(n_modes=3).fit(fc.W[0], fc.x0[0]).predict(fc.x0_new)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-16)


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_povr_phi_is_diagonal_and_starts_at_identity_or_zero(excitation):
    fc = free_case("coupled", excitation)
    model = POVR(n_modes=3, excitation=excitation).fit(fc.W[0], fc.x0[0])
    Phi = model.Phi_
    assert Phi.shape == (fc.n, 3, 3)
    off = Phi - np.einsum("ijj->ij", Phi)[:, :, None] * np.eye(3)
    assert np.all(off == 0)
    # Φ11(0) = I (the state starts at w0); Φ12(0) = 0 (no displacement at t = 0)
    np.testing.assert_allclose(Phi[0], np.eye(3) if excitation == "displacement" else 0,
                               atol=1e-12)


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_povr_is_not_exact_on_the_coupled_chain(excitation):
    """k = m (no projection error): what remains is POVR's diagonalization error.

    Measured (relative Frobenius error, each of the 5 training responses):
    displacement 0.18 0.74 0.42 0.37 0.45; velocity 0.18 12.9 0.10 0.14 0.22.
    """
    fc = free_case("coupled", excitation)
    errs = [rel_err(POVR(n_modes=D, excitation=excitation).fit(W, x).predict(fc.x0_new),
                    fc.W_new) for W, x in zip(fc.W, fc.x0, strict=True)]
    assert min(errs) > 5e-2
    assert np.median(errs) > 0.1


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_povr_is_close_on_the_ideal_chain(excitation):
    """Identity mass, light Rayleigh damping, 18 slowest periods: POMs ≈ eigenmodes.

    Measured: displacement 0.016 0.113 0.048 0.012 0.017 (median 0.017); velocity 0.0071
    0.119 0.0031 0.0028 0.0059 (median 0.0059). The outlier is training set 2, whose
    initial condition barely excites one mode, so its POM is poorly resolved.
    """
    fc = free_case("ideal", excitation)
    errs = [rel_err(POVR(n_modes=D, excitation=excitation).fit(W, x).predict(fc.x0_new),
                    fc.W_new) for W, x in zip(fc.W, fc.x0, strict=True)]
    assert np.median(errs) < 5e-2


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_povr_is_exact_in_the_eigenmode_basis_of_the_ideal_chain(excitation):
    """With the eigenmodes as basis Φ11/Φ12 are exactly diagonal (Newmark decouples too)."""
    fc = free_case("ideal", excitation)
    basis = eigenmodes(fc.M, fc.K)  # orthonormal because M = I
    model = POVR(excitation=excitation).fit(fc.W[0], fc.x0[0], basis=basis)
    assert rel_err(model.predict(fc.x0_new), fc.W_new) < 1e-9


# ------------------------------------------------------------------------- MDS
@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_mds_is_exact_on_the_coupled_chain(excitation):
    """k = m = 5 independent data sets: no projection and no diagonalization error.

    Measured: 3e-15 (displacement), 2e-14 (velocity).
    """
    fc = free_case("coupled", excitation)
    model = MDS(excitation=excitation).fit(fc.W, fc.x0)
    assert model.n_modes_ == D
    assert rel_err(model.predict(fc.x0_new), fc.W_new) < 1e-9


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_mds_phi_at_time_zero(excitation):
    """Φ11(0) = I and Φ12(0) = 0 (Eqs. 3.26, 3.30 at t = 0)."""
    fc = free_case("coupled", excitation)
    model = MDS(excitation=excitation).fit(fc.W, fc.x0)
    assert model.Phi_.shape == (fc.n, D, D)
    np.testing.assert_allclose(model.Phi_[0], np.eye(D) if excitation == "displacement" else 0,
                               atol=1e-10)


def test_mds_is_the_matlab_icresp_disp_multi():
    """Transcription of the appendix's icresp_disp_multi (Φ11 per step with inv(V0))."""
    fc = free_case("coupled", "displacement")
    k = 3
    U = np.linalg.svd(fc.W[0], full_matrices=False)[0][:, :k]
    Vold = [U.T @ W for W in fc.W[:k]]
    V0 = np.column_stack([V[:, 0] for V in Vold])
    V0new = U.T @ fc.x0_new
    Vnew = np.column_stack(
        [np.column_stack([V[:, j] for V in Vold]) @ np.linalg.inv(V0) @ V0new
         for j in range(fc.n)]
    )
    expected = U @ Vnew
    got = MDS(n_modes=k).fit(fc.W[:k]).predict(fc.x0_new)
    np.testing.assert_allclose(got, expected, atol=1e-10 * np.abs(expected).max())


def test_mds_with_more_data_sets_than_modes_stays_exact_on_consistent_data():
    fc = free_case("coupled", "displacement")
    rng = np.random.default_rng(5)
    x_extra = 0.01 * rng.standard_normal(D)
    W_extra = newmark(fc.M, fc.C, fc.K, fc.dt, fc.n, w0=x_extra)[0]
    model = MDS(n_modes=D).fit(fc.W + [fc.W_new], fc.x0 + [fc.x0_new])
    assert rel_err(model.predict(x_extra), W_extra) < 1e-9


def test_mds_twin_in_povr_basis_removes_the_diagonalization_error():
    """Harness usage: MDS in POVR's basis isolates POVR's diagonalization error (k = m)."""
    fc = free_case("coupled", "displacement")
    povr = POVR(n_modes=D).fit(fc.W[0], fc.x0[0])
    twin = MDS().fit(fc.W, fc.x0, basis=povr.modes_)
    assert rel_err(twin.predict(fc.x0_new), fc.W_new) < 1e-9
    assert rel_err(povr.predict(fc.x0_new), fc.W_new) > 0.1


def _random_system(rng, d):
    A = rng.standard_normal((d, d))
    M = A @ A.T + d * np.eye(d)
    B = rng.standard_normal((d, d))
    K = 1e3 * (B @ B.T + 0.5 * d * np.eye(d))
    G = rng.standard_normal((d, d))
    C = 0.5 * (G @ G.T)  # arbitrary (non-proportional) PSD damping
    wmax = np.sqrt(np.max(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    return M, C, K, 0.3 / wmax


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.integers(2, 4),
       excitation=st.sampled_from(EXCITATIONS))
def test_mds_exact_for_random_lti_systems(seed, d, excitation):
    """Property: random SPD M, K, PSD C, k = m independent profiles → MDS exact."""
    rng = np.random.default_rng(seed)
    M, C, K, dt = _random_system(rng, d)
    key = "w0" if excitation == "displacement" else "v0"
    x0 = [rng.standard_normal(d) for _ in range(d + 1)]
    W = [newmark(M, C, K, dt, 40, **{key: x})[0] for x in x0]
    model = MDS(excitation=excitation).fit(W[:d], x0[:d])
    assert model.condition_number_ < 1e10
    assert rel_err(model.predict(x0[d]), W[d]) < 1e-6


def test_pocs_and_povs_are_the_svd_of_the_first_data_set():
    fc = free_case("coupled", "displacement")
    model = MDS(n_modes=3).fit(fc.W[:3])
    p = snapshot_svd(fc.W[0], 3)
    np.testing.assert_allclose(model.povs_, p.povs, rtol=1e-12)
    np.testing.assert_allclose(model.modes_, p.modes, atol=1e-12)
    np.testing.assert_allclose(model.pocs_, p.pocs, atol=1e-12)
