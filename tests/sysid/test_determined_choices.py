"""Data-dependent choices of the direct solvers that round-off must not move (issue 23).

* ``truncated_tls``: where the discarded directions of ``[A | B]`` carry no weight on ``B``
  (``V22 = 0``, the non-generic TLS problem), the rank is lowered until the TLS denominator
  reaches ``TLS_MIN_DEN``; checked against the non-generic TLS solution computed from the
  full SVD, and under a 1e-12 perturbation of the data. A singular value within
  ``TLS_CUT_TIE·σ_1`` below the ``rcond`` cut is kept.
* ``subspace``: ``L₃₂`` from the numerical ranges of the future inputs and the instruments;
  checked against the projections formed from the explicit Hankel matrices, on pulse loads
  (future inputs of deficient rank) and an output that no linear model explains exactly.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from podbench.errors import PodbenchWarning
from podbench.sysid import deconvolution as dc
from podbench.sysid.deconvolution import dense
from podbench.sysid.deconvolution.subspace import subspace_factor, subspace_poles

from .test_realization_solver import _state_space


def _singular_square(n=40, seed=0):
    """A square ``A`` with one zero singular value and a ``b`` outside its range: every
    singular value of the ``n × (n+1)`` ``[A | b]`` passes the cut, so the rank is capped at
    ``n`` and the direction discarded is the null vector of ``[A | b]``, ``(z, 0)`` with
    ``A z = 0``: ``V22 = 0``."""
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    s = np.linspace(1.0, 0.2, n)
    s[-1] = 0.0
    A = (U * s) @ V.T
    b = A @ rng.standard_normal(n) + 0.3 * U[:, -1]  # a component along A's left null vector
    return A, b[:, None]


def _nongeneric_reference(A, B, p):
    """``X = −V12 V22ᵀ(V22 V22ᵀ)⁻¹`` over the right singular vectors ``p+1 …`` of the full
    SVD (the non-generic TLS solution at rank ``p``), computed independently."""
    M = A.shape[1]
    _, _, Vt = np.linalg.svd(np.hstack([A, B]), full_matrices=True)
    Vd = Vt[p:].T
    V12, V22 = Vd[:M], Vd[M:]
    return -(V12 @ V22.T) @ np.linalg.inv(V22 @ V22.T)


def test_nongeneric_tls_lowers_the_rank_to_a_determined_solution():
    A, B = _singular_square()
    n = A.shape[1]
    res = dense.TruncatedTLS().solve_matrix(A, B)
    X, info = res.X, res.info
    assert info["rank"] == n - 1  # the rcond rule's n, lowered by one
    ref = _nongeneric_reference(A, B, n - 1)
    assert np.linalg.norm(X - ref) <= 1e-10 * np.linalg.norm(ref)
    # the denominator at rank n is round-off (the null vector of [A | b] is (z, 0))
    _, _, Vt = np.linalg.svd(np.hstack([A, B]), full_matrices=True)
    assert abs(Vt[n, n]) < 1e-12 and Vt[n - 1, n] ** 2 > 1e-3
    # determined: a 1e-12 relative perturbation of the data moves X by < 1e-9 (measured
    # 2e-11); the rank-n formula divides round-off by round-off and moves by O(1)
    rng = np.random.default_rng(1)
    moved, raw = [], []
    for _ in range(3):
        Ap = A * (1 + 1e-12 * rng.standard_normal(A.shape))
        Bp = B * (1 + 1e-12 * rng.standard_normal(B.shape))
        Xp = dense.truncated_tls(Ap, Bp)
        moved.append(np.linalg.norm(Xp - X) / np.linalg.norm(X))
        _, _, Vtp = np.linalg.svd(np.hstack([Ap, Bp]), full_matrices=False)
        V21 = Vtp[:n, n:].T
        raw.append(Vtp[:n, :n].T @ V21.T / (1.0 - float((V21 @ V21.T)[0, 0])))
    assert max(moved) < 1e-9
    spread = max(np.linalg.norm(a - c) for a in raw for c in raw)
    assert spread > 1e-2 * max(np.linalg.norm(a) for a in raw)


def test_nongeneric_tls_gram_and_svd_agree():
    A, B = _singular_square(n=60, seed=3)
    assert dense._tls_gram(A, B, None) is None  # its denominator is below TLS_MIN_DEN
    Xr, ref = dense._tls_svd(A, B, None, None, None)
    X = dense.truncated_tls(A, B)
    np.testing.assert_array_equal(X, Xr)
    assert ref["rank"] == 59


def test_right_hand_side_outside_every_direction_gives_zero_with_a_warning():
    # B orthogonal to A's range: no rank has a denominator (every kept direction of A has
    # zero weight on B); the non-generic TLS solution is X = 0, as least squares's
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.standard_normal((120, 81)))
    U, b = Q[:, :80], Q[:, 80]
    V, _ = np.linalg.qr(rng.standard_normal((80, 80)))
    A = (U * np.logspace(0, -2, 80)) @ V.T
    B = 10.0 * b[:, None]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        X = dense.truncated_tls(A, B)
    assert not np.any(X)
    assert any(issubclass(w.category, PodbenchWarning) and "denominator" in str(w.message)
               for w in caught)
    assert np.linalg.norm(np.linalg.lstsq(A, B, rcond=None)[0]) < 1e-10 * np.linalg.norm(B)


def test_singular_value_at_the_cut_is_kept_within_the_tie_band():
    # σ_1 = 1, cut 1e-3: 1e-16 below it is a tie (round-off, kept); 1e-9 below it is not
    s = np.array([1.0, 0.5, 1e-3 - 1e-16, 1e-3 - 1e-9, 1e-5])
    assert dense.tls_rank(s, (10, 5), 4) == 3
    assert dense.tls_rank(10.0 * s, (10, 5), 4) == 3  # the band scales with σ_1
    # the Gram route and the SVD keep the same directions at a tie: a 2 × 2 block with
    # singular values 1 and exactly the cut
    A = np.diag([1.0, 1e-3])
    B = np.array([[0.0], [0.0]])
    C = np.vstack([np.hstack([A, B]), [[0.0, 0.0, 1e-6]]])
    Xg = dense._tls_gram(C[:, :2], C[:, 2:], None)
    Xr = dense._tls_svd(C[:, :2], C[:, 2:], None, None, None)
    assert Xg is None or Xg[1]["rank"] == Xr[1]["rank"] == 2


# ------------------------------------------------------------------------------ subspace
def _pulse_records(n=160, seed=4):
    """Two load cases of a 2-input, 2-output system under 3-sample pulses (the future
    inputs' Hankel matrix has rank 6 of 2i·k columns), outputs with a cubic term."""
    A, B, C, D = _state_space(order=6, k=2, r=2, seed=seed)
    dt = 0.01
    Qs, Ys = [], []
    for j in range(2):
        U = np.zeros((2, n))
        U[j, :3] = [2.0, 3.0, 1.0]
        x = np.zeros(6)
        Y = np.zeros((2, n))
        for s in range(n):
            Y[:, s] = C @ x + D @ U[:, s] * dt
            x = A @ x + B @ U[:, s] * dt
        Y = Y + 0.3 * Y ** 3 / np.max(np.abs(Y)) ** 2  # not a linear system's output
        Qs.append(U)
        Ys.append(Y.T)
    return Qs, np.concatenate(Ys), dt


def _hankel(x, i, first):
    """Rows ``x[t + first + q]`` (q = 0 … i−1, zero outside the record) for t = 0 … n−i."""
    n, c = x.shape
    pad = np.vstack([np.zeros((i, c)), x, np.zeros((i, c))])
    t = np.arange(n - i + 1)
    return np.vstack([pad[t + i + first + q].T for q in range(i)])


def _projected_l32_singular_values(G, Y, i, tol=1e-8):
    """Independently: ``Y_f`` with the future inputs' row space projected out, read on the
    instruments' (projected) row space; both ranges at ``tol`` of their largest singular
    value, from the explicit Hankel matrices (``pinv``)."""
    Uf = np.hstack([_hankel(G[:, j], i, 0) for j in range(G.shape[1])])
    Zp = np.vstack([np.hstack([_hankel(G[:, j], i, -i) for j in range(G.shape[1])]),
                    np.hstack([_hankel(Y[:, j], i, -i) for j in range(G.shape[1])])])
    Yf = np.hstack([_hankel(Y[:, j], i, 0) for j in range(G.shape[1])])
    Pu = np.eye(Uf.shape[1]) - np.linalg.pinv(Uf, rcond=tol) @ Uf
    Z = Zp @ Pu
    Pz = np.linalg.pinv(Z, rcond=tol) @ Z
    return np.linalg.svd(Yf @ Pu @ Pz, compute_uv=False)


def test_subspace_l32_is_the_projection_of_the_explicit_data():
    Qs, Bs, dt = _pulse_records()
    system = dc.ConvolutionSystem(Qs, Bs, dt)
    G, Y = np.asarray(system.G), np.asarray(system.Y) / dt
    i = 10
    R = subspace_factor(G, Y, i)
    sv, _ = subspace_poles(R, i, 2, 2, [])
    want = _projected_l32_singular_values(G, Y, i)
    k = 8  # the leading ones (the rest are at round-off)
    np.testing.assert_allclose(sv[:k] / sv[0], want[:k] / want[0], rtol=1e-7)


@pytest.mark.heavy  # four subspace fits with the order rule: seconds
def test_subspace_choice_is_stable_under_last_digit_changes():
    Qs, Bs, dt = _pulse_records()
    res = dc.deconvolve(Qs, Bs, dt, "subspace", return_info=True)
    rng = np.random.default_rng(2)
    for _ in range(3):
        Qp = [q * (1 + 1e-12 * rng.standard_normal(q.shape)) for q in Qs]
        Bp = Bs * (1 + 1e-12 * rng.standard_normal(Bs.shape))
        other = dc.deconvolve(Qp, Bp, dt, "subspace", return_info=True)
        assert (other.info["order"], other.info["horizon"]) == \
            (res.info["order"], res.info["horizon"])
        assert np.linalg.norm(other.X - res.X) < 1e-6 * np.linalg.norm(res.X)
