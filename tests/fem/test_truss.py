"""The §4.2 satellite truss: sizes, definiteness, rigid-body kinematics, fracture."""

import numpy as np
import pytest
import scipy.linalg

from podbench.errors import InputError
from podbench.fem import load_structure
from podbench.fem.truss import (
    dissertation_dof_element,
    element_members,
    face_dof,
    satellite_truss,
    truss_dof,
)

# Table 4.1, converted here independently of the package
FT = 12.0
A_SIDE = B_BAY = 9.8 * FT
RHO = 112.3 / 1728.0 / (9.80665 / 0.0254)  # lbf·s²/in⁴
E = 1.0e7


def tube(D, t):
    return np.pi / 4 * (D**2 - (D - 2 * t) ** 2)


A_LON, A_BAT, A_DIA = tube(3.0, 0.04), tube(1.0, 0.02), tube(1.0, 0.02)
L_DIA = np.hypot(A_SIDE, B_BAY)


@pytest.fixture(scope="module")
def truss():
    return load_structure("satellite_truss")


@pytest.fixture(scope="module")
def free_truss():
    return satellite_truss(supports="free", fracture_element=None)


def x_faces(n_faces=101):
    return np.arange(n_faces) * B_BAY


def rigid_vectors(truss_structure, faces, pivot_x, *, rotation=True):
    """Generalized coordinates of a rigid rotation about X3 through (pivot_x, centroid) of
    the given faces (others zero), or of a unit X2 translation."""
    q = np.zeros(truss_structure.n_dofs)
    coords = truss_structure.metadata["free_coordinates"]
    for dof, c in enumerate(coords):
        f, k = divmod(int(c), 3)
        if f not in faces:
            continue
        x = f * B_BAY
        if rotation:
            q[dof] = 1.0 if k == 2 else x - pivot_x
        else:
            q[dof] = 0.0 if k == 2 else 1.0
    return q


def test_sizes_and_labels(truss):
    assert (truss.n_dofs, truss.n_sensors) == (299, 299)
    np.testing.assert_array_equal(truss.sensor_dofs, np.arange(299))
    assert truss.dof_labels[0] == "face0.theta" and truss.dof_labels[-1] == "face100.theta"
    assert truss.dof_labels[truss_dof(23, "d2")] == "face44.d_bot"
    assert truss_dof(23, "d2") == 131 and truss_dof(1, "theta1") == 0
    assert truss_dof(50, "theta3") == 298
    assert face_dof(44, "d_bot") == 131
    with pytest.raises(InputError, match="pinned"):
        truss_dof(1, "d2")
    with pytest.raises(InputError, match="element"):
        truss_dof(51, "d2")
    # the dissertation's printed DOF numbers name these elements
    for dof, e in ((140, 23), (50, 8), (80, 13), (200, 33), (290, 48), (56, 9), (20, 3)):
        assert dissertation_dof_element(dof) == e
    assert truss.sensor_positions[131] == pytest.approx(44 * B_BAY)


def test_element_has_21_members_of_table_4_1():
    members = element_members()
    groups = [m.group for m in members]
    assert len(members) == 21
    assert (groups.count("longeron"), groups.count("batten"), groups.count("diagonal")) == (
        6, 9, 6)
    s = satellite_truss(n_elements=1, fracture_element=None)
    for row in s.metadata["members"]:
        expected = {"longeron": B_BAY, "batten": A_SIDE, "diagonal": L_DIA}[row["group"]]
        assert row["length"] == pytest.approx(expected, rel=1e-12)
    assert L_DIA / FT == pytest.approx(13.9, abs=0.05)  # Table 4.1's rounded 13.9 ft


def test_matrices_symmetric_and_definite(truss):
    K, M = truss.K.toarray(), truss.M.toarray()
    assert abs(K - K.T).max() == 0.0 and abs(M - M.T).max() == 0.0
    scipy.linalg.cholesky(M)  # raises if M is not positive definite
    scipy.linalg.cholesky(K)  # pinned intact truss: no mechanism
    assert truss.C is None


def test_rigid_translation_kinetic_energy_equals_member_mass(free_truss):
    # Σ ρ A L over 50 x 21 members, from Table 4.1 directly
    per_element = RHO * (6 * A_LON * B_BAY + 9 * A_BAT * A_SIDE + 6 * A_DIA * L_DIA)
    total = 50 * per_element
    v = rigid_vectors(free_truss, range(101), 0.0, rotation=False)
    assert 0.5 * v @ (free_truss.M @ v) == pytest.approx(0.5 * total, rel=1e-12)
    assert free_truss.metadata["member_mass"] == pytest.approx(total, rel=1e-12)


