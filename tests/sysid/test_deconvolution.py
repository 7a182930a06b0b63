"""Convolution matrices and deconvolution solvers (§3.3, §3.5)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from podbench.errors import (
    DimensionError,
    IllConditionedError,
    InputError,
    PodbenchWarning,
    UnknownNameError,
)
from podbench.sysid import deconvolution as dc

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=50, deadline=None)
@given(q=arrays(float, st.integers(1, 40), elements=finite),
       data=st.data(), dt=st.floats(1e-4, 10.0))
def test_convolution_matrix_is_truncated_np_convolve(q, data, dt):
    """Eq. 3.40: (Q̌ c)[s] = Δt Σ_{p≤s} c[p] q[s−p] = Δt·np.convolve(q, c)[:n]."""
    c = data.draw(arrays(float, q.size, elements=finite))
    expected = dt * np.convolve(q, c)[: q.size]
    A = dc.convolution_matrix(q, dt)
    assert A.shape == (q.size, q.size)
    assert np.all(np.triu(A, 1) == 0)
    np.testing.assert_allclose(A @ c, expected, rtol=1e-9, atol=1e-9 * (1 + np.abs(expected).max()))
    np.testing.assert_allclose(dc.convolve(c, q, dt), expected, rtol=1e-9,
                               atol=1e-9 * dt * (1 + np.abs(q).max() * np.abs(c).sum()))


def test_convolve_broadcasts_and_accepts_longer_kernels():
    rng = np.random.default_rng(0)
    C = rng.standard_normal((3, 1, 70))
    q = rng.standard_normal((1, 4, 50))
    out = dc.convolve(C, q, 0.1)
    assert out.shape == (3, 4, 50)
    for i in range(3):
        for j in range(4):
            np.testing.assert_allclose(out[i, j], 0.1 * np.convolve(C[i, 0, :50], q[0, j])[:50],
                                       atol=1e-12)
    with pytest.raises(DimensionError, match="kernel"):
        dc.convolve(np.ones(10), np.ones(20), 0.1)


def test_block_convolution_matrix_matches_convolve_kernel():
    """Eq. 3.48 with C̄ (k·n × k) equals the matrix convolution of Eq. 3.36."""
    rng = np.random.default_rng(1)
    k, n, n_cases, dt = 3, 25, 4, 0.01
    Qs = [rng.standard_normal((k, n)) for _ in range(n_cases)]
    kernel = rng.standard_normal((k, k, n))  # kernel[l, i] = c_li
    Cbar = np.vstack([kernel[:, i, :].T for i in range(k)])
    A = dc.block_convolution_matrix(Qs, dt)
    assert A.shape == (n_cases * n, k * n)
    stacked = A @ Cbar
    for j, Q in enumerate(Qs):
        np.testing.assert_allclose(stacked[j * n:(j + 1) * n].T, dc.convolve_kernel(kernel, Q, dt),
                                   atol=1e-12)
    with pytest.raises(DimensionError, match="Q_list"):
        dc.block_convolution_matrix([Qs[0], Qs[1][:, :-1]], dt)


def test_ls_solves_the_singular_but_consistent_zero_first_sample_system():
    """A force with q[0] = 0 gives a zero diagonal; min-norm LS still predicts exactly."""
    rng = np.random.default_rng(2)
    n, dt = 60, 0.01
    q = np.zeros(n)
    q[1:6] = 1.0  # pulse starting at sample 1
    c_true = np.exp(-0.05 * np.arange(n)) * np.sin(0.4 * np.arange(n))
    A = dc.convolution_matrix(q, dt)
    assert np.all(np.diag(A) == 0) and np.linalg.matrix_rank(A) == n - 1
    v = A @ c_true
    c = dc.solve(A, v, "ls")
    np.testing.assert_allclose(A @ c, v, atol=1e-12 * np.abs(v).max())
    # the unidentifiable part is c[n-1] only; a new force with q̃[0] = 0 never uses it
    np.testing.assert_allclose(c[:-1], c_true[:-1], atol=1e-8)
    q_new = np.r_[0.0, rng.standard_normal(n - 1)]
    np.testing.assert_allclose(dc.convolve(c, q_new, dt), dc.convolve(c_true, q_new, dt),
                               atol=1e-10)
    # a plain triangular solve fails on the zero diagonal
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        scipy.linalg.solve_triangular(A, v, lower=True)


def _matlab_tlsdeconv(y, X, tol=1000.0):
    """Transcription of the appendix's tlsdeconv (Eq. 3.80 with r from cond <= tol)."""
    Cm = np.column_stack([X, y])
    _, S, Vt = np.linalg.svd(Cm)  # full SVD as MATLAB's svd(C)
    V = Vt.T
    r = int(np.sum(S[0] / S <= tol))
    n = V.shape[0] - 1
    num = sum(V[n, i] * V[:n, i] for i in range(r))
    den = 1 - sum(V[n, i] ** 2 for i in range(r))
    return num / den


