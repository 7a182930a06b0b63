"""The kernel-based (empirical-Bayes) solver, the honest truncated TLS and ``solver="auto"``.

Checked against independent computations: the solution against the dense posterior mean
``P Aᵀ (A P Aᵀ + γ I)⁻¹ B``, the evidence against a dense Cholesky evaluation
(:func:`log_marginal_likelihood`) and its maximum by perturbing each hyper-parameter.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import sklearn.base

from podbench.errors import IllConditionedError, InputError
from podbench.sysid import deconvolution as dc
from podbench.sysid.deconvolution.kernel import _apply_S, _apply_St, _factor, _scales

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _chain(n=40, k=2, noise=0.0, seed=0, dt=0.01):
    """k load cases, k modes, decaying oscillating kernels, noise relative to std(B)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    Qs = [rng.standard_normal((k, n)) for _ in range(k)]
    X = np.stack([np.exp(-t / 0.1) * np.sin(2 * np.pi * 5 * (i + 1) * t)
                  for i in range(k * k)]).reshape(k, k, n).transpose(0, 2, 1).reshape(k * n, k)
    B = dc.convolution_product(Qs, X, dt)
    B = B + noise * B.std() * np.random.default_rng(seed + 100).standard_normal(B.shape)
    return Qs, B, dt, X


def test_kernel_factor_and_recursions():
    S = _factor(9, 0.9, 0.6)
    np.testing.assert_allclose(S @ S.T, dc.kernel_matrix(9, 0.9, 0.6), atol=1e-15)
    # TC is DC with ρ = √λ: λ^max(p, q)
    p = np.arange(9)
    np.testing.assert_allclose(dc.kernel_matrix(9, 0.8, np.sqrt(0.8)),
                               0.8 ** np.maximum(p[:, None], p[None, :]), rtol=1e-13)
    E = np.random.default_rng(0).standard_normal((9, 3))
    np.testing.assert_allclose(_apply_S(E, 0.9, 0.6), S @ E, atol=1e-14)
    np.testing.assert_allclose(_apply_St(E, 0.9, 0.6), S.T @ E, atol=1e-14)


def test_contract_clone_pickle_and_bad_options():
    for cls, opts in ((dc.KernelRegularized, {"kernel": "tc", "n_hyper": 64}),
                      (dc.Auto, {"threshold": 1e-2})):
        solver = cls(**opts)
        assert dc.get_solver(cls.name) is cls and cls.structured
        twin = sklearn.base.clone(solver)
        assert type(twin) is cls and twin.get_params() == solver.get_params()
        assert pickle.loads(pickle.dumps(solver)).get_params() == solver.get_params()
    with pytest.raises(InputError, match="`kernel`"):
        dc.make_solver("kernel", {"kernel": "ss"})
    with pytest.raises(InputError, match="`rho`"):
        dc.make_solver("kernel", {"kernel": "tc", "rho": 0.5})
    with pytest.raises(InputError, match="`lam`"):
        dc.make_solver("kernel", {"lam": 1.0})


def test_solution_equals_dense_posterior_mean_and_cg_path():
    Qs, B, dt, _ = _chain(noise=0.01)
    system = dc.ConvolutionSystem(Qs, B, dt)
    n = system.n
    res = dc.KernelRegularized(lam=0.95, rho=0.7, gamma=1e-3).solve(system)
    sc = _scales(system)
    A = system.dense() / np.repeat(sc, n)[None, :]
    P = np.kron(np.eye(2), dc.kernel_matrix(n, 0.95, 0.7))
    X = P @ A.T @ np.linalg.solve(A @ P @ A.T + 1e-3 * np.eye(A.shape[0]), B)
    X /= np.repeat(sc, n)[:, None]
    # measured 9e-14
    assert np.abs(res.X - X).max() <= 1e-10 * np.abs(X).max()
    assert res.info["iterations"] == 0 and res.info["n_hyper"] == n
    # the full-system conjugate-gradient path (evidence on 10 samples only), same γ, λ, ρ
    cg = dc.KernelRegularized(lam=0.95, rho=0.7, gamma=1e-3, n_hyper=10, tol=1e-12).solve(system)
    assert cg.info["converged"] and cg.info["iterations"] > 0
    assert np.abs(cg.X - X).max() <= 1e-8 * np.abs(X).max()  # measured 2e-10


