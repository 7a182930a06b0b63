"""Bad input is rejected with podbench errors (ValueError subclasses) and clear messages."""

from __future__ import annotations

import numpy as np
import pytest

from podbench.errors import DimensionError, IllConditionedError, InputError
from podbench.sysid.methods import MDS, POVR, MixedResponse, MultipleLoad, SingleLoad

from ._cases import D, forced_case, free_case, mixed_case
from ._truth import eigenmodes, pulse


@pytest.fixture
def free():
    return free_case("coupled", "displacement")


@pytest.fixture
def vel():
    return free_case("coupled", "velocity")


@pytest.fixture
def forced():
    return forced_case("coupled")


@pytest.fixture
def mixed():
    return mixed_case("coupled")


def test_errors_are_value_errors():
    for err in (InputError, DimensionError, IllConditionedError):
        assert issubclass(err, ValueError)


# ------------------------------------------------------------------ shared checks
def test_nan_and_inf_in_data(free, forced):
    W = free.W[0].copy()
    W[2, 7] = np.nan
    with pytest.raises(InputError, match="`W`: contains 1 NaN or Inf"):
        POVR(n_modes=2).fit(W)
    with pytest.raises(InputError, match=r"`W\[1\]`: contains 1 NaN or Inf"):
        MDS().fit([free.W[0], W])
    F = forced.F[0].copy()
    F[0, 3] = np.inf
    with pytest.raises(InputError, match="`F`: contains 1 NaN or Inf"):
        SingleLoad(n_modes=2).fit(forced.W[0], F, dt=forced.dt)
    x = free.x0[0].copy()
    x[0] = np.nan
    with pytest.raises(InputError, match="`x0`: contains 1 NaN"):
        POVR(n_modes=2).fit(free.W[0], x)


def test_n_modes_above_the_rank_of_the_data(free):
    rng = np.random.default_rng(0)
    W = rng.standard_normal((D, 2)) @ rng.standard_normal((2, 50))  # rank 2
    with pytest.raises(InputError, match="numerical rank 2"):
        POVR(n_modes=3).fit(W)
    with pytest.raises(InputError, match="numerical rank 2"):
        MDS().fit([W, W, W])
    with pytest.raises(InputError, match="numerical rank 5"):
        POVR(n_modes=6).fit(free.W[0])


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "3"])
def test_n_modes_must_be_a_positive_integer(free, bad):
    with pytest.raises(InputError, match="n_modes"):
        POVR(n_modes=bad).fit(free.W[0])


def test_unknown_keywords_are_type_errors(free, forced):
    with pytest.raises(TypeError):
        POVR(n_modes=2).fit(free.W[0], free.x0[0], bassis=None)
    with pytest.raises(TypeError):
        SingleLoad(n_modes=2).fit(forced.W[0], forced.F[0], forced.dt)  # dt is keyword-only
    with pytest.raises(TypeError):
        MDS(excitations="velocity")


def test_basis_checks(free):
    Q = np.linalg.qr(np.random.default_rng(1).standard_normal((D, 3)))[0]
    with pytest.raises(InputError, match="not orthonormal"):
        POVR().fit(free.W[0], basis=2 * Q)
    with pytest.raises(DimensionError, match="expected 5 rows"):
        POVR().fit(free.W[0], basis=Q[:4])
    with pytest.raises(InputError, match="`n_modes`: 2 differs from the 3 columns"):
        POVR(n_modes=2).fit(free.W[0], basis=Q)


def test_predict_shapes(free, forced):
    model = POVR(n_modes=2).fit(free.W[0])
    with pytest.raises(DimensionError, match=r"`x0_new`: expected shape \(5,\)"):
        model.predict(np.ones(4))
    sl = SingleLoad(n_modes=2).fit(forced.W[0], forced.F[0], dt=forced.dt)
    with pytest.raises(DimensionError, match=r"n' <= 200"):
        sl.predict(np.zeros((D, 201)))
    with pytest.raises(DimensionError, match="`F_new`: expected shape"):
        sl.predict(np.zeros((4, 10)))


# ------------------------------------------------------------------ POVR
def _two_mode_data(n=80):
    """W = σ1 u1 v1ᵀ + σ2 u2 v2ᵀ with v2(0) = 0: mode 2 is absent from W[:, 0].

    v1, v2 are exactly orthogonal (whole periods on a periodic grid), so u1, u2 are the POMs.
    """
    t = np.arange(n) / n
    u1 = np.array([1.0, 1, 1, 1, 1]) / np.sqrt(5)
    u2 = np.array([1.0, -1, 0, 1, -1]) / 2
    W = np.outer(u1, np.cos(2 * np.pi * 3 * t)) + 0.5 * np.outer(u2, np.sin(2 * np.pi * 7 * t))
    return W, u1, u2


