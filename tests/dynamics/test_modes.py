"""The finite-element modes at the sensors against closed forms and scipy's eigensolver."""

import numpy as np
import pytest
import scipy.linalg

import podbench as pb
from podbench.core.modeshapes import mac, mpc, real_shapes
from podbench.dynamics.modes import fe_modes, newmark_poles, normal_modes, pom_normal_mac
from podbench.errors import InputError
from podbench.structures.chain import chain


def test_shape_conventions():
    rng = np.random.default_rng(0)
    phi = rng.normal(size=6)
    # a real shape seen at any phase and scale comes back as itself, max |component| = 1
    z = (2.5 - 1.1j) * phi
    back = real_shapes(z[:, None])[:, 0]
    top = np.argmax(np.abs(phi))
    np.testing.assert_allclose(back, phi / phi[top], rtol=1e-13, atol=1e-15)
    assert mpc(z[:, None])[0] == pytest.approx(1.0, abs=1e-13)
    # MAC: scale and phase invariant, 1 for the same shape, 0 for orthogonal ones
    Q = np.linalg.qr(rng.normal(size=(6, 3)))[0]
    np.testing.assert_allclose(mac(Q * np.array([2.0, -1j, 0.3]), Q), np.eye(3), atol=1e-14)
    # a shape with a 90° phase between two halves is not collinear
    assert mpc(np.array([[1.0, 1.0, 1j, 1j]]).T)[0] == pytest.approx(0.0, abs=1e-14)


def test_chain_ideal_matches_closed_form_frequencies_and_rayleigh_damping():
    """ω_k = 2√(k/m) sin((2k−1)π/22) for the fixed-free chain of 5 equal masses (its file),
    ζ_k = α/(2ω_k) + βω_k/2 for Rayleigh damping C = αM + βK."""
    s = pb.load_structure("chain_ideal")
    k_, m_, alpha, beta = 1000.0, 1.0, 0.1, 3.0e-4
    w = 2 * np.sqrt(k_ / m_) * np.sin((2 * np.arange(1, 6) - 1) * np.pi / 22)
    modes = fe_modes(s)
    np.testing.assert_allclose(modes.frequency_hz, w / (2 * np.pi), rtol=1e-12)
    np.testing.assert_allclose(modes.damping_ratio, alpha / (2 * w) + beta * w / 2, rtol=1e-10)
    normal = fe_modes(s, kind="normal")
    np.testing.assert_allclose(normal.damping_ratio, modes.damping_ratio, rtol=1e-10)
    # proportional damping: the complex shapes are the normal modes (MAC 1, MPC 1)
    np.testing.assert_allclose(np.diag(mac(modes.shapes, normal.shapes)), 1.0, atol=1e-12)
    np.testing.assert_allclose(mpc(modes.shapes), 1.0, atol=1e-12)
    table = modes.table()
    assert list(table.columns[:3]) == ["mode", "frequency_hz", "damping_ratio"]
    assert list(table.columns[3:]) == [f"shape:{i}" for i in range(5)]
    assert np.allclose(np.max(np.abs(table.iloc[:, 3:].to_numpy()), axis=1), 1.0)


def test_non_proportional_damping_against_scipy_state_space_eig():
    s = pb.load_structure("chain_coupled")
    M, K, C = s.M.toarray(), s.K.toarray(), s.C.toarray()
    n = M.shape[0]
    Ac = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K),
                                                   -np.linalg.solve(M, C)]])
    lam, V = scipy.linalg.eig(Ac)
    up = lam.imag > 0
    order = np.argsort(np.abs(lam[up]))
    lam, V = lam[up][order], V[:n, up][:, order]
    modes = fe_modes(s)
    np.testing.assert_allclose(modes.poles, lam, rtol=1e-10)
    np.testing.assert_allclose(np.diag(mac(modes.shapes, V)), 1.0, atol=1e-10)
    assert np.all(mpc(modes.shapes) < 1.0 - 1e-6)  # complex modes: the dashpots couple them
    # the band keeps the modes inside it
    band = fe_modes(s, band_hz=(10.0, 25.0))
    assert len(band) == 2 and np.all((band.frequency_hz >= 10) & (band.frequency_hz <= 25))


