"""Deconvolution solvers as objects: the Solver contract, true diagnostics, user solvers.

The diagnostics are checked against independent computations: the residual against a dense
``‖A X − B‖/‖B‖``, the GCV parameter against :func:`gcv_regularization`, the CGLS iteration
count by re-running with exactly that many (and one fewer) iterations, the TLS rank against
:func:`tls_rank` on an SVD of ``[A | B]``, the block shift and growth against the forces.
"""

from __future__ import annotations

import json
import pickle
import sys
import textwrap

import numpy as np
import pytest
import sklearn.base

from podbench.errors import (
    ConvergenceError,
    DimensionError,
    InputError,
    InvalidParameterError,
    UnknownNameError,
)
from podbench.sysid import deconvolution as dc

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

SOLVERS = {
    "ls": dc.LeastSquares,
    "tls-dt": dc.TruncatedTLS,
    "block": dc.BlockSubstitution,
    "fft": dc.FFTTikhonov,
    "cgls": dc.CGLS,
}
NON_DEFAULT = {  # one changed hyper-parameter per solver
    "ls": {"rcond": 1e-12},
    "tls-dt": {"rank": 5},
    "block": {"leaf": 8},
    "fft": {"reg": 1e-3, "pad": 3.0},
    "cgls": {"reg": 1e-4, "max_iter": 50},
}


def _system(n=60, k=2, r=2, lead=1, noise=1e-3, seed=0, dt=0.01):
    """Square block system (k load cases), a pulse-like force starting after ``lead`` zero
    samples with a dominant first nonzero sample, noisy right-hand side."""
    rng = np.random.default_rng(seed)
    Qs = []
    for j in range(k):
        Q = np.zeros((k, n))
        Q[:, lead:] = 0.5 * rng.standard_normal((k, n - lead)) * 0.5 ** np.arange(n - lead)
        Q[j, lead] += 4.0
        Qs.append(Q)
    X = rng.standard_normal((k * n, r)) * np.exp(-0.05 * np.tile(np.arange(n), k))[:, None]
    B = dc.convolution_product(Qs, X, dt)
    B = B + noise * np.abs(B).max() * rng.standard_normal(B.shape)
    return Qs, B, dt


# ------------------------------------------------------------------ the contract
@pytest.mark.parametrize("name", SOLVERS)
def test_params_clone_repr_pickle(name):
    cls = SOLVERS[name]
    assert cls.name == name and dc.get_solver(name) is cls
    assert cls.structured == (name in dc.structured_solvers())
    solver = cls(**NON_DEFAULT[name])
    params = solver.get_params()
    assert set(params) == set(cls._get_param_names()) >= set(NON_DEFAULT[name])
    assert all(params[key] == value for key, value in NON_DEFAULT[name].items())
    twin = sklearn.base.clone(solver)
    assert type(twin) is cls and twin is not solver and twin.get_params() == params
    assert cls().set_params(**NON_DEFAULT[name]).get_params() == params
    with pytest.raises(TypeError, match="unknown parameter 'nope'"):
        cls().set_params(nope=1)
    assert repr(solver).startswith(f"{cls.__name__}(") and all(
        f"{key}={value!r}" in repr(solver) for key, value in params.items())
    copy = pickle.loads(pickle.dumps(solver))
    assert type(copy) is cls and copy.get_params() == params


@pytest.mark.parametrize("name", SOLVERS)
def test_result_shape_info_keys_and_true_residual(name):
    Qs, B, dt = _system(seed=1)
    A = dc.block_convolution_matrix(Qs, dt)
    system = dc.ConvolutionSystem(Qs, B, dt)
    res = SOLVERS[name]().solve(system)
    assert res.X.shape == (A.shape[1], B.shape[1])
    np.testing.assert_array_equal(res.X, dc.deconvolve(Qs, B, dt, name))
    assert tuple(res.info)[: len(dc.INFO_KEYS)] == dc.INFO_KEYS
    assert res.info["solver"] == name
    assert json.loads(json.dumps(res.info)) == res.info  # JSON scalars only
    dense = np.linalg.norm(A @ res.X - B) / np.linalg.norm(B)
    assert res.info["residual"] == pytest.approx(dense, rel=1e-9)
    assert 1e-5 < dense < 0.5  # a noisy, inconsistent system: not a trivial 0
    # a vector right-hand side gives a vector solution
    v = dc.deconvolve(Qs, B[:, 0], dt, name, return_info=True)
    assert v.X.shape == (A.shape[1],)
    assert v.info["residual"] == pytest.approx(
        np.linalg.norm(A @ v.X - B[:, 0]) / np.linalg.norm(B[:, 0]), rel=1e-9)
    with pytest.raises(AttributeError):
        res.X = None  # frozen


