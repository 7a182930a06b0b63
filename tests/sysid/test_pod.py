"""POD utilities (§2.3): SVD, method of snapshots, energy fractions, projection."""

from __future__ import annotations

import numpy as np
import pytest

from podbench.errors import DimensionError, InputError
from podbench.sysid.pod import (
    check_orthonormal,
    energy_fractions,
    method_of_snapshots,
    n_modes_for_energy,
    pod,
    project,
    projection_error,
    snapshot_svd,
)


def _separated(m, n, seed=0, decay=0.5):
    """A matrix with singular values 1, decay, decay², … (well separated spectrum)."""
    rng = np.random.default_rng(seed)
    r = min(m, n)
    U = np.linalg.qr(rng.standard_normal((m, r)))[0]
    V = np.linalg.qr(rng.standard_normal((n, r)))[0]
    s = decay ** np.arange(r)
    return (U * s) @ V.T, U, s, V


def test_svd_reconstructs_and_is_orthonormal():
    W, _, s, _ = _separated(7, 30)
    p = snapshot_svd(W)
    np.testing.assert_allclose((p.modes * p.povs) @ p.pocs.T, W, atol=1e-13)
    np.testing.assert_allclose(p.modes.T @ p.modes, np.eye(7), atol=1e-13)
    np.testing.assert_allclose(p.pocs.T @ p.pocs, np.eye(7), atol=1e-13)
    np.testing.assert_allclose(p.povs, s, rtol=1e-12)


def test_sign_convention_largest_entry_positive():
    W, *_ = _separated(6, 20, seed=3)
    for p in (snapshot_svd(W), snapshot_svd(-W)):
        idx = np.argmax(np.abs(p.modes), axis=0)
        assert np.all(p.modes[idx, np.arange(6)] > 0)
    # flipping W flips the POCs, not the POMs
    np.testing.assert_allclose(snapshot_svd(-W).modes, snapshot_svd(W).modes, atol=1e-13)


def test_method_of_snapshots_matches_svd_where_spectrum_separates():
    W, *_ = _separated(3000, 25, seed=1, decay=0.7)
    a, b = method_of_snapshots(W, 8), snapshot_svd(W, 8)
    np.testing.assert_allclose(a.povs, b.povs, rtol=1e-10)
    np.testing.assert_allclose(a.modes, b.modes, atol=1e-8)
    np.testing.assert_allclose(a.pocs, b.pocs, atol=1e-8)


def test_method_of_snapshots_never_forms_an_m_by_m_matrix():
    # an m × m float matrix here would need 8·(2e5)² bytes = 320 GB
    rng = np.random.default_rng(2)
    W = rng.standard_normal((200_000, 6))
    p = method_of_snapshots(W, 3)
    assert p.modes.shape == (200_000, 3)
    np.testing.assert_allclose(p.modes.T @ p.modes, np.eye(3), atol=1e-10)
    assert pod(W, 3).modes.shape == (200_000, 3)  # "auto" picks the method of snapshots


def test_method_of_snapshots_refuses_a_zero_mode():
    W = np.zeros((50, 4))
    W[0, 0] = 1.0
    with pytest.raises(InputError, match="zero proper orthogonal value"):
        method_of_snapshots(W, 2)


def test_energy_fractions_sigma_is_eq_2_3_and_sigma2_differs():
    s = np.array([3.0, 1.0])
    np.testing.assert_allclose(energy_fractions(s), [0.75, 0.25])
    np.testing.assert_allclose(energy_fractions(s, kind="sigma2"), [0.9, 0.1])
    with pytest.raises(InputError, match="kind"):
        energy_fractions(s, kind="sigma3")
    with pytest.raises(InputError, match="zero"):
        energy_fractions([0.0, 0.0])


def test_energy_of_a_pod_is_eq_2_3_by_hand():
    """Eq. 2.3 on a record with known POVs: W = U diag(4, 3, 1) Vᵀ (rotated), so the POVs are
    4, 3, 1 and ε = (4, 3, 1)/8 = 0.5, 0.375, 0.125 (two POMs: 87.5 %); the squared variant
    (16, 9, 1)/26 gives 96.2 % for two."""
    rng = np.random.default_rng(7)
    U, _ = np.linalg.qr(rng.standard_normal((6, 3)))
    V, _ = np.linalg.qr(rng.standard_normal((50, 3)))
    W = U @ np.diag([4.0, 3.0, 1.0]) @ V.T
    s = np.linalg.svd(W, compute_uv=False)[:3]
    np.testing.assert_allclose(energy_fractions(s), [0.5, 0.375, 0.125], rtol=1e-12)
    np.testing.assert_allclose(np.cumsum(energy_fractions(s))[1], 0.875, rtol=1e-12)
    np.testing.assert_allclose(energy_fractions(s, kind="sigma2"),
                               [16 / 26, 9 / 26, 1 / 26], rtol=1e-12)


def test_n_modes_for_energy_thresholds():
    s = np.array([6.0, 3.0, 1.0])  # sigma fractions 0.6 0.3 0.1
    assert n_modes_for_energy(s, 0.6) == 1
    assert n_modes_for_energy(s, 0.61) == 2
    assert n_modes_for_energy(s, 0.9) == 2
    assert n_modes_for_energy(s, 1.0) == 3
    # sigma² fractions 36/46, 9/46, 1/46: 0.9 is reached with two modes
    assert n_modes_for_energy(s, 0.97, kind="sigma2") == 2
    assert n_modes_for_energy(s, 0.97, kind="sigma") == 3
    with pytest.raises(InputError, match="threshold"):
        n_modes_for_energy(s, 1.5)


def test_project_and_projection_error():
    W, U, s, V = _separated(6, 40, seed=4)
    Uk = U[:, :2]
    np.testing.assert_allclose(project(W, Uk), Uk.T @ W)
    # the floor: the discarded singular values
    expected = np.sqrt(np.sum(s[2:] ** 2) / np.sum(s**2))
    assert projection_error(W, Uk) == pytest.approx(expected, rel=1e-10)
    assert projection_error(W, U) == pytest.approx(0.0, abs=1e-14)
    with pytest.raises(DimensionError, match="rows"):
        project(W, U[:5])


def test_check_orthonormal():
    Q = np.linalg.qr(np.random.default_rng(0).standard_normal((5, 3)))[0]
    assert check_orthonormal(Q, n_rows=5) is not None
    with pytest.raises(InputError, match="orthonormal"):
        check_orthonormal(2 * Q)
    with pytest.raises(DimensionError, match="rows"):
        check_orthonormal(Q, n_rows=4)
    with pytest.raises(InputError, match="NaN"):
        check_orthonormal(np.full((3, 2), np.nan))


def test_svd_rejects_bad_input():
    with pytest.raises(InputError, match="NaN or Inf"):
        snapshot_svd(np.array([[1.0, np.inf]]))
    with pytest.raises(DimensionError, match="2-D"):
        snapshot_svd(np.ones(3))
    with pytest.raises(InputError, match="n_modes"):
        snapshot_svd(np.ones((3, 4)), 4)
    with pytest.raises(InputError, match="method"):
        pod(np.ones((3, 4)), method="qr")
