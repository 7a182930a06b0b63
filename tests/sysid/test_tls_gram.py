"""The truncated TLS with the rcond rule, computed from the discarded eigenvectors of the
Gram matrix (``X = −V12 V22⁺``), against an independent full SVD of ``[A | B]`` (the kept
vectors, Eq. 3.80's form ``X = V11 V21ᵀ(I − V21 V21ᵀ)⁻¹``)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from podbench.sysid import deconvolution as dc
from podbench.sysid.deconvolution.dense import truncated_tls


def _svd_tls(A, B, rcond):
    M = A.shape[1]
    _, s, Vt = np.linalg.svd(np.hstack([A, B]), full_matrices=False)
    p = min(int(np.count_nonzero(s >= rcond * s[0])), M)
    V = Vt[:p].T
    V11, V21 = V[:M], V[M:]
    X = V11 @ V21.T @ np.linalg.inv(np.eye(B.shape[1]) - V21 @ V21.T)
    return X, p, s[0] / s[p - 1]


def _noisy_toeplitz(n, n_rhs, noise, seed):
    rng = np.random.default_rng(seed)
    q = np.exp(-np.arange(n) / 15.0) * np.sin(np.arange(n) / 3.0)
    A = scipy.linalg.toeplitz(q, np.zeros(n)) + noise * rng.standard_normal((n, n))
    X = rng.standard_normal((n, n_rhs)) * np.exp(-np.arange(n) / 40.0)[:, None]
    return A, A @ X + noise * rng.standard_normal((n, n_rhs))


@pytest.mark.parametrize("n_rhs,noise,rcond", [(1, 1e-3, 1e-3), (2, 1e-2, 1e-3),
                                               (3, 1e-3, 1e-2)])
def test_gram_path_equals_the_full_svd(n_rhs, noise, rcond):
    A, B = _noisy_toeplitz(160, n_rhs, noise, seed=n_rhs)
    X_ref, p, cond = _svd_tls(A, B, rcond)
    assert 0 < p < A.shape[1]  # a real truncation
    res = dc.solve(A, B, dc.TruncatedTLS(rcond=rcond), return_info=True)
    assert res.info["rank"] == p
    assert abs(res.info["condition"] - cond) <= 1e-8 * cond
    assert np.linalg.norm(res.X - X_ref) <= 1e-8 * np.linalg.norm(X_ref)


def test_gram_path_with_the_rank_capped_at_the_unknowns():
    # a loose cut keeps every direction of A: p = M, the r smallest discarded
    A, B = _noisy_toeplitz(120, 2, 1e-2, seed=5)
    X_ref, p, _ = _svd_tls(A, B, 1e-12)
    assert p == A.shape[1]
    X = truncated_tls(A, B, rcond=1e-12)
    assert np.linalg.norm(X - X_ref) <= 1e-8 * np.linalg.norm(X_ref)
