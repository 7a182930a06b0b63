"""``simulate``: the Response it returns, determinism and input checks."""

import numpy as np
import pytest
from dynamics_systems import cantilever, chain

from podbench.core.response import Response
from podbench.dynamics import newmark, simulate
from podbench.dynamics.excitations import ForceHistory, Pulse
from podbench.errors import DimensionError, InputError, UnknownNameError


def test_response_holds_sensor_samples_of_the_dof_histories():
    s = cantilever()
    rng = np.random.default_rng(0)
    q0 = np.linalg.solve(s.K.toarray(), rng.normal(size=s.n_dofs))
    v0 = rng.normal(size=s.n_dofs)
    r = simulate(s, n_samples=50, dt=1e-4, initial_displacement=q0, initial_velocity=v0,
                 force=Pulse(23.0, 500.0, 5e-4), label="w0+pulse")
    assert isinstance(r, Response)
    assert r.W.shape == r.F.shape == (25, 50) and r.q.shape == r.qd.shape == (48, 50)
    np.testing.assert_array_equal(r.t, np.arange(50) * 1e-4)
    np.testing.assert_array_equal(r.W[0], 0.0)  # clamped root sensor
    np.testing.assert_array_equal(r.W[1:], r.q[0::2])  # sensors read the w DOFs
    np.testing.assert_array_equal(r.W[:, 0], s.observe(q0))
    np.testing.assert_array_equal(r.w0, s.observe(q0))
    np.testing.assert_array_equal(r.v0, s.observe(v0))
    assert (r.structure, r.engine, r.label) == ("lti_beam", "newmark", "w0+pulse")
    assert r.dt == 1e-4
    # the force acts on the sensor's DOF: same result as passing the DOF loads to newmark
    ref = newmark(s, q0, v0, s.to_dofs(r.F), 1e-4)
    np.testing.assert_array_equal(r.q, ref.q)
    np.testing.assert_array_equal(r.F[23, 1:6], 500.0)


def test_force_array_and_force_history_object_are_equivalent():
    s = chain(4)
    F = np.random.default_rng(1).normal(size=(4, 30))
    a = simulate(s, 30, 0.01, force=F)
    b = simulate(s, 30, 0.01, force=ForceHistory(F))
    np.testing.assert_array_equal(a.W, b.W)


def test_zero_excitation_stays_at_rest():
    r = simulate(chain(3), 10, 0.01)
    np.testing.assert_array_equal(r.W, 0.0)


def test_same_call_gives_bit_identical_arrays():
    s = cantilever()
    q0 = np.linalg.solve(s.K.toarray(), np.ones(s.n_dofs))
    a = simulate(s, 100, 1e-4, initial_displacement=q0, force=Pulse(11.0, 500.0, 5e-4))
    b = simulate(s, 100, 1e-4, initial_displacement=q0, force=Pulse(11.0, 500.0, 5e-4))
    np.testing.assert_array_equal(a.W, b.W)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.qd, b.qd)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"engine": "rk4"}, UnknownNameError, "unknown engine 'rk4'"),
        ({"n_samples": 1}, InputError, "n_samples.*at least 2"),
        ({"n_samples": 2.5}, InputError, "n_samples.*integer"),
        ({"dt": 0.0}, InputError, "dt.*positive"),
        ({"dt": -1e-3}, InputError, "dt.*positive"),
        ({"dt": float("nan")}, InputError, "dt.*finite"),
        ({"initial_displacement": np.zeros(3)}, DimensionError,
         r"initial_displacement.*\(4,\).*\(3,\)"),
        ({"initial_velocity": np.full(4, np.inf)}, InputError, "initial_velocity.*NaN or Inf"),
        ({"force": np.zeros((4, 9))}, DimensionError, r"force.*\(4, 10\).*\(4, 9\)"),
        ({"force": np.zeros(10)}, DimensionError, "force.*2-D"),
        ({"force": np.full((4, 10), np.nan)}, InputError, "force.*NaN"),
        ({"force": ForceHistory(np.zeros((3, 10)))}, DimensionError, r"\(4, 10\).*\(3, 10\)"),
    ],
)
def test_bad_inputs_raise_podbench_errors(kwargs, error, match):
    args = {"n_samples": 10, "dt": 0.01, **kwargs}
    with pytest.raises(error, match=match):
        simulate(chain(4), **args)


def test_structure_must_be_a_structure():
    with pytest.raises(InputError, match="structure.*Structure"):
        simulate({"M": 1}, 10, 0.01)