def test_solve_validates_its_parameters_and_the_system():
    Qs, B, dt = _system()
    with pytest.raises(InputError, match="Parameter `reg`"):
        dc.CGLS(reg=-1.0).solve(dc.ConvolutionSystem(Qs, B, dt))
    with pytest.raises(InputError, match="Parameter `system`: expected a ConvolutionSystem"):
        dc.LeastSquares().solve((Qs, B, dt))


# ------------------------------------------------------------------ diagnostics are true
def test_fft_gcv_parameter_is_gcv_regularization_and_reproduces_x():
    Qs, B, dt = _system(seed=2)
    res = dc.deconvolve(Qs, B, dt, "fft", return_info=True)
    assert res.info["reg_rule"] == "gcv"
    assert res.info["reg"] == dc.gcv_regularization(Qs, B, dt)
    fixed = dc.deconvolve(Qs, B, dt, dc.FFTTikhonov(reg=res.info["reg"]), return_info=True)
    np.testing.assert_array_equal(fixed.X, res.X)
    assert fixed.info["reg_rule"] == "fixed" and fixed.info["reg"] == res.info["reg"]
    assert res.info["shift"] == 1 and res.info["iterations"] is None


def test_cgls_iteration_count_and_gcv_parameter_are_true():
    Qs, B, dt = _system(seed=3)
    system = dc.ConvolutionSystem(Qs, B, dt)
    res = dc.CGLS().solve(system)
    info = res.info
    assert info["reg_rule"] == "gcv" and info["solves"] >= 2  # GCV tried several parameters
    assert 0 < info["iterations"] <= info["solves"] * min(dc.TRIAL_ITER, 1000)
    # the chosen parameter, re-solved from zero, gives the same kernel (to the CG tolerance)
    fixed = dc.CGLS(reg=info["reg"]).solve(system)
    assert np.linalg.norm(fixed.X - res.X) <= 1e-7 * np.linalg.norm(res.X)
    # one solve: exactly `iterations` iterations are needed (one fewer does not converge)
    it = fixed.info["iterations"]
    assert fixed.info["solves"] == 1 and fixed.info["reg_rule"] == "fixed" and it > 0
    np.testing.assert_array_equal(dc.CGLS(reg=info["reg"], max_iter=it).solve(system).X,
                                  fixed.X)
    with pytest.raises(ConvergenceError, match=f"no convergence in {it - 1} iterations"):
        dc.CGLS(reg=info["reg"], max_iter=it - 1).solve(system)


@pytest.mark.parametrize("options", [{}, {"rcond": 1e-2}, {"noise_level": 1e-4}, {"rank": 40}])
def test_tls_rank_is_tls_rank_of_the_augmented_matrix(options):
    Qs, B, dt = _system(n=40, seed=4, noise=1e-2)
    A = dc.block_convolution_matrix(Qs, dt)
    _, s, Vt = np.linalg.svd(np.hstack([A, B]))
    s = s[:min(A.shape[0], A.shape[1] + B.shape[1])]
    res = dc.deconvolve(Qs, B, dt, "tls-dt", return_info=True, **options)
    p = dc.tls_rank(s, (A.shape[0], A.shape[1] + B.shape[1]), A.shape[1], **options)
    # the rule's rank, lowered while the TLS denominator λ_min(I − V21 V21ᵀ) is zero (the
    # non-generic problem; with the default cut this wide system's rank 79 has 6e-16)
    r = B.shape[1]

    def den(q):
        V21 = Vt[:q, A.shape[1]:].T
        return np.linalg.eigvalsh(np.eye(r) - V21 @ V21.T)[0]

    while den(p) < 1e-8:
        p -= 1
    assert res.info["rank"] == p and 0 < p <= A.shape[1]
    assert res.info["condition"] == pytest.approx(s[0] / s[p - 1], rel=1e-9)
    assert res.info["rcond"] == (options.get("rcond", dc.DEFAULT_TLS_RCOND)
                                 if set(options) <= {"rcond"} else None)
    np.testing.assert_array_equal(res.X, dc.truncated_tls(A, B, **options))


