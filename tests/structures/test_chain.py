"""Spring–mass chains against closed-form frequencies; damping and mass-coupling options."""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

from podbench.errors import DimensionError, InputError
from podbench.structures import load_structure
from podbench.structures.chain import chain


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


def _dense_chain(n, m, k, mu=0.0, boundary="fixed-free", rayleigh=None, dashpots=()):
    """Independent reference: the dense n × n assembly (podbench's builder before it went
    sparse), spring by spring and dashpot by dashpot."""
    m = np.broadcast_to(np.asarray(m, dtype=float), (n,))
    k = np.broadcast_to(np.asarray(k, dtype=float), (n if boundary == "fixed-free" else n + 1,))
    K = np.zeros((n, n))
    K[0, 0] += k[0]
    for i in range(1, n):
        K[i - 1, i - 1] += k[i]
        K[i, i] += k[i]
        K[i - 1, i] -= k[i]
        K[i, i - 1] -= k[i]
    if boundary == "fixed-fixed":
        K[n - 1, n - 1] += k[n]
    sq = np.sqrt(m)
    M = np.diag(m)
    if mu and n > 1:
        off = mu * sq[:-1] * sq[1:]
        M += np.diag(off, 1) + np.diag(off, -1)
    C = None if rayleigh is None else rayleigh[0] * M + rayleigh[1] * K
    for *dofs, c in dashpots:
        C = np.zeros((n, n)) if C is None else C
        i = dofs[0]
        C[i, i] += c
        if len(dofs) == 2:
            j = dofs[1]
            C[j, j] += c
            C[i, j] -= c
            C[j, i] -= c
    return M, K, C


CHAIN_VARIANTS = [
    dict(n=1),
    dict(n=2, boundary="fixed-fixed"),
    dict(n=7, mu=0.25, rayleigh=(0.3, 0.01)),
    dict(n=6, boundary="fixed-fixed", mu=-0.2, dashpots=[(0, 0.5), (1, 3, 0.2), (3, 0.7)]),
    dict(n=5, rayleigh=(0.1, 3e-4), dashpots=[(2, 0.4), (2, 4, 0.3), (4, 2, 0.1)]),
    dict(n=4, rayleigh=(0.0, 0.0)),
    dict(n=3, dashpots=[(0, 1, 0.0)]),
    dict(n=40, mu=0.1, rayleigh=(0.05, 1e-3), dashpots=[(39, 2.0)]),
]


@pytest.mark.parametrize("variant", CHAIN_VARIANTS)
def test_sparse_chain_equals_dense_assembly(variant):
    n = variant["n"]
    rng = np.random.default_rng(n)
    m = rng.uniform(0.5, 2.0, n)
    k = rng.uniform(100.0, 500.0, n if variant.get("boundary", "fixed-free") == "fixed-free"
                    else n + 1)
    s = chain(n, masses=m, springs=k, mass_coupling=variant.get("mu", 0.0),
              boundary=variant.get("boundary", "fixed-free"), rayleigh=variant.get("rayleigh"),
              dashpots=variant.get("dashpots", ()))
    M, K, C = _dense_chain(n, m, k, variant.get("mu", 0.0),
                           variant.get("boundary", "fixed-free"), variant.get("rayleigh"),
                           variant.get("dashpots", ()))
    for name, sparse, dense in (("M", s.M, M), ("K", s.K, K), ("C", s.C, C)):
        if dense is None:
            assert sparse is None, name
            continue
        assert sp.isspmatrix_csr(sparse), name
        np.testing.assert_array_equal(sparse.toarray(), dense, err_msg=name)
        assert sparse.nnz == np.count_nonzero(dense), name  # no stored zeros


def test_100k_dof_chain_is_sparse_and_tridiagonal():
    n = 100_000
    s = chain(n, masses=2.0, springs=1e4, mass_coupling=0.25, rayleigh=(1e-3, 1e-6),
              dashpots=[(n - 1, 0.5)], sensors=np.linspace(n - 1, 0, 10).astype(int))
    assert s.n_dofs == n and s.n_sensors == 10
    for A in (s.M, s.K, s.C):
        assert sp.isspmatrix_csr(A) and A.nnz == 3 * n - 2
    assert chain(n).M.nnz == n  # uncoupled: diagonal
    # the tridiagonal entries: free end 1e4, interior 2e4, coupling μ·m
    np.testing.assert_array_equal(s.K.diagonal()[[0, 1, n - 1]], [2e4, 2e4, 1e4])
    np.testing.assert_array_equal(s.K.diagonal(1), -1e4)
    np.testing.assert_allclose(s.M.diagonal(-1), 0.25 * 2.0, rtol=1e-15)
    assert s.C[n - 1, n - 1] == pytest.approx(1e-3 * 2.0 + 1e-6 * 1e4 + 0.5, rel=1e-15)
    # the sensors read their masses
    q = np.arange(n, dtype=float)
    np.testing.assert_array_equal(s.observe(q), s.sensor_dofs)
    assert s.sensor_labels[0] == f"mass{n - 1}" and s.sensor_positions[0] == float(n)


def test_chain_sensors_option():
    s = chain(6, masses=1.0, springs=100.0, sensors=[5, 2])
    assert s.n_sensors == 2 and list(s.sensor_dofs) == [5, 2]
    assert s.sensor_labels == ("mass5", "mass2")
    np.testing.assert_array_equal(s.sensor_positions, [6.0, 3.0])
    for bad, match in (([6], r"\[0, 5\]"), ([1, 1], "repeated"), ([], "non-empty"),
                       ([0.5], "integers"), ([True], "integers")):
        with pytest.raises(InputError, match=match):
            chain(6, sensors=bad)
