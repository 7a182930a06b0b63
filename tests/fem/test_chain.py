"""Spring–mass chains against closed-form frequencies; damping and mass-coupling options."""

import numpy as np
import pytest
import scipy.linalg

from podbench.errors import DimensionError, InputError
from podbench.fem import load_structure
from podbench.fem.chain import chain


@pytest.mark.parametrize("n", [1, 3, 8])
def test_uniform_fixed_free_frequencies(n):
    m, k = 0.02, 350.0
    s = chain(n, masses=m, springs=k)
    j = np.arange(1, n + 1)
    w = 2 * np.sqrt(k / m) * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1)))
    np.testing.assert_allclose(s.natural_frequencies(n), w / (2 * np.pi), rtol=1e-10)
    assert s.C is None and (s.n_dofs, s.n_sensors) == (n, n)


def test_uniform_fixed_fixed_frequencies():
    n, m, k = 6, 1.5, 40.0
    s = chain(n, masses=m, springs=k, boundary="fixed-fixed")
    j = np.arange(1, n + 1)
    w = 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1)))
    np.testing.assert_allclose(s.natural_frequencies(n), w / (2 * np.pi), rtol=1e-10)


def test_static_deflection_of_series_springs():
    k = np.array([100.0, 200.0, 400.0])
    s = chain(3, masses=[1.0, 2.0, 3.0], springs=k)
    q = np.linalg.solve(s.K.toarray(), [0.0, 0.0, 10.0])  # 10 lbf at the free end
    np.testing.assert_allclose(q, 10.0 * np.cumsum(1.0 / k), rtol=1e-12)


def test_mass_coupling_is_positive_definite_and_consistent():
    m = np.array([1.0, 4.0, 9.0])
    s = chain(3, masses=m, springs=1.0, mass_coupling=0.25)
    M = s.M.toarray()
    np.testing.assert_allclose(np.diag(M), m)
    assert M[0, 1] == pytest.approx(0.25 * 2.0) and M[1, 2] == pytest.approx(0.25 * 6.0)
    assert M[0, 2] == 0.0
    assert np.linalg.eigvalsh(M).min() > 0
    with pytest.raises(InputError, match="mass_coupling"):
        chain(3, mass_coupling=0.5)


def test_rayleigh_is_proportional_dashpots_are_not():
    s = chain(4, masses=[1.0, 2.0, 1.5, 1.0], springs=[10.0, 20.0, 15.0, 5.0],
              rayleigh=(0.3, 0.01))
    np.testing.assert_allclose(s.C.toarray(), 0.3 * s.M.toarray() + 0.01 * s.K.toarray())
    _, phi = scipy.linalg.eigh(s.K.toarray(), s.M.toarray())
    modal = phi.T @ s.C.toarray() @ phi
    assert np.abs(modal - np.diag(np.diag(modal))).max() < 1e-12 * np.abs(modal).max()

    d = chain(4, masses=[1.0, 2.0, 1.5, 1.0], springs=[10.0, 20.0, 15.0, 5.0],
              dashpots=[(0, 0.5), (1, 3, 0.2)])
    C = d.C.toarray()
    expected = np.zeros((4, 4))
    expected[0, 0] = 0.5
    expected[np.ix_([1, 3], [1, 3])] += 0.2 * np.array([[1, -1], [-1, 1]])
    np.testing.assert_array_equal(C, expected)
    modal = phi.T @ C @ phi
    assert np.abs(modal - np.diag(np.diag(modal))).max() > 1e-3 * np.abs(modal).max()


def test_bad_sizes():
    with pytest.raises(DimensionError, match="springs"):
        chain(3, springs=[1.0, 2.0])
    with pytest.raises(DimensionError, match="masses"):
        chain(3, masses=[1.0, 2.0, 3.0, 4.0])
    with pytest.raises(InputError, match="dashpots"):
        chain(3, dashpots=[(3, 1.0)])


def test_shipped_chain_files():
    ideal = load_structure("chain_ideal")
    assert np.array_equal(ideal.M.toarray(), np.eye(5))
    np.testing.assert_allclose(ideal.C.toarray(), 0.1 * np.eye(5) + 3e-4 * ideal.K.toarray())
    coupled = load_structure("chain_coupled")
    M = coupled.M.toarray()
    assert np.count_nonzero(M - np.diag(np.diag(M))) == 8  # tridiagonal coupling
    assert coupled.C.toarray()[0, 0] == pytest.approx(0.05)
    assert coupled.C.toarray()[2, 3] == pytest.approx(-0.03)
    a, b = load_structure("chain_coupled"), load_structure("chain_coupled")
    np.testing.assert_array_equal(a.C.toarray(), b.C.toarray())