def test_evidence_is_true_and_maximized():
    Qs, B, dt, X_true = _chain(noise=0.02, seed=3)
    system = dc.ConvolutionSystem(Qs, B, dt)
    res = dc.KernelRegularized().solve(system)
    info = res.info
    # per-column c, σ² are needed for the independent evaluation: recover them by fixing
    # the shape and γ per column (one column at a time)
    total, parts = 0.0, []
    for col in range(B.shape[1]):
        sub = dc.ConvolutionSystem(Qs, B[:, col], dt)
        one = dc.KernelRegularized(lam=info["lam"], rho=info["rho"]).solve(sub).info
        parts.append(one)
        total += one["log_evidence"]
        direct = dc.log_marginal_likelihood(sub, lam=one["lam"], rho=one["rho"], c=one["c"],
                                            sigma2=one["sigma2"])
        assert direct == pytest.approx(one["log_evidence"], rel=1e-8, abs=1e-8)
        for key, factor in (("c", 1.3), ("c", 0.7), ("sigma2", 1.3), ("sigma2", 0.7)):
            hp = {"c": one["c"], "sigma2": one["sigma2"]}
            hp[key] *= factor
            assert dc.log_marginal_likelihood(sub, lam=one["lam"], rho=one["rho"],
                                              **hp) < direct
        for dl, dr in ((0.5, 1), (2, 1), (1, 0.5), (1, 2)):  # perturb 1 − λ and 1 − ρ
            lam = 1 - (1 - one["lam"]) * dl
            rho = 1 - (1 - one["rho"]) * dr
            assert dc.log_marginal_likelihood(sub, lam=lam, rho=rho, c=one["c"],
                                              sigma2=one["sigma2"]) < direct
    assert total == pytest.approx(info["log_evidence"], rel=1e-6)
    # it estimates the noise level (2 % of std(B); the floor is σ/rms(y) per column)
    assert 0.01 < info["noise_floor"] < 0.04
    # and beats plain least squares, which amplifies the noise
    err = np.linalg.norm(res.X - X_true) / np.linalg.norm(X_true)
    err_ls = np.linalg.norm(dc.deconvolve(Qs, B, dt, "ls") - X_true) / np.linalg.norm(X_true)
    assert err < 0.2 < 10 * err < err_ls


def test_auto_picks_exact_on_clean_and_robust_on_noisy():
    Qs, B, dt, X = _chain()
    clean = dc.deconvolve(Qs, B, dt, "auto", return_info=True)
    assert clean.info["choice"] == "block" and clean.info["noise_test"] == "kernel"
    assert clean.info["noise_floor"] < 1e-12  # the exact kernel's Hankel floor: round-off
    np.testing.assert_allclose(clean.X, dc.deconvolve(Qs, B, dt, "block"), rtol=0, atol=0)
    Qs, B, dt, X = _chain(noise=0.01)
    noisy = dc.deconvolve(Qs, B, dt, "auto", return_info=True)
    # noise amplified past max_growth: block refuses, the kernel solver's evidence decides
    with pytest.raises(IllConditionedError):
        dc.deconvolve(Qs, B, dt, dc.BlockSubstitution(max_growth=1e4))
    assert noisy.info["noise_test"] == "evidence" and noisy.info["noise_floor"] > 1e-3
    assert noisy.info["choice"] == "subspace"
    np.testing.assert_allclose(noisy.X, dc.deconvolve(Qs, B, dt, "subspace"), rtol=0, atol=0)
    assert noisy.info["order"] == dc.deconvolve(Qs, B, dt, "subspace",
                                                return_info=True).info["order"]
    kern = dc.deconvolve(Qs, B, dt, dc.Auto(robust="kernel"), return_info=True)
    assert kern.info["noise_floor"] > 1e-3 and kern.info["choice"] == "kernel"
    np.testing.assert_allclose(kern.X, dc.deconvolve(Qs, B, dt, "kernel"), rtol=0, atol=0)
    real = dc.deconvolve(Qs, B, dt, dc.Auto(robust="realization"), return_info=True)
    assert real.info["noise_floor"] > 1e-3 and real.info["choice"] == "realization"
    np.testing.assert_allclose(real.X, dc.deconvolve(Qs, B, dt, "realization"), rtol=0, atol=0)
    assert real.info["order"] == dc.deconvolve(Qs, B, dt, "realization",
                                               return_info=True).info["order"]
    with pytest.raises(InputError, match="`robust`"):
        dc.make_solver("auto", {"robust": "tls-dt"})