def test_free_truss_has_exactly_two_rigid_modes(free_truss):
    K = free_truss.K.toarray()
    assert free_truss.n_dofs == 303
    # ω² of K φ = ω² M φ (rad²/s²): rigid modes ~1e-10, the first flexible one ~2
    w2 = scipy.linalg.eigh(K, free_truss.M.toarray(), eigvals_only=True,
                           subset_by_index=[0, 4])
    assert np.sum(np.abs(w2) < 1e-6) == 2 and w2[2] > 1.0
    for q in (rigid_vectors(free_truss, range(101), 0.0, rotation=False),
              rigid_vectors(free_truss, range(101), 1234.5)):
        assert np.linalg.norm(K @ q) < 1e-9 * np.linalg.norm(K, 2) * np.linalg.norm(q)


def test_first_frequency_matches_equivalent_beam(truss):
    # simply supported beam with the longerons' bending stiffness and the members' mass
    y_t, y_b = A_SIDE / np.sqrt(3), -A_SIDE / (2 * np.sqrt(3))
    EI = E * A_LON * (y_t**2 + 2 * y_b**2)
    m = 50 * RHO * (6 * A_LON * B_BAY + 9 * A_BAT * A_SIDE + 6 * A_DIA * L_DIA) / (100 * B_BAY)
    L = 100 * B_BAY
    f_beam = np.pi / (2 * L**2) * np.sqrt(EI / m)
    assert truss.natural_frequencies(1)[0] == pytest.approx(f_beam, rel=0.01)


def test_fracture_of_element_10(truss):
    (ev,) = truss.events
    assert ev.time == 3.0
    K0 = truss.stiffness(2.9).toarray()
    K1 = truss.stiffness(3.0).toarray()
    np.testing.assert_array_equal(K0, truss.K.toarray())
    # only element 10's coordinates (faces 18, 19, 20) change
    changed = np.flatnonzero(np.abs(K1 - K0).sum(axis=0))
    faces = {int(c) // 3 for c in truss.metadata["free_coordinates"][changed]}
    assert faces == {18, 19, 20}
    # the mass is unchanged by the event
    assert truss.mass(5.0) is truss.M

    left = rigid_vectors(truss, range(0, 19), 0.0)          # about the left pin
    right = rigid_vectors(truss, range(20, 101), 100 * B_BAY)  # about the right pin
    orphan = np.zeros((truss.n_dofs, 3))
    for k, name in enumerate(("d_top", "d_bot", "theta")):
        orphan[face_dof(19, name), k] = 1.0
    basis = np.column_stack([left, right, orphan])
    scale = np.abs(K1).max()
    for q in basis.T:
        assert np.linalg.norm(K1 @ q) < 1e-9 * scale * np.linalg.norm(q)
        # ... and none of them is a zero-energy motion of the intact truss
        assert np.linalg.norm(K0 @ q) > 1e6 * np.linalg.norm(K1 @ q)

    w2, vec = scipy.linalg.eigh(K1, truss.M.toarray(), subset_by_index=[0, 7])  # ω², rad²/s²
    zero = np.abs(w2) < 1e-6
    assert zero.sum() == 5  # two rigid rotations + the orphaned middle face of element 10
    assert w2[5] > 1.0
    # the null space is exactly span{left rotation, right rotation, face-19 coordinates}
    Q, _ = np.linalg.qr(basis)
    N = vec[:, zero]
    np.testing.assert_allclose(Q @ (Q.T @ N), N, atol=1e-8)

    f = truss.natural_frequencies(6, t=3.0)
    assert np.all(f[:5] < 1e-4) and f[5] > 0.1


def test_no_fracture_option_and_bad_arguments():
    s = satellite_truss(fracture_element=None)
    assert s.is_time_invariant
    with pytest.raises(InputError, match="fracture_element"):
        satellite_truss(fracture_element=51)
    with pytest.raises(InputError, match="supports"):
        satellite_truss(supports="clamped")


def test_build_is_deterministic(truss):
    again = load_structure("satellite_truss")
    np.testing.assert_array_equal(again.K.toarray(), truss.K.toarray())
    np.testing.assert_array_equal(again.M.toarray(), truss.M.toarray())
    np.testing.assert_array_equal(again.events[0].delta_K.toarray(),
                                  truss.events[0].delta_K.toarray())