def test_newmark_poles_are_those_of_a_newmark_record():
    """A one-mass free decay simulated by podbench's Newmark obeys an exact two-term
    recurrence whose roots are the record's poles: ln z/Δt equals newmark_poles."""
    s = chain(1, masses=2.0, springs=5.0e3, rayleigh=(0.5, 1.0e-4))
    dt = 0.01  # f Δt ≈ 0.08: a visible period elongation
    r = pb.simulate(s, 200, dt, initial_displacement=np.array([0.1]))
    w = r.W[0]
    X = np.column_stack([w[1:-1], w[:-2]])
    a1, a2 = np.linalg.lstsq(X, w[2:], rcond=None)[0]
    z = np.roots([1.0, -a1, -a2])
    s_rec = np.log(z[z.imag > 0][0]) / dt
    truth = fe_modes(s, dt=dt)
    assert truth.poles[0] == pytest.approx(s_rec, rel=1e-9)
    assert newmark_poles(fe_modes(s).poles, dt)[0] == pytest.approx(s_rec, rel=1e-9)
    # the period elongation of the trapezoidal rule: f' = atan(π f Δt)/(π Δt) undamped
    # (ζ = 0.3 % here moves it by 1e-5 relative)
    f = fe_modes(s).frequency_hz[0]
    assert truth.frequency_hz[0] == pytest.approx(np.arctan(np.pi * f * dt) / (np.pi * dt),
                                                  rel=1e-4)


def test_time_varying_and_nonlinear_structures_are_marked():
    ltv = fe_modes(pb.load_structure("ltv_beam"), band_hz=(0, 300))
    assert any("time-varying" in n for n in ltv.notes)
    assert ltv.frequency_hz[0] == pytest.approx(
        pb.load_structure("ltv_beam").natural_frequencies(1)[0], rel=1e-7)
    nl = fe_modes(pb.load_structure("nl_beam"), kind="normal", band_hz=(0, 300))
    assert any("nonlinear" in n for n in nl.notes)
    assert nl.frequency_hz[0] == pytest.approx(
        pb.load_structure("nl_beam").linear_twin().natural_frequencies(1)[0], rel=1e-7)
    with pytest.raises(InputError, match="kind"):
        fe_modes(pb.load_structure("chain_ideal"), kind="modal")


def test_pom_normal_mac_is_one_for_identity_mass_and_not_otherwise():
    """§2.1: with M ∝ I the (Euclidean-orthonormal) POMs can equal the normal modes; the
    normal modes of a chain with M ∝ I are such a basis, those of the coupled chain (M not
    ∝ I) are not orthogonal, so an orthonormal basis cannot hold them all."""
    ideal = pb.load_structure("chain_ideal")
    _, Phi = normal_modes(ideal)
    U = Phi / np.linalg.norm(Phi, axis=0)
    np.testing.assert_allclose(U.T @ U, np.eye(5), atol=1e-12)
    table = pom_normal_mac(ideal, U[:, ::-1])  # ordered by energy, not by frequency
    assert table["mode"].tolist() == [5, 4, 3, 2, 1]
    np.testing.assert_allclose(table["mac"], 1.0, atol=1e-12)
    coupled = pb.load_structure("chain_coupled")
    _, Phi = normal_modes(coupled)
    Q = np.linalg.qr(Phi)[0]  # the closest orthonormal basis in order of the modes
    assert pom_normal_mac(coupled, Q)["mac"].min() < 0.99
    # POMs of a free decay of the ideal chain: the normal modes to 1e-3 in MAC
    r = pb.simulate(ideal, 2000, 0.01, initial_displacement=np.array([0.1, 0.3, -0.2, 0.4, 0.2]))
    Upod = np.linalg.svd(r.W, full_matrices=False)[0]
    assert pom_normal_mac(ideal, Upod)["mac"].min() > 0.999
    with pytest.raises(InputError, match="poms"):
        pom_normal_mac(ideal, np.ones((4, 2)))
