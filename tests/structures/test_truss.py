"""The §4.2 satellite truss: sizes, definiteness, rigid-body kinematics, fracture."""

import numpy as np
import pytest
import scipy.linalg

from podbench.errors import InputError
from podbench.structures import load_structure
from podbench.structures.truss import (
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


@pytest.mark.heavy
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


def _assembled_without(truss_structure, skip):
    """K, M of the pinned truss assembled here from the element matrices, leaving out the
    1-based elements ``skip`` (independent of the package's assembly and event code)."""
    md = truss_structure.metadata
    n_coord = 3 * md["n_faces"]
    K = np.zeros((n_coord, n_coord))
    M = np.zeros((n_coord, n_coord))
    for e in range(md["n_elements"]):
        if e + 1 in skip:
            continue
        idx = np.arange(6 * e, 6 * e + 9)
        K[np.ix_(idx, idx)] += md["element_K"]
        M[np.ix_(idx, idx)] += md["element_M"]
    free = md["free_coordinates"]
    return K[np.ix_(free, free)], M[np.ix_(free, free)]


@pytest.mark.heavy
def test_fracture_of_element_10_removes_the_element(truss):
    """§4.2: "the 10th truss element breaks off and disappears" and "the remaining truss
    sections ... are free to exhibit rigid-body rotation around each pinned end": after the
    event exactly two zero-stiffness modes, the two rotations (the old model, stiffness only,
    had five; it is kept as the variant tested below)."""
    (ev,) = truss.events
    assert ev.time == 3.0
    assert truss.metadata["fracture_model"] == "element"
    face19 = [face_dof(19, name) for name in ("d_top", "d_bot", "theta")]
    assert ev.removed_dofs == tuple(face19) == (55, 56, 57)
    np.testing.assert_array_equal(truss.removed_dofs(2.9), [])
    np.testing.assert_array_equal(truss.removed_dofs(3.0), face19)
    np.testing.assert_array_equal(truss.stiffness(2.9).toarray(), truss.K.toarray())
    np.testing.assert_array_equal(truss.mass(2.9).toarray(), truss.M.toarray())

    K1, M1, removed = truss.matrices_at((0,))
    K1, M1 = K1.toarray(), M1.toarray()
    keep = np.setdiff1d(np.arange(truss.n_dofs), removed)
    assert keep.size == 296
    # the remaining model is the truss assembled without element 10 (stiffness AND mass)
    K_ref, M_ref = _assembled_without(truss, {10})
    kk = np.ix_(keep, keep)
    np.testing.assert_allclose(K1[kk], K_ref[kk], rtol=0, atol=1e-9 * np.abs(K_ref).max())
    np.testing.assert_allclose(M1[kk], M_ref[kk], rtol=0, atol=1e-12 * np.abs(M_ref).max())
    # ... and without element 10 the face-19 coordinates carry nothing at all
    assert not np.any(K_ref[face19]) and not np.any(M_ref[face19])
    # removed coordinates: decoupled (no stiffness, placeholder mass on the diagonal only)
    assert not np.any(K1[face19]) and not np.any(K1[:, face19])
    np.testing.assert_array_equal(M1[np.ix_(face19, face19)],
                                  np.diag(truss.M.diagonal()[face19]))
    assert not np.any(M1[np.ix_(keep, face19)])

    Kr, Mr = K1[kk], M1[kk]
    assert np.linalg.eigvalsh(Mr).min() > 0  # the remaining mass is positive definite
    w2, vec = scipy.linalg.eigh(Kr, Mr, subset_by_index=[0, 5])  # ω², rad²/s²
    zero = np.abs(w2) < 1e-6
    assert zero.sum() == 2  # exactly the two rigid rotations (measured |ω²| < 1e-9)
    assert w2[2] > 1.0      # next: 0.266 Hz, ω² = 2.80
    left = rigid_vectors(truss, range(0, 19), 0.0)[keep]            # about the left pin
    right = rigid_vectors(truss, range(20, 101), 100 * B_BAY)[keep]  # about the right pin
    basis = np.column_stack([left, right])
    scale = np.abs(Kr).max()
    for q in basis.T:
        assert np.linalg.norm(Kr @ q) < 1e-9 * scale * np.linalg.norm(q)
        assert np.linalg.norm(K_ref[kk] @ q) < 1e-9 * scale * np.linalg.norm(q)
        assert np.linalg.norm(truss.K.toarray()[kk] @ q) > 1e3 * np.linalg.norm(Kr @ q)
    Q, _ = np.linalg.qr(basis)
    N = vec[:, zero]
    np.testing.assert_allclose(Q @ (Q.T @ N), N, atol=1e-8)

    f = truss.natural_frequencies(4, t=3.0)  # on the remaining coordinates
    assert np.all(f[:2] < 1e-4) and f[2] == pytest.approx(0.2663, abs=5e-4)


def test_stiffness_only_variant_keeps_the_mass_and_five_zero_modes():
    """The variant structures/satellite_truss_stiffness_only.toml (the literal first clause:
    only the element's stiffness is removed): its mass and middle face stay, K has five zero
    eigenvalues (two rotations + the orphaned face 19's three coordinates)."""
    truss = load_structure("satellite_truss_stiffness_only")
    (ev,) = truss.events
    assert ev.time == 3.0 and ev.delta_M is None and ev.removed_dofs == ()
    assert truss.metadata["fracture_model"] == "stiffness_only"
    K0 = truss.stiffness(2.9).toarray()
    K1 = truss.stiffness(3.0).toarray()
    np.testing.assert_array_equal(K0, truss.K.toarray())
    K_ref, _ = _assembled_without(truss, {10})
    np.testing.assert_allclose(K1, K_ref, rtol=0, atol=1e-9 * np.abs(K_ref).max())
    # only element 10's coordinates (faces 18, 19, 20) change
    changed = np.flatnonzero(np.abs(K1 - K0).sum(axis=0))
    faces = {int(c) // 3 for c in truss.metadata["free_coordinates"][changed]}
    assert faces == {18, 19, 20}
    # the mass is unchanged by the event
    np.testing.assert_array_equal(truss.mass(5.0).toarray(), truss.M.toarray())

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


@pytest.mark.parametrize(("element", "faces"), [(1, [0, 1]), (50, [99, 100])])
def test_end_element_fracture_also_removes_the_end_face_rotation(element, faces):
    """The first/last element alone holds its end face's rotation (the pinned face's
    d_top, d_bot are not DOFs): it leaves with the element, and the remaining truss keeps one
    rigid rotation (the part still pinned at the other end)."""
    s = satellite_truss(fracture_element=element)
    removed = s.events[0].removed_dofs
    labels = [s.dof_labels[d] for d in removed]
    assert sorted({int(lab[4:lab.index(".")]) for lab in labels}) == faces
    assert len(removed) == 4  # the middle face (3) + the end face's rotation (1)
    f = s.natural_frequencies(3, t=3.0)
    assert f[0] < 1e-4 and f[1] > 1e-2

def test_no_fracture_option_and_bad_arguments():
    s = satellite_truss(fracture_element=None)
    assert s.is_time_invariant
    with pytest.raises(InputError, match="fracture_element"):
        satellite_truss(fracture_element=51)
    with pytest.raises(InputError, match="supports"):
        satellite_truss(supports="clamped")
    with pytest.raises(InputError, match="fracture_model"):
        satellite_truss(fracture_model="mass_only")


def test_build_is_deterministic(truss):
    again = load_structure("satellite_truss")
    np.testing.assert_array_equal(again.K.toarray(), truss.K.toarray())
    np.testing.assert_array_equal(again.M.toarray(), truss.M.toarray())
    np.testing.assert_array_equal(again.events[0].delta_K.toarray(),
                                  truss.events[0].delta_K.toarray())
    np.testing.assert_array_equal(again.events[0].delta_M.toarray(),
                                  truss.events[0].delta_M.toarray())