def test_povr_initial_value_too_small_suggests_mds():
    W, *_ = _two_mode_data()
    with pytest.raises(IllConditionedError,
                       match=r"initial POC value of mode\(s\) 2 is too small.*use MDS"):
        POVR(n_modes=2).fit(W)


def test_povr_initial_derivative_too_small_suggests_mds():
    W, u1, _ = _two_mode_data()
    with pytest.raises(IllConditionedError,
                       match=r"initial POC derivative of mode\(s\) 2 is too small.*MDS"):
        POVR(n_modes=2, excitation="velocity").fit(W, 3 * u1)  # no velocity in mode 2


def test_povr_threshold_is_the_tol_parameter():
    W, u1, u2 = _two_mode_data()
    x0 = u1 + 1e-5 * u2  # modal share 1e-5 of ‖x0‖
    with pytest.raises(IllConditionedError, match="tol = 0.0001"):
        POVR(n_modes=2, excitation="velocity", tol=1e-4).fit(W, x0)
    POVR(n_modes=2, excitation="velocity", tol=1e-6).fit(W, x0)  # accepted


def test_povr_velocity_needs_the_profile_and_a_nonzero_one(vel):
    with pytest.raises(InputError, match="initial velocity profile v0.*required"):
        POVR(n_modes=2, excitation="velocity").fit(vel.W[0])
    with pytest.raises(IllConditionedError, match="profile is zero"):
        POVR(n_modes=2, excitation="velocity").fit(vel.W[0], np.zeros(D))


# ------------------------------------------------------------------ MDS
def test_mds_shape_mismatch_between_data_sets(free):
    with pytest.raises(DimensionError, match=r"`W\[1\]`: shape \(5, 199\) differs"):
        MDS().fit([free.W[0], free.W[1][:, :-1]])
    with pytest.raises(DimensionError, match=r"`W\[1\]`: shape \(4, 200\) differs"):
        MDS().fit([free.W[0], free.W[1][:4]])
    with pytest.raises(DimensionError, match="wrap it in a list"):
        MDS().fit(free.W[0])


def test_mds_fewer_data_sets_than_modes(free):
    with pytest.raises(InputError, match=r"fewer data sets \(2\) than modes \(3\)"):
        MDS(n_modes=3).fit(free.W[:2])


def test_mds_dependent_initial_profiles_report_the_condition_number(free):
    W3 = free.W[0] + free.W[1]  # response to w0¹ + w0² (linear system)
    with pytest.raises(IllConditionedError, match=r"linearly dependent.*condition number of "
                       r"V̂0.* is (inf|\d\.\d+e\+\d+) > max_cond = 1e\+10"):
        MDS().fit([free.W[0], free.W[1], W3])


def test_mds_profile_count_and_velocity_requirement(vel):
    with pytest.raises(DimensionError, match="expected 3 profiles"):
        MDS(excitation="velocity").fit(vel.W[:3], vel.x0[:2])
    with pytest.raises(InputError, match="required for excitation='velocity'"):
        MDS(excitation="velocity").fit(vel.W[:3])
    with pytest.raises(DimensionError, match="single 1-D array"):
        MDS(excitation="velocity").fit(vel.W[:3], vel.x0[0])


# ------------------------------------------------------------------ SL / ML
@pytest.mark.parametrize("dt", [0.0, -0.01, None, np.nan])
def test_dt_must_be_positive(forced, dt):
    with pytest.raises(InputError, match="dt"):
        SingleLoad(n_modes=2).fit(forced.W[0], forced.F[0], dt=dt)
    with pytest.raises(InputError, match="dt"):
        MultipleLoad().fit(forced.W[:2], forced.F[:2], dt=dt)


def test_force_shape_must_match_snapshots(forced):
    with pytest.raises(DimensionError, match=r"`F`: force matrix shape \(5, 199\) differs"):
        SingleLoad(n_modes=2).fit(forced.W[0], forced.F[0][:, :-1], dt=forced.dt)
    with pytest.raises(DimensionError, match=r"`F\[1\]`: force matrix shape"):
        MultipleLoad().fit(forced.W[:2], [forced.F[0], forced.F[1][:4]], dt=forced.dt)
    with pytest.raises(DimensionError, match="expected 2 force matrices"):
        MultipleLoad().fit(forced.W[:2], forced.F[:3], dt=forced.dt)


