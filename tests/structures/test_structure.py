import numpy as np
import pytest
import scipy.sparse as sp

from podbench.errors import DimensionError, InputError
from podbench.structures import CubicSpring, StiffnessEvent, Structure


def _chain(n=3):
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tolil()
    K[n - 1, n - 1] = 1.0
    return Structure(name="c", M=sp.eye(n), K=K, sensor_dofs=np.arange(n))


def test_chain_frequencies_match_analytic():
    # fixed-free chain of unit masses and springs: w_j = 2 sin((2j-1)pi/(2(2n+1)))
    n = 3
    s = _chain(n)
    j = np.arange(1, n + 1)
    expected = 2 * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1))) / (2 * np.pi)
    np.testing.assert_allclose(s.natural_frequencies(n), expected, rtol=1e-12)


def test_sensor_maps_are_adjoint():
    s = Structure(name="c", M=sp.eye(3), K=sp.eye(3), sensor_dofs=np.array([-1, 2, 0]))
    q = np.array([1.0, 2.0, 3.0])
    f = np.array([5.0, 7.0, 11.0])
    np.testing.assert_allclose(s.observe(q), [0.0, 3.0, 1.0])
    # <S q, f> == <q, S^T f>
    assert s.observe(q) @ f == pytest.approx(q @ s.to_dofs(f))
    np.testing.assert_allclose(s.sensor_matrix() @ q, s.observe(q))


def test_event_timing_half_step_convention():
    s = _chain(3)
    dK = -sp.csr_matrix(s.K)
    s2 = Structure(name="c", M=s.M, K=s.K, sensor_dofs=s.sensor_dofs,
                   events=(StiffnessEvent(3.0, dK),))
    assert s2.events[0].first_sample(0.05) == 60
    # in effect from 3.0 - dt/2 = 2.975 s on
    assert abs(s2.stiffness(2.97, dt=0.05) - s.K).sum() == 0.0
    assert abs(s2.stiffness(2.98, dt=0.05)).sum() == 0.0
    assert abs(s2.stiffness(2.98)).sum() > 0.0  # without dt: from 3.0 exactly
    assert not s2.is_time_invariant


def test_linear_twin_drops_nonlinear_elements():
    s = _chain(3)
    nl = Structure(name="n", M=s.M, K=s.K, sensor_dofs=s.sensor_dofs,
                   nonlinear=(CubicSpring(2, 10.0),))
    assert not nl.is_linear and nl.linear_twin().is_linear
    assert s.linear_twin() is s


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(DimensionError, match="K"):
        Structure(name="x", M=sp.eye(3), K=sp.eye(2), sensor_dofs=np.arange(3))
    with pytest.raises(DimensionError, match="sensor_dofs"):
        Structure(name="x", M=sp.eye(3), K=sp.eye(3), sensor_dofs=np.array([0, 5]))
    with pytest.raises(InputError, match="NaN"):
        Structure(name="x", M=sp.eye(2), K=np.array([[1.0, np.nan], [0, 1]]),
                  sensor_dofs=np.arange(2))
