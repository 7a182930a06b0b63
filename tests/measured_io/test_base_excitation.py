"""Base-excitation truth data: effective load, outputs, strain, exudyn cross-check, and ML
identified from base-excited acceleration records."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from podbench import load_structure
from podbench.core.records import Record
from podbench.dynamics.base_excitation import (
    beam_strain_matrix,
    ground_motion,
    influence_vector,
    simulate_base,
)
from podbench.structures.truss import (
    element_members,
    face_dof,
    member_strain_matrix,
    satellite_truss,
)
from podbench.sysid.methods import MultipleLoad


def measured_ml(**kw):
    """ML on measured inputs with the lag rule (the former ``MultipleLoadIO``'s defaults)."""
    return MultipleLoad(**{"inputs": "measured", "n_lags": "auto", "solver": "ls", **kw})


DT = 1e-4


@pytest.fixture(scope="module")
def beam():
    return load_structure("lti_beam")


def test_strain_from_shape_functions_is_exact_for_a_tip_load(beam):
    """A tip load P bends the cantilever into a cubic, which Hermite elements hold
    exactly: κ(x) = P (L − x)/EI, surface strain −c κ at any point, not only nodes."""
    P, c = 10.0, 0.375
    f = np.zeros(beam.n_dofs)
    f[beam.metadata["tip_dof"]] = P
    q = spla.spsolve(beam.K.tocsc(), f)
    x = np.array([0.0, 0.3, 5.5, 12.0, 17.25, 23.9, 24.0])
    expected = -c * P * (24.0 - x) / beam.metadata["EI"]
    np.testing.assert_allclose(beam_strain_matrix(beam, x, c) @ q, expected, rtol=1e-9,
                               atol=1e-12 * np.abs(expected).max())


def test_ground_motion_integrates_a_constant_acceleration_exactly():
    vg, ug = ground_motion(np.full(11, 2.0), 0.1)
    t = np.arange(11) * 0.1
    np.testing.assert_allclose(vg, 2.0 * t, atol=1e-14)
    np.testing.assert_allclose(ug, t**2, atol=1e-14)


def test_rigid_structure_limit_absolute_equals_base(beam):
    """The relative response is driven by −M r ü_g; absolute = relative + base motion,
    and at the clamp the absolute acceleration is the base acceleration itself."""
    ag = np.sin(np.arange(300) * DT * 2 * np.pi * 20.0) * 386.0
    out = simulate_base(beam, ag, DT, outputs=("absolute_acceleration",
                                               "absolute_displacement",
                                               "relative_displacement"))
    np.testing.assert_array_equal(out["absolute_acceleration"][0], ag)
    _, ug = ground_motion(ag, DT)
    np.testing.assert_allclose(out["absolute_displacement"] - out["relative_displacement"],
                               np.broadcast_to(ug, out["relative_displacement"].shape),
                               atol=1e-15)


def test_exudyn_cross_check(beam):
    pytest.importorskip("exudyn")
    t = np.arange(400) * DT
    ag = 386.0 * np.where(t < 0.005, np.sin(np.pi * t / 0.005), 0.0)
    a = simulate_base(beam, ag, DT, outputs=("relative_displacement",))
    b = simulate_base(beam, ag, DT, outputs=("relative_displacement",), engine="exudyn")
    rel = np.linalg.norm(a["relative_displacement"] - b["relative_displacement"]) / \
        np.linalg.norm(a["relative_displacement"])
    assert rel < 1e-6


def test_ml_from_base_excited_acceleration_records_is_exact(beam):
    """One base-excited record (ü_g a decaying pulse from sample 1: with Newmark truth a
    nonzero first sample enters through the initial acceleration and is not a causal
    convolution, DESIGN's sampling convention), outputs the
    absolute accelerations at the 25 sensors: ML's kernel over the whole record (k = 25,
    'block') predicts a held-out base-excited response to round-off — as forced ML does on
    the LTI beam (< 1e-9, tests/methods/test_forced_methods.py)."""
    n = 400
    t = np.arange(n) * DT
    train_ag = np.concatenate([[0.0], 386.0 * 0.7 ** np.arange(n - 1)])
    test_ag = 386.0 * np.sin(2 * np.pi * 150 * t) * np.exp(-t / 0.01)

    def rec(ag, name):
        y = simulate_base(beam, ag, DT)["absolute_acceleration"]
        return Record(u=ag[None, :], y=y, dt=DT, input_units="in/s^2",
                        output_units="in/s^2", input_channels=("ground",),
                        output_channels=beam.sensor_labels, name=name)

    train, target = rec(train_ag, "pulse"), rec(test_ag, "burst")
    ml = measured_ml(n_lags=None, solver="block").fit([train])
    err = np.linalg.norm(ml.predict(target) - target.y) / np.linalg.norm(target.y)
    assert err < 1e-9


# ----------------------------------------------------------------------------- the truss
@pytest.fixture(scope="module")
def truss():
    return load_structure("satellite_truss")


def test_truss_influence_vector_is_a_rigid_motion():
    """On the unpinned truss (all 303 coordinates) the vertical rigid translation moves no
    member: K r = 0 to round-off and every member strain is zero."""
    free = satellite_truss(supports="free", fracture_element=None, n_elements=4)
    r = influence_vector(free)
    assert r.sum() == 2 * free.metadata["n_faces"]  # d_top and d_bot of every face
    assert np.abs(free.K @ r).max() < 1e-9 * abs(free.K).max()
    E = member_strain_matrix(free, [(e, "10") for e in range(1, 5)])
    np.testing.assert_allclose(E @ r, 0.0, atol=1e-15)


def test_truss_member_strain_by_hand_and_by_strain_energy(truss):
    """A unit X2 motion of element 1's middle-face top joint stretches the bay-1 diagonal
    10 (bottom joint of the left face → top of the middle face, length √(a² + b²)) by its
    X2 direction cosine: ε = (a√3/2)/(a² + b²) with a = b; longeron 1 (along X1) not at all.
    Summed over all members, EA·L·ε² is the strain energy 2·½qᵀKq."""
    a = truss.metadata["side"]
    q = np.zeros(truss.n_dofs)
    q[face_dof(1, "d_top")] = 1.0
    E = member_strain_matrix(truss, [(1, "10"), (1, "1")])
    np.testing.assert_allclose(E @ q, [a * np.sqrt(3) / 2 / (2 * a * a), 0.0], atol=1e-15)
    md = truss.metadata
    labels = [m.label for m in element_members(md["diagonal_pattern"])]
    n = md["n_elements"]
    Eall = member_strain_matrix(truss, [(e, lbl) for e in range(1, n + 1) for lbl in labels])
    eal = np.tile([row["EA/L"] * row["length"] ** 2 for row in md["members"]], n)
    q = np.random.default_rng(0).normal(size=truss.n_dofs)
    assert np.sum(eal * (Eall @ q) ** 2) == pytest.approx(q @ (truss.K @ q), rel=1e-12)


def test_truss_base_excitation_against_exudyn_across_the_fracture(truss):
    """A 0.1-g, 0.6-s half-sine of both pins, 10 s at 0.05 s (the fracture at 3 s inside):
    podbench's Newmark against exudyn's, relative displacement and member strain."""
    pytest.importorskip("exudyn")
    dt, n = 0.05, 200
    t = np.arange(n) * dt
    ag = 38.6 * np.where((t > dt / 2) & (t < 0.6 - dt / 2), np.sin(np.pi * t / 0.6), 0.0)
    members = [(10, "10"), (23, "1"), (38, "12")]
    kw = dict(outputs=("relative_displacement", "strain"), strain_members=members)
    a = simulate_base(truss, ag, dt, **kw)
    b = simulate_base(truss, ag, dt, engine="exudyn", **kw)
    for key in kw["outputs"]:
        rel = np.linalg.norm(a[key] - b[key]) / np.linalg.norm(a[key])
        assert rel < 1e-6, key
    start = truss.events[0].first_sample(dt)
    assert np.all(a["strain"][0, start:] == 0.0) and np.any(a["strain"][0, :start] != 0.0)