def test_tls_column_scaling_invariance_and_gap_rule():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((30, 6))
    x = rng.standard_normal((6, 2))
    B = A @ x + 1e-3 * rng.standard_normal((30, 2))
    alpha = 1e4
    A2 = A.copy()
    A2[:, 2] *= alpha
    X1 = dc.truncated_tls(A, B, scale=True)
    X2 = dc.truncated_tls(A2, B, scale=True)
    expected = X1.copy()
    expected[2] /= alpha
    np.testing.assert_allclose(X2, expected, rtol=1e-9, atol=0)
    # without scaling TLS is not invariant (the dissertation's form)
    X3 = dc.truncated_tls(A2, B)
    assert not np.allclose(X3[2] * alpha, dc.truncated_tls(A, B)[2], rtol=1e-3)
    # the gap rule: an exact rank-4 A plus tiny noise has its gap after σ_4
    U = rng.standard_normal((30, 4))
    A4 = U @ rng.standard_normal((4, 6))
    B4 = A4 @ x
    s = np.linalg.svd(np.hstack([A4 + 1e-8 * rng.standard_normal(A4.shape), B4]),
                      compute_uv=False)
    assert dc.tls_rank(s, (30, 8), 6, rank="gap") == 4
    res = dc.solve(A4, B4, "tls-dt", rank="gap", scale=True, return_info=True)
    assert res.info["rank"] == 4 and res.info["rank_rule"] == "gap" and res.info["scaled"]
    with pytest.raises(InputError, match="`rank`"):
        dc.make_solver("tls-dt", {"rank": "elbow"})


def test_evidence_quadratic_has_no_cancellation_on_square_systems():
    # Q = yᵀ(I + ΦΦᵀ/γ)⁻¹y for a square Φ = diag(s): exactly Σ y² γ/(s² + γ), with d = s²,
    # z = s·y. The direct form yy − Σ z²/(d + γ) loses every digit at small γ (its sign
    # then decided the noise floor machine by machine; here a relative error of ~1e-6 at
    # γ = 1e-14·max d); the rewritten form keeps them.
    from podbench.sysid.deconvolution.kernel import _quadratic

    rng = np.random.default_rng(3)
    s = np.exp(rng.uniform(-3, 3, 50))
    y = rng.standard_normal(50)
    d, z2 = s**2, (s * y) ** 2
    for g in (1e-14 * d.max(), 1e-8 * d.max(), 1e-2 * d.max(), 10 * d.max()):
        exact = float(np.sum(y**2 * g / (d + g)))
        assert abs(_quadratic(float(y @ y), d, z2, g) - exact) <= 1e-12 * exact


def test_shape_decompositions_shared_by_refits_on_the_same_forces():
    """A refit on the same forces with other responses (a band's noise refit) reuses the
    kept shape decompositions: the same answer, bit for bit, as with none kept, the same
    evaluation count, and the shapes it shares are not decomposed again."""
    from podbench.sysid.deconvolution import kernel

    Qs, B, dt, _ = _chain(n=48, k=2, noise=0.01)
    B2 = B + 0.01 * B.std() * np.random.default_rng(7).standard_normal(B.shape)
    solver = dc.KernelRegularized(n_hyper=24)
    kernel._DECOMPOSED.clear()
    first = solver.solve(dc.ConvolutionSystem(Qs, B, dt))
    shapes = set(kernel._DECOMPOSED)
    assert len(shapes) == first.info["evaluations"] >= 25  # the 5 x 5 grid and the search
    again = solver.solve(dc.ConvolutionSystem(Qs, B2, dt))
    added = len(kernel._DECOMPOSED) - len(shapes)
    assert added <= again.info["evaluations"] - 25  # the grid's 25 starts were read back
    kernel._DECOMPOSED.clear()
    fresh = solver.solve(dc.ConvolutionSystem(Qs, B2, dt))
    np.testing.assert_array_equal(again.X, fresh.X)
    assert again.info == fresh.info
