"""Base-excitation truth data: effective load, outputs, strain, exudyn cross-check, and ML
identified from base-excited acceleration records."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from podbench import load_structure
from podbench.core.iorecords import IORecord
from podbench.dynamics.base_excitation import beam_strain_matrix, ground_motion, simulate_base
from podbench.sysid.methods.inputs import MultipleLoadIO

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
        return IORecord(u=ag[None, :], y=y, dt=DT, input_units="in/s^2",
                        output_units="in/s^2", input_channels=("ground",),
                        output_channels=beam.sensor_labels, name=name)

    train, target = rec(train_ag, "pulse"), rec(test_ag, "burst")
    ml = MultipleLoadIO(n_lags=None, solver="block").fit([train])
    err = np.linalg.norm(ml.predict(target) - target.y) / np.linalg.norm(target.y)
    assert err < 1e-9