def test_ls_rank_and_condition():
    Qs, B, dt = _system(lead=2, seed=5)
    A = dc.block_convolution_matrix(Qs, dt)
    info = dc.deconvolve(Qs, B, dt, "ls", return_info=True).info
    # two zero leading samples: 2·k zero rows and columns of A
    assert info["rank"] == np.linalg.matrix_rank(A) == A.shape[1] - 2 * 2
    s = np.linalg.svd(A, compute_uv=False)
    assert info["condition"] >= s[0] / s[-5] and info["rcond"] == pytest.approx(
        np.finfo(float).eps * max(A.shape))


@pytest.mark.parametrize("lead", [0, 1, 3])
def test_block_shift_condition_and_growth(lead):
    Qs, B, dt = _system(lead=lead, seed=6)
    res = dc.deconvolve(Qs, B, dt, "block", return_info=True)
    G = np.stack(Qs)  # (k cases, k modes, n)
    norms = np.linalg.norm(G, axis=(0, 1))
    assert res.info["shift"] == lead == np.flatnonzero(norms)[0]
    assert res.info["condition"] == pytest.approx(np.linalg.cond(G[:, :, lead]), rel=1e-9)
    # ‖B‖ over the equations that hold an unknown (the first `lead` of each case do not)
    rows = np.linalg.norm(B.reshape(len(Qs), -1, B.shape[1])[:, lead:])
    growth = dt * norms.sum() * np.linalg.norm(res.X) / rows
    assert res.info["growth"] == pytest.approx(growth, rel=1e-9)
    assert res.info["reg"] is None and res.info["iterations"] is None


# ------------------------------------------------------------------ the system
def test_convolution_system_operators_against_the_dense_matrix():
    rng = np.random.default_rng(7)
    n, k, n_cases, dt = 23, 2, 3, 0.02
    Qs = [rng.standard_normal((k, n)) for _ in range(n_cases)]
    B = rng.standard_normal((n_cases * n, 4))
    system = dc.ConvolutionSystem(Qs, B, dt)
    A = dc.block_convolution_matrix(Qs, dt)
    assert (system.n, system.k, system.n_cases, system.n_rhs) == (n, k, n_cases, 4)
    assert system.shape == A.shape
    np.testing.assert_array_equal(system.dense(), A)
    X = rng.standard_normal((k * n, 3))
    Z = rng.standard_normal((n_cases * n, 2))
    np.testing.assert_allclose(system.matvec(X), A @ X, atol=1e-12)
    np.testing.assert_allclose(system.matvec(X[:, 0]), A @ X[:, 0], atol=1e-12)
    np.testing.assert_allclose(system.rmatvec(Z), A.T @ Z, atol=1e-12)
    np.testing.assert_allclose(system.rmatvec(Z[:, 1]), A.T @ Z[:, 1], atol=1e-12)
    Xs = rng.standard_normal((k * n, 4))
    assert system.residual(Xs) == pytest.approx(
        np.linalg.norm(A @ Xs - B) / np.linalg.norm(B), rel=1e-12)
    for Q, Qj in zip(system.Q_list, Qs, strict=True):
        np.testing.assert_array_equal(Q, Qj)
    assert not system.G.flags.writeable and not system.Y.flags.writeable
    with pytest.raises(InputError, match=r"ConvolutionSystem.dense: .* 69 × 46"):
        system.dense(max_bytes=1000)
    with pytest.raises(DimensionError, match="Parameter `X`: expected 46 rows"):
        system.matvec(X[:-1])
    with pytest.raises(DimensionError, match="Parameter `B`: expected 69 rows"):
        dc.ConvolutionSystem(Qs, B[:-1], dt)
    with pytest.raises(InputError, match="dt"):
        dc.ConvolutionSystem(Qs, B, 0.0)


# ------------------------------------------------------------------ a user's solver
USER_FILE = '''
import scipy.linalg

from podbench.deconvolution import Solver


class ScipyLstsq(Solver):
    """Minimum-norm least squares by scipy.linalg.lstsq on the dense matrix."""

    name = "scipy-lstsq"

    def __init__(self, *, driver="gelsd"):
        self.driver = driver

    def _validate_params(self):
        from podbench.errors import InputError
        if self.driver not in ("gelsd", "gelsy", "gelss"):
            raise InputError(f"Parameter `driver`: unknown LAPACK driver {self.driver!r}")

    def _solve(self, system):
        X, _, rank, _ = scipy.linalg.lstsq(system.dense(solver=self.name), system.B,
                                           lapack_driver=self.driver)
        return X, {"rank": int(rank)}


class NotASolver:
    def solve(self, system):
        return None
'''