def test_tls_one_rhs_equals_eq_3_80():
    rng = np.random.default_rng(3)
    n, dt = 50, 0.01
    q = np.r_[0.0, np.ones(4), np.zeros(n - 5)] + 0.05 * rng.standard_normal(n)
    A = dc.convolution_matrix(q, dt)
    b = A @ np.sin(0.3 * np.arange(n)) + 1e-3 * rng.standard_normal(n)
    np.testing.assert_allclose(dc.truncated_tls(A, b), _matlab_tlsdeconv(b, A), rtol=1e-9,
                               atol=1e-12)
    for rcond in (1e-1, 1e-2):
        np.testing.assert_allclose(dc.truncated_tls(A, b, rcond=rcond),
                                   _matlab_tlsdeconv(b, A, 1 / rcond), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("p", [3, 10, 20])
def test_tls_several_rhs_is_minus_v12_v22_pinv(p):
    rng = np.random.default_rng(4)
    N, M, r = 30, 20, 3
    A = rng.standard_normal((N, M))
    B = rng.standard_normal((N, r))
    V = np.linalg.svd(np.hstack([A, B]))[2].T  # full (M + r) × (M + r)
    V12, V22 = V[:M, p:], V[M:, p:]
    expected = -V12 @ np.linalg.pinv(V22)
    np.testing.assert_allclose(dc.truncated_tls(A, B, rank=p), expected, atol=1e-10)
    # column by column with one right-hand side it is *not* the same problem in general,
    # but with r = 1 it reduces to Eq. 3.80
    np.testing.assert_allclose(dc.truncated_tls(A, B[:, 0], rank=p),
                               _matlab_rank(B[:, 0], A, p), atol=1e-10)


def _matlab_rank(y, X, r):
    V = np.linalg.svd(np.column_stack([X, y]))[2].T
    n = V.shape[0] - 1
    return sum(V[n, i] * V[:n, i] for i in range(r)) / (1 - sum(V[n, i] ** 2 for i in range(r)))


def test_full_rank_tls_is_the_classical_closed_form():
    """p = M: x = (AᵀA − σ²_{M+1} I)⁻¹ Aᵀ b (Golub & Van Loan), independent of the SVD split."""
    rng = np.random.default_rng(5)
    A = rng.standard_normal((40, 6))
    b = A @ rng.standard_normal(6) + 0.1 * rng.standard_normal(40)
    s_last = np.linalg.svd(np.column_stack([A, b]), compute_uv=False)[-1]
    expected = np.linalg.solve(A.T @ A - s_last**2 * np.eye(6), A.T @ b)
    np.testing.assert_allclose(dc.truncated_tls(A, b, rank=6), expected, rtol=1e-9)
    # and the default rule keeps all 6 here (well-conditioned A), capped at M
    np.testing.assert_allclose(dc.truncated_tls(A, b), expected, rtol=1e-9)


def test_tls_rank_rules():
    s = np.array([10.0, 1.0, 0.1, 0.009, 1e-6])
    assert dc.tls_rank(s, (10, 5), 4) == 3  # default rcond 1e-3: keep s >= 0.01
    assert dc.tls_rank(s, (10, 5), 4, rcond=1e-5) == 4  # capped at the 4 unknowns
    assert dc.tls_rank(s, (10, 5), 2, rcond=1e-5) == 2
    assert dc.tls_rank(s, (10, 5), 4, rank=1) == 1
    # noise edge s_e (√10 + √5) = 0.0539·s_e/0.01: with s_e = 0.01 keep 10, 1, 0.1
    assert dc.tls_rank(s, (10, 5), 4, noise_level=0.01) == 3
    assert dc.tls_rank(s, (10, 5), 4, noise_level=0.1) == 2
    with pytest.raises(InputError, match="at most one"):
        dc.tls_rank(s, (10, 5), 4, rcond=1e-2, noise_level=0.1)
    with pytest.raises(InputError, match="rcond"):
        dc.tls_rank(s, (10, 5), 4, rcond=2.0)


def test_noise_level_rule_finds_the_signal_rank():
    """Rank-3 signal plus iid noise of known level: the edge separates them."""
    rng = np.random.default_rng(6)
    N, Mp, sd = 200, 60, 1e-3
    S = rng.standard_normal((N, 3)) @ rng.standard_normal((3, Mp))
    s = np.linalg.svd(S + sd * rng.standard_normal((N, Mp)), compute_uv=False)
    assert dc.tls_rank(s, (N, Mp), Mp - 1, noise_level=sd) == 3


def test_tls_with_nothing_kept_warns_and_returns_zero():
    A = np.eye(3)
    with pytest.warns(PodbenchWarning, match="no singular value"):
        x = dc.truncated_tls(A, np.ones(3), noise_level=100.0)
    np.testing.assert_array_equal(x, 0.0)


def test_tls_without_noise_recovers_the_exact_solution():
    rng = np.random.default_rng(7)
    A = rng.standard_normal((30, 30)) + 10 * np.eye(30)
    x = rng.standard_normal((30, 2))
    np.testing.assert_allclose(dc.solve(A, A @ x, "tls-dt"), x, atol=1e-9)


def test_truncation_keeps_tls_bounded_where_pinv_blows_up():
    """Noisy force and response: pinv fits the noise through tiny singular values."""
    rng = np.random.default_rng(8)
    n, dt = 120, 0.01
    t = np.arange(n)
    q = np.exp(-(((t - 8) / 3.0) ** 2))  # smooth force: convolution matrix nearly singular
    q[0] = 0.0
    c_true = np.exp(-0.02 * t) * np.sin(0.25 * t)
    v = dc.convolution_matrix(q, dt) @ c_true
    qn = q + 1e-3 * rng.standard_normal(n)
    vn = v + 1e-3 * np.abs(v).max() * rng.standard_normal(n)
    A = dc.convolution_matrix(qn, dt)
    c_ls = dc.solve(A, vn, "ls")
    err = {}
    for key, c in (("ls", c_ls), ("tls-dt", dc.solve(A, vn, "tls-dt")),
                   ("tls 1e-2", dc.solve(A, vn, "tls-dt", rcond=1e-2))):
        err[key] = np.linalg.norm(c - c_true) / np.linalg.norm(c_true)
    # measured: ls 2.9e5, tls (default rcond 1e-3) 0.15, tls rcond 1e-2 0.05
    assert err["ls"] > 1e3
    assert err["tls-dt"] < 0.5
    assert err["tls 1e-2"] < 0.5


def test_solver_table_and_user_dense_solvers():
    assert dc.available_solvers() == ("ls", "tls-dt", "tls-appendix", "tls-balanced", "block",
                                     "fft", "cgls", "kernel", "realization", "subspace",
                                     "stls", "auto")
    assert dc.get_solver("tls-dt") is dc.TruncatedTLS
    with pytest.raises(UnknownNameError, match="unknown solver 'fft'.*'ls'"):
        dc.solve(np.eye(2), np.ones(2), "fft")
    # an unknown option is an InputError naming it, and a TypeError as in Python
    with pytest.raises(TypeError, match="unknown option 'noise_level' for solver 'ls'"):
        dc.solve(np.eye(2), np.ones(2), "ls", noise_level=1.0)
    assert not hasattr(dc, "register_solver")  # no global table a worker would not see

    class Halves(dc.DenseSolver):
        def __init__(self, *, factor=0.5, max_dense_bytes=dc.DENSE_MAX_BYTES):
            self.factor = factor
            self.max_dense_bytes = max_dense_bytes

        def _solve_matrix(self, A, B):
            return self.factor * np.linalg.solve(A, B)

    class WrongShape(dc.DenseSolver):
        def _solve_matrix(self, A, B):
            return np.zeros(1)

    class NaN(dc.DenseSolver):
        def _solve_matrix(self, A, B):
            return np.full((A.shape[1], B.shape[1]), np.nan)

    np.testing.assert_allclose(dc.solve(2 * np.eye(2), np.ones(2), Halves()), 0.25)
    np.testing.assert_allclose(dc.solve(np.eye(2), np.ones(2), Halves, factor=1), 1)
    res = dc.solve(2 * np.eye(2), np.ones(2), Halves(), return_info=True)
    assert res.info["solver"] == "Halves" and res.info["residual"] == pytest.approx(0.5)
    with pytest.raises(DimensionError, match="'WrongShape' returned shape"):
        dc.solve(np.eye(2), np.ones(2), WrongShape())
    with pytest.raises(IllConditionedError, match="NaN"):
        dc.solve(np.eye(2), np.ones(2), NaN())


def test_bad_input():
    with pytest.raises(InputError, match="dt"):
        dc.convolution_matrix(np.ones(3), 0.0)
    with pytest.raises(InputError, match="NaN"):
        dc.convolution_matrix(np.array([1.0, np.nan]), 0.1)
    with pytest.raises(DimensionError, match="rows"):
        dc.solve(np.eye(3), np.ones(4))
