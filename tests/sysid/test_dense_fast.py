"""The fast paths of the dense solvers (issue 24 item 10) against their references.

* ``truncated_tls`` with the ``rcond`` rule solves through the discarded eigenvectors of
  ``[A | B]ᵀ[A | B]`` (``dense._tls_gram``); ``dense._tls_svd`` is the reference (the economy
  SVD and the kept vectors, Eqs. 3.78-3.80 as written). Same rank, same ``condition``, same
  ``X`` to round-off, on well-posed, rank-deficient, under-determined and capped systems.
* The built-in dense solvers keep their answers per process (``dense._MEMO``): a repeated
  solve returns the first one bit for bit; another system, right-hand side or option is
  solved afresh.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from podbench.deconvolution import ConvolutionSystem

from podbench.errors import PodbenchWarning
from podbench.sysid.deconvolution import dense


def _decaying(N, M, r, rng, decay=3.0):
    """``A`` with singular values spread over ``10**decay`` and ``B = A X + noise``."""
    U, _ = np.linalg.qr(rng.standard_normal((N, N)))
    V, _ = np.linalg.qr(rng.standard_normal((M, M)))
    s = np.logspace(0, -decay, min(N, M))
    A = (U[:, :s.size] * s) @ V[:s.size]
    B = A @ rng.standard_normal((M, r)) + 1e-3 * rng.standard_normal((N, r))
    return A, B


def _cases():
    rng = np.random.default_rng(24)
    A1, B1 = _decaying(60, 40, 1, rng)            # small (λ1 by eigvalsh)
    A2, B2 = _decaying(120, 90, 3, rng, 4.0)      # λ1 by Lanczos, several right-hand sides
    A3, B3 = _decaying(50, 80, 2, rng)            # under-determined: null vectors discarded
    A4 = rng.standard_normal((100, 70))           # well-conditioned: every σ passes, p = M
    B4 = A4 @ rng.standard_normal((70, 2))
    A5, B5 = _decaying(90, 70, 1, rng)
    A5[:, 10] = A5[:, 3]                          # rank-deficient: a repeated column
    A5[:, 20] = 0.0                               # and a zero one
    return {"small": (A1, B1), "lanczos": (A2, B2), "underdetermined": (A3, B3),
            "capped": (A4, B4), "rank_deficient": (A5, B5)}


@pytest.mark.parametrize("case", list(_cases()))
@pytest.mark.parametrize("scale", [False, True])
def test_tls_gram_equals_svd_reference(case, scale):
    A, B = _cases()[case]
    if scale:
        da, db = dense._column_scales(A), dense._column_scales(B)
        A, B = A / da, B / db
    Xf, fast = dense._tls_gram(A, B, None)
    Xr, ref = dense._tls_svd(A, B, None, None, None)
    assert fast["rank"] == ref["rank"]
    assert fast["condition"] == pytest.approx(ref["condition"], rel=1e-9)
    # the Gram route's subspace is the SVD's to ε λ_1 / gap (measured up to 2e-10 here)
    assert np.linalg.norm(Xf - Xr) <= 1e-9 * np.linalg.norm(Xr)
    if case == "capped":
        assert ref["rank"] == A.shape[1]  # the cap at M, not the cut, decided the rank


@pytest.mark.heavy
def test_truncated_tls_takes_the_fast_path_only_for_the_rcond_rule():
    A, B = _cases()["lanczos"]
    for kwargs in ({"rank": "gap"}, {"rank": 50}, {"noise_level": 1e-3}, {"rcond": 1e-6}):
        X = dense.truncated_tls(A, B, **kwargs)
        Xr = dense._tls_svd(A, B, kwargs.get("rcond"), kwargs.get("noise_level"),
                            kwargs.get("rank"))[0]
        assert np.array_equal(X, Xr), kwargs
    X = dense.truncated_tls(A, B, rcond=1e-2)
    assert np.array_equal(X, dense._tls_gram(A, B, 1e-2)[0])
    assert np.linalg.norm(X - dense._tls_svd(A, B, 1e-2, None, None)[0]) \
        <= 1e-9 * np.linalg.norm(X)


def _system(rng, n=96, k=2, cases=2):
    q = [np.vstack([np.r_[0.0, np.exp(-np.arange(n - 1) / (5.0 + i + j))]
                    + 0.01 * rng.standard_normal(n) for i in range(k)]) for j in range(cases)]
    B = rng.standard_normal((cases * n, k))
    return q, B


@pytest.mark.heavy
@pytest.mark.parametrize("solver", [dense.LeastSquares(), dense.TruncatedTLS(scale=True),
                                    dense.AppendixTLS(), dense.BalancedTLS()])
def test_memo_returns_the_first_answer_bit_for_bit(solver):
    rng = np.random.default_rng(7)
    q, B = _system(rng)
    dense._MEMO.clear()
    first = solver.solve(ConvolutionSystem(q, B, 1e-3))
    key = dense._memo_key(solver, ConvolutionSystem(q, B, 1e-3))
    assert key in dense._MEMO
    again = solver.solve(ConvolutionSystem([x.copy() for x in q], B.copy(), 1e-3))
    assert np.array_equal(first.X, again.X) and first.info == again.info
    again.X[0, 0] += 1.0  # the caller's copy: the memo's answer is untouched
    assert np.array_equal(solver.solve(ConvolutionSystem(q, B, 1e-3)).X, first.X)
    # the uncached solve gives that answer too
    X_direct = solver._solve_dense(ConvolutionSystem(q, B, 1e-3))[0]
    assert np.array_equal(X_direct, first.X)


@pytest.mark.heavy
def test_memo_tells_systems_and_options_apart():
    rng = np.random.default_rng(8)
    q, B = _system(rng)
    dense._MEMO.clear()
    base = dense.LeastSquares().solve(ConvolutionSystem(q, B, 1e-3)).X
    B2 = B.copy()
    B2[5, 1] += 1e-12
    other_b = dense.LeastSquares().solve(ConvolutionSystem(q, B2, 1e-3)).X
    other_dt = dense.LeastSquares().solve(ConvolutionSystem(q, B, 2e-3)).X
    other_rcond = dense.LeastSquares(rcond=1e-2).solve(ConvolutionSystem(q, B, 1e-3)).X
    assert not np.array_equal(base, other_b)
    np.testing.assert_allclose(other_dt, base / 2, rtol=1e-8, atol=1e-12 * np.abs(base).max())
    assert np.linalg.norm(other_rcond - base) > 1e-6 * np.linalg.norm(base)
    assert len(dense._MEMO) == 4


def test_memo_skips_user_subclasses_and_repeats_warnings():
    class MyLS(dense.LeastSquares):
        name = "my-ls"

    rng = np.random.default_rng(9)
    q, B = _system(rng)
    dense._MEMO.clear()
    MyLS().solve(ConvolutionSystem(q, B, 1e-3))
    assert not dense._MEMO
    # nothing to keep (zero forces and responses): a warning, on the first solve and on
    # the memo's answer alike
    system = ConvolutionSystem([np.zeros_like(x) for x in q], np.zeros_like(B), 1e-3)
    for _ in range(2):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            X = dense.TruncatedTLS().solve(system).X
        assert any(issubclass(w.category, PodbenchWarning) for w in caught)
        assert not np.any(X)
    assert len(dense._MEMO) == 1


def test_tls_gram_gives_way_to_the_svd_where_the_tls_denominator_vanishes():
    # B orthogonal to A's range and larger than A, and A with singular values below the cut:
    # B's direction is kept, the discarded directions are A's small ones with (round-off)
    # zero weight on B, V22 ≈ 0 (the non-generic TLS problem), and X = −V12 V22ᵀ(V22 V22ᵀ)⁻¹
    # divides round-off by round-off; the SVD lowers the rank (tests/sysid/
    # test_determined_choices.py): no rank has a denominator here, X = 0 with a warning
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.standard_normal((120, 81)))
    U, b = Q[:, :80], Q[:, 80]
    V, _ = np.linalg.qr(rng.standard_normal((80, 80)))
    s = np.concatenate([np.logspace(0, -2, 70), np.full(10, 1e-6)])
    A = (U * s) @ V.T
    B = 10.0 * b[:, None]
    assert dense._tls_gram(A, B, None) is None     # its denominator is below TLS_MIN_DEN
    with pytest.warns(PodbenchWarning, match="denominator"):
        X = dense.truncated_tls(A, B)
    with pytest.warns(PodbenchWarning, match="denominator"):
        Xr, _ = dense._tls_svd(A, B, None, None, None)
    np.testing.assert_array_equal(X, Xr)           # the SVD answered
    assert not np.any(X)


def test_cgls_keeps_its_answer_like_the_dense_solvers(monkeypatch):
    """``"cgls"`` (conjugate gradients, deterministic) returns a repeated solve from the same
    memo: the first answer bit for bit, without iterating again; another right-hand side
    is solved afresh."""
    from podbench.sysid.deconvolution import tikhonov

    rng = np.random.default_rng(10)
    q, B = _system(rng)
    dense._MEMO.clear()
    runs = []
    real = tikhonov.cgls_iterate
    monkeypatch.setattr(tikhonov, "cgls_iterate", lambda *a: runs.append(1) or real(*a))
    solver = tikhonov.CGLS(reg=1e-3)
    first = solver.solve(ConvolutionSystem(q, B, 1e-3))
    again = solver.solve(ConvolutionSystem([x.copy() for x in q], B.copy(), 1e-3))
    assert len(runs) == 1
    assert np.array_equal(first.X, again.X) and first.info == again.info
    dense._MEMO.clear()
    assert np.array_equal(solver.solve(ConvolutionSystem(q, B, 1e-3)).X, first.X)
    other = solver.solve(ConvolutionSystem(q, 2.0 * B, 1e-3))
    assert len(runs) == 3
    np.testing.assert_allclose(other.X, 2.0 * first.X, rtol=1e-6, atol=1e-9 * np.abs(first.X).max())
