"""Identification of component kernels from interface records (issue 25)."""

import numpy as np
import pytest

from podbench.sysid.components import identify_kernel, identify_lagged, temporal_basis

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _ss_response(A, B, C, D, g):
    x = np.zeros(A.shape[0])
    y = np.empty_like(g)
    for j, gj in enumerate(g):
        y[j] = C @ x + D * gj
        x = A @ x + B * gj
    return y


def test_identify_known_lti_kernel_with_feedthrough():
    """A two-pole kernel with a lag-0 term (an accelerometer's), clean records."""
    r, th = 0.97, 0.3
    A = r * np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    B, C, D = np.array([1.0, 0.0]), np.array([0.5, -0.2]), 2.0
    n = 300
    H = np.array([D] + [C @ np.linalg.matrix_power(A, k - 1) @ B for k in range(1, n)])
    rng = np.random.default_rng(1)
    F = [rng.standard_normal(n) for _ in range(2)]
    Y = [_ss_response(A, B, C, D, g) for g in F]
    dt = 1e-4
    fit = identify_kernel([g[None] for g in F], [y[None] for y in Y], dt, n_lags=n,
                          solver="cgls", options={"reg": 0.0}, realization_order=2)
    assert np.allclose(fit.kernel[:, 0, 0], H, atol=1e-6 * np.abs(H).max())
    A2, B2, C2, D2 = fit.realization
    Hr = [D2[0, 0]] + [(C2 @ np.linalg.matrix_power(A2, k - 1) @ B2)[0, 0] for k in range(1, 50)]
    assert np.allclose(Hr, H[:50], atol=1e-5 * np.abs(H).max())


@pytest.mark.parametrize("n_records", [2, 4])
def test_identify_time_varying_mass_from_few_records(n_records):
    n = 400
    t = np.arange(n) / n
    m = 1.0 + 0.3 * t - 0.2 * t ** 2            # a smooth law: a polynomial of degree 2
    rng = np.random.default_rng(2)
    F = [rng.standard_normal((1, n)) for _ in range(n_records)]
    Y = [g / m for g in F]
    fit = identify_lagged(F, Y, n_lags=2, n_basis=13)
    assert fit.kernel.shape == (n, 2, 1, 1)
    assert np.allclose(fit.kernel[:, 0, 0, 0], 1.0 / m, rtol=1e-6)
    assert np.allclose(fit.kernel[1:, 1, 0, 0], 0.0, atol=1e-6)
    auto = identify_lagged(F, Y)
    assert np.allclose(auto.kernel[:, 0, 0, 0], 1.0 / m, rtol=1e-3)


def test_temporal_basis_is_legendre():
    b = temporal_basis(5, 3)
    assert np.allclose(b[0], 1.0) and np.allclose(b[1], np.linspace(-1, 1, 5))