@pytest.fixture
def user_dir(tmp_path):
    (tmp_path / "my_solvers.py").write_text(textwrap.dedent(USER_FILE), encoding="utf-8")
    yield tmp_path
    for key in [k for k in sys.modules if k.startswith("podbench_user_")
                and k.endswith("_my_solvers")]:
        sys.modules.pop(key)


def test_user_solver_from_a_file_matches_ls_and_pickles(user_dir):
    Qs, B, dt = _system(lead=1, seed=8)
    ref = dc.deconvolve(Qs, B, dt, "ls")
    solver = dc.make_solver("my_solvers.py:ScipyLstsq", {"driver": "gelsd"}, base_dir=user_dir)
    assert isinstance(solver, dc.Solver) and solver.name == "scipy-lstsq"
    res = dc.deconvolve(Qs, B, dt, solver, return_info=True)
    np.testing.assert_allclose(res.X, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    assert res.info["solver"] == "scipy-lstsq" and res.info["rank"] == 2 * 60 - 2
    assert sklearn.base.clone(solver).get_params() == {"driver": "gelsd"}
    # pickled, and unpickled where the user's module was never imported (a fresh worker)
    blob = pickle.dumps(solver)
    for key in [k for k in sys.modules if k.endswith("_my_solvers")]:
        sys.modules.pop(key)
    copy = pickle.loads(blob)
    assert type(copy).__name__ == "ScipyLstsq" and copy.get_params() == {"driver": "gelsd"}
    np.testing.assert_array_equal(dc.deconvolve(Qs, B, dt, copy), res.X)
    with pytest.raises(InputError, match="Parameter `driver`"):
        dc.make_solver("my_solvers.py:ScipyLstsq", {"driver": "magic"}, base_dir=user_dir)
    with pytest.raises(InputError, match="'my_solvers.py:NotASolver' is not a podbench"):
        dc.make_solver("my_solvers.py:NotASolver", base_dir=user_dir)
    with pytest.raises(InputError, match='Parameter `solver`: no such file ".*nope.py"'):
        dc.make_solver("nope.py:ScipyLstsq", base_dir=user_dir)


# ------------------------------------------------------------------ make_solver
def test_make_solver_builds_and_rejects():
    solver = dc.make_solver("cgls", {"reg": 1e-3, "max_iter": 20})
    assert isinstance(solver, dc.CGLS) and (solver.reg, solver.max_iter) == (1e-3, 20)
    assert dc.make_solver(solver) is solver
    assert isinstance(dc.make_solver(dc.FFTTikhonov, {"pad": 4}), dc.FFTTikhonov)
    with pytest.raises(UnknownNameError,
                       match="Parameter `solver`: unknown solver 'nope'; built-in: 'ls', 'tls-dt', "
                             "'tls-appendix', 'tls-balanced', 'block', 'fft', 'cgls'"):
        dc.make_solver("nope")
    with pytest.raises(InputError, match=r"Parameter `solver_options`: unknown option 'regg' "
                                         r"for solver 'cgls' \(its options: reg, tol, max_iter\)"):
        dc.make_solver("cgls", {"regg": 1e-3})
    with pytest.raises(InvalidParameterError, match=r"^Parameter `max_iter`: expected None or "
                                                    r"an integer >= 1, got 2\.5$") as info:
        dc.make_solver("cgls", {"max_iter": 2.5})
    assert info.value.param == "max_iter"
    with pytest.raises(InvalidParameterError, match=r"^Parameter `rcond`: expected a number "
                                                    r"in \(0, 1\), got 2\.0$"):
        dc.make_solver("tls-dt", {"rcond": 2.0})
    with pytest.raises(InputError, match="Parameters `rcond`, `noise_level`, `rank`"):
        dc.make_solver("tls-dt", {"rcond": 1e-2, "rank": 3})
    with pytest.raises(InputError, match="Parameter `solver_options`: options \\['reg'\\] given "
                                         "with the solver instance"):
        dc.make_solver(solver, {"reg": 1.0})
    with pytest.raises(InvalidParameterError,
                       match="Parameter `solver_options`: expected None or a dict"):
        dc.make_solver("ls", [("rcond", 1e-3)])
    with pytest.raises(InputError, match="Parameter `solver`: expected a solver name"):
        dc.make_solver(3)
    with pytest.raises(InputError, match="Parameter `max_dense_bytes`"):
        dc.make_solver("ls", {"max_dense_bytes": -1})