def test_ml_fewer_load_cases_than_modes(forced):
    with pytest.raises(InputError, match=r"fewer load cases \(2\) than modes \(3\)"):
        MultipleLoad(n_modes=3).fit(forced.W[:2], forced.F[:2], dt=forced.dt)


def test_ml_dependent_load_cases_report_the_condition_number(forced):
    W = [forced.W[0], forced.W[1], 2 * forced.W[0] - forced.W[1]]
    F = [forced.F[0], forced.F[1], 2 * forced.F[0] - forced.F[1]]
    with pytest.raises(IllConditionedError,
                       match=r"load cases are \(nearly\) linearly dependent.*condition number"):
        MultipleLoad().fit(W, F, dt=forced.dt)


def test_sl_load_orthogonal_to_a_mode():
    fc = forced_case("ideal")
    Phi = eigenmodes(fc.M, fc.K)
    F = np.outer(Phi[:, 0], pulse(1, fc.n, 0)[0])  # loads only eigenmode 1
    W = np.outer(Phi[:, 0], np.linspace(0, 1, fc.n)) + 1e-3 * fc.W[0]
    with pytest.raises(IllConditionedError, match=r"modal force of mode\(s\) 2, 3, 4, 5"):
        SingleLoad().fit(W, F, dt=fc.dt, basis=Phi)


def test_solver_name_and_options(forced):
    with pytest.raises(InputError, match="`solver`: unknown solver 'wiener'; built-in: 'ls'"):
        SingleLoad(n_modes=2, solver="wiener").fit(forced.W[0], forced.F[0], dt=forced.dt)
    with pytest.raises(InputError, match="solver_options"):
        SingleLoad(n_modes=2, solver_options=[1]).fit(forced.W[0], forced.F[0], dt=forced.dt)
    with pytest.raises(InputError, match="`solver_options`: unknown option 'rcnd'"):
        SingleLoad(n_modes=2, solver_options={"rcnd": 1}).fit(forced.W[0], forced.F[0],
                                                               dt=forced.dt)
    with pytest.raises(InputError, match="at most one truncation rule"):
        MultipleLoad(n_modes=2, solver="tls-dt", solver_options={"rcond": 1e-2, "rank": 3}).fit(
            forced.W[:2], forced.F[:2], dt=forced.dt)


# ------------------------------------------------------------------ MR
def _mr(mc, **kw):
    args = dict(w0=mc.w0, v0=mc.v0, F=mc.F, dt=mc.dt)
    args.update(kw)
    W = args.pop("W", mc.W)
    return MixedResponse(n_modes=3).fit(W, **args)


def test_mr_needs_three_data_sets(mixed):
    with pytest.raises(InputError, match="exactly 3 training records"):
        _mr(mixed, W=mixed.W[:2], w0=mixed.w0[:2], v0=mixed.v0[:2], F=mixed.F[:2])


def test_mr_zero_reference_initial_conditions(mixed):
    with pytest.raises(IllConditionedError, match="u_iᵀw0_a.*Eqs. 3.58"):
        _mr(mixed, w0=[np.zeros(D), mixed.w0[1], mixed.w0[2]])
    with pytest.raises(IllConditionedError, match="u_iᵀv0_a"):
        _mr(mixed, v0=[np.zeros(D), mixed.v0[1], mixed.v0[2]])


def test_mr_proportional_initial_conditions_cannot_be_separated(mixed):
    w0 = [mixed.w0[0], 2 * mixed.w0[0], mixed.w0[2]]
    v0 = [mixed.v0[0], 2 * mixed.v0[0], mixed.v0[2]]
    with pytest.raises(IllConditionedError, match="r_bv − r_bd = 0"):
        _mr(mixed, w0=w0, v0=v0)


def test_mr_loads_must_be_separable(mixed):
    zero = [np.zeros_like(F) for F in mixed.F]
    with pytest.raises(IllConditionedError, match="combined modal force"):
        _mr(mixed, F=zero)


def test_mr_predict_needs_an_excitation(mixed):
    model = _mr(mixed)
    with pytest.raises(InputError, match="at least one of"):
        model.predict()
    with pytest.raises(DimensionError, match="`v0`: expected shape"):
        model.predict(v0=np.ones(3))


def test_mr_requires_velocities_and_forces(mixed):
    with pytest.raises(InputError, match="v0"):
        MixedResponse(n_modes=3).fit(mixed.W, w0=mixed.w0, F=mixed.F, dt=mixed.dt)
