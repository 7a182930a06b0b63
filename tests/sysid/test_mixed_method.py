"""MixedResponse (§3.4) against an independent Newmark truth (``_truth``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg

from podbench import Record
from podbench.sysid.deconvolution import convolution_matrix
from podbench.sysid.methods import MixedResponse

from ._cases import D, mixed_case
from ._contract import MethodContract
from ._truth import eigenmodes, ideal_chain, newmark, pulse, rel_err

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _mr_case(scaling="ratio"):
    mc = mixed_case("coupled")
    return SimpleNamespace(
        params=dict(n_modes=3, velocity_scaling=scaling),
        fit=lambda model, basis=None: model.fit(mc.W, w0=mc.w0, v0=mc.v0, F=mc.F, dt=mc.dt,
                                                basis=basis),
        predict_train=lambda model: [
            (model.predict(w0=mc.w0[j], v0=mc.v0[j], F=mc.F[j]), mc.W[j]) for j in range(3)
        ],
        predict_new=lambda model: model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new),
        bad_param=("velocity_scaling", "spline"),
        records=[Record(W=mc.W[j], F=mc.F[j], w0=mc.w0[j], v0=mc.v0[j], dt=mc.dt)
                 for j in range(3)],
        target=Record(W=mc.W_all, F=mc.F_new, w0=mc.w0_new, v0=mc.v0_new, dt=mc.dt),
    )


class TestMixedResponseContract(MethodContract):
    method = MixedResponse

    def case(self):
        return _mr_case()


def _parts(model, mc):
    return {
        "w0": rel_err(model.predict(w0=mc.w0_new), mc.W_w0),
        "v0": rel_err(model.predict(v0=mc.v0_new), mc.W_v0),
        "F": rel_err(model.predict(F=mc.F_new), mc.W_F),
        "all": rel_err(model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new), mc.W_all),
    }


def _fit(mc, **kw):
    """MR fitted on ``mc``; velocity scaling ``"ratio"`` unless given (the exact one: these
    tests check the method's exactness; the default, Eq. 3.64, has an O(ωΔt) bias)."""
    basis = kw.pop("basis", None)
    kw.setdefault("velocity_scaling", "ratio")
    return MixedResponse(**kw).fit(mc.W, w0=mc.w0, v0=mc.v0, F=mc.F, dt=mc.dt, basis=basis)


def test_mr_is_exact_in_the_eigenmode_basis_of_the_ideal_chain():
    """Diagonal Φ11, Φ12, C hold exactly in the eigenmode basis: every part is exact."""
    mc = mixed_case("ideal")
    errs = _parts(_fit(mc, basis=eigenmodes(mc.M, mc.K)), mc)
    assert max(errs.values()) < 1e-9, errs


SEEDS = range(10)


def _median_parts(name):
    errs = [_parts(_fit(mixed_case(name, seed), n_modes=D), mixed_case(name, seed))
            for seed in SEEDS]
    return {key: float(np.median([e[key] for e in errs])) for key in errs[0]}


@pytest.mark.slow  # two chains' noisy fits over seeds: about 20 s
def test_mr_with_poms_is_better_on_the_ideal_than_on_the_coupled_chain():
    """POMs of case a (k = m = 5), ten random excitation sets per chain.

    Measured medians (worst): ideal w0 0.11 (0.29), v0 0.16 (1.35), F 0.19 (1.03);
    coupled w0 0.43 (0.98), v0 0.80 (5.2), F 0.83 (16.7). MR is far more sensitive to the
    POMs not being eigenmodes than POVR or SL (see the next test); it is exact when they are.
    """
    ideal, coupled = _median_parts("ideal"), _median_parts("coupled")
    for key in ("w0", "v0", "F"):
        assert ideal[key] < 0.25, ideal
        assert ideal[key] < coupled[key], (ideal, coupled)


def test_mr_error_grows_linearly_with_the_basis_departure_from_eigenmodes():
    """Basis = eigenmodes rotated by expm(ε A): error ≈ g·ε, with a gain g ≈ 5–12 here
    (measured: ε = 1e-4 → 5e-4, 5e-4, 1.2e-3 for w0, v0, F; ×10 at ε = 1e-3)."""
    mc = mixed_case("ideal")
    Phi = eigenmodes(mc.M, mc.K)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((D, D))
    A = A - A.T
    errs = {}
    for eps in (1e-4, 1e-3):
        basis = Phi @ scipy.linalg.expm(eps * A)
        errs[eps] = _parts(_fit(mc, basis=basis), mc)
    for key in ("w0", "v0", "F"):
        assert errs[1e-4][key] < 5e-3
        assert errs[1e-3][key] / errs[1e-4][key] == pytest.approx(10, rel=0.2)


def test_displacement_history_starts_at_the_initial_coordinate():
    """D[0] = u_iᵀw0_a and V[0] = 0, so scaling by u_iᵀw̃0/u_iᵀw0_a (Eq. 3.58) equals the
    MATLAB's u_iᵀw̃0 / D[0]."""
    mc = mixed_case("coupled")
    model = _fit(mc, n_modes=3)
    a = model.initial_displacement_coordinates_
    np.testing.assert_allclose(model.disp_histories_[:, 0], a, rtol=1e-10)
    np.testing.assert_allclose(model.vel_histories_[:, 0], 0, atol=1e-12 * np.abs(a).max())
    # Eqs. 3.62-3.63 only split D and V into POV × unit POC
    np.testing.assert_allclose(np.linalg.norm(model.pocs_disp_, axis=0), 1)
    np.testing.assert_allclose(model.pocs_disp_ * model.povs_disp_, model.disp_histories_.T)
    np.testing.assert_allclose(model.pocs_vel_ * model.povs_vel_, model.vel_histories_.T)


def test_mr_is_the_matlab_elimination():
    """Transcription of the appendix's loop (inv(Q) replaced by pinv: Q is singular when the
    forces start with a zero sample; the MATLAB's inv would fail there)."""
    mc = mixed_case("coupled")
    k, dt = 3, mc.dt
    model = _fit(mc, n_modes=k)
    Ua = np.linalg.svd(mc.W[0], full_matrices=False)[0][:, :k]
    Ua = Ua * np.sign(np.sum(Ua * model.modes_, axis=0))
    Va, Vb, Vc = ((Ua.T @ W).T for W in mc.W)
    qa, qb, qc = (Ua.T @ F for F in mc.F)
    for i in range(k):
        u = Ua[:, i]
        rbad = (u @ mc.w0[1]) / (u @ mc.w0[0])
        rbav = (u @ mc.v0[1]) / (u @ mc.v0[0])
        rcad = (u @ mc.w0[2]) / (u @ mc.w0[0])
        rcav = (u @ mc.v0[2]) / (u @ mc.v0[0])
        Rcb = (rcav - rcad) / (rbav - rbad)
        Qa, Qb, Qc = (np.tril(np.array([[q[i, r - c] if r >= c else 0 for c in range(mc.n)]
                                        for r in range(mc.n)])) for q in (qa, qb, qc))
        Q = Qc - rcad * Qa - Rcb * (Qb - rbad * Qa)
        dtC = np.linalg.pinv(Q) @ (Vc[:, i] - rcad * Va[:, i] - Rcb * (Vb[:, i] - rbad * Va[:, i]))
        V_iv = (Vb[:, i] - rbad * Va[:, i] - (Qb - rbad * Qa) @ dtC) / (rbav - rbad)
        V_id = Va[:, i] - V_iv - Qa @ dtC
        tol = 1e-8 * np.abs(Va[:, i]).max()
        np.testing.assert_allclose(model.vel_histories_[i], V_iv, atol=tol)
        np.testing.assert_allclose(model.disp_histories_[i], V_id, atol=tol)
        np.testing.assert_allclose(model.pov_ratios_[i], [rbad, rbav, rcad, rcav], rtol=1e-10)
        # the MATLAB's dtCbar is Δt times our kernel (Eq. 3.39 keeps Δt); compare its effect
        q_new = Ua[:, i] @ mc.F_new
        np.testing.assert_allclose(
            convolution_matrix(q_new, dt) @ model.kernel_[i, i],
            convolution_matrix(q_new, 1.0) @ dtC, atol=tol)


def _one_dof_fd_ratio(omega, c, dt):
    """(w1 − w0)/Δt of a unit-mass oscillator started with unit velocity (_truth Newmark)."""
    W, _ = newmark(np.eye(1), np.array([[c]]), np.array([[omega**2]]), dt, 2, v0=[1.0])
    return (W[0, 1] - W[0, 0]) / dt


def test_finite_difference_derivative_is_the_newmark_one_step_difference():
    """Eq. 3.64 in the eigenmode basis: V̇(0) = u_iᵀv0_a · (w1 − w0)/Δt of the modal
    oscillator (ω_i, modal damping α + β ω_i²), an independent one-DOF computation."""
    mc = mixed_case("ideal")
    Phi = eigenmodes(mc.M, mc.K)
    model = _fit(mc, basis=Phi, velocity_scaling="finite_difference")
    omega = np.sqrt(np.diag(Phi.T @ mc.K @ Phi))
    cmod = np.diag(Phi.T @ mc.C @ Phi)
    expected = np.array([_one_dof_fd_ratio(w, c, mc.dt) for w, c in zip(omega, cmod,
                                                                          strict=True)])
    np.testing.assert_allclose(
        model.velocity_derivative_ / model.initial_velocity_coordinates_, expected, rtol=1e-8)
    assert expected.min() < 0.6  # at ω Δt ≈ 1.9 the one-sided difference is far off


def test_velocity_scaling_ratio_vs_finite_difference():
    """Both options on the same data (eigenmode basis, so only the scaling differs):
    ratio exact; finite differences biased, the bias shrinking with Δt.
    Measured FD errors: 0.117 (Δt = 0.01 s), 0.0048 (Δt = 0.002 s)."""
    M, C, K = ideal_chain(D)
    Phi = eigenmodes(M, K)
    fd_err = {}
    for dt in (0.01, 0.002):
        n = 400
        rng = np.random.default_rng(14)
        w0 = [0.01 * rng.standard_normal(D) for _ in range(3)]
        v0 = [rng.standard_normal(D) for _ in range(3)]
        F = [pulse(D, n, j, width=3) for j in (4, 2, 0)]
        W = [newmark(M, C, K, dt, n, w0=a, v0=b, F=c)[0] for a, b, c in zip(w0, v0, F,
                                                                           strict=True)]
        v_new = rng.standard_normal(D)
        W_new = newmark(M, C, K, dt, n, v0=v_new)[0]
        for scaling in ("ratio", "finite_difference"):
            model = MixedResponse(velocity_scaling=scaling).fit(W, w0=w0, v0=v0, F=F, dt=dt,
                                                                 basis=Phi)
            err = rel_err(model.predict(v0=v_new), W_new)
            if scaling == "ratio":
                assert err < 1e-9
            else:
                fd_err[dt] = err
    assert fd_err[0.01] > 0.05
    assert fd_err[0.002] < 0.2 * fd_err[0.01]


def test_predict_parts_superpose_and_shorter_force():
    mc = mixed_case("coupled")
    model = _fit(mc, n_modes=3)
    total = model.predict(w0=mc.w0_new, v0=mc.v0_new, F=mc.F_new)
    parts = model.predict(w0=mc.w0_new) + model.predict(v0=mc.v0_new) + model.predict(F=mc.F_new)
    np.testing.assert_allclose(total, parts, atol=1e-12 * np.abs(total).max())
    short = model.predict(w0=mc.w0_new, F=mc.F_new[:, :30])
    assert short.shape == (D, 30)
    np.testing.assert_allclose(short, model.predict(w0=mc.w0_new, F=mc.F_new)[:, :30],
                               atol=1e-12 * np.abs(total).max())


def test_default_w0_is_first_column():
    mc = mixed_case("coupled")
    a = MixedResponse(n_modes=3).fit(mc.W, v0=mc.v0, F=mc.F, dt=mc.dt)
    b = _fit(mc, n_modes=3)
    np.testing.assert_allclose(a.predict(w0=mc.w0_new), b.predict(w0=mc.w0_new), rtol=1e-12)


@pytest.mark.parametrize("solver", ["ls", "tls-dt"])
def test_solvers_agree_on_clean_data(solver):
    mc = mixed_case("ideal")
    errs = _parts(_fit(mc, basis=eigenmodes(mc.M, mc.K), solver=solver), mc)
    assert max(errs.values()) < 1e-8, errs


# --- Eq. 3.64 as the default; the design rule (podbench.methods.mixed_design) ---------------

def test_default_velocity_scaling_is_the_finite_difference_of_eq_3_64():
    """The text's and the appendix MATLAB's scaling is the default; "ratio" stays an option."""
    assert MixedResponse().velocity_scaling == "finite_difference"
    mc = mixed_case("ideal")
    recs = [Record(W=mc.W[j], F=mc.F[j], w0=mc.w0[j], v0=mc.v0[j], dt=mc.dt) for j in range(3)]
    fd = MixedResponse(n_modes=3).fit(recs)
    assert fd.velocity_scaling_ == "finite_difference"
    s = (fd.modes_.T @ mc.v0_new) / fd.velocity_derivative_
    np.testing.assert_allclose(fd.predict(v0=mc.v0_new),
                               fd.modes_ @ (fd.vel_histories_ * s[:, None]), rtol=1e-12)
    ratio = MixedResponse(n_modes=3, velocity_scaling="ratio").fit(recs)
    assert not np.allclose(fd.predict(v0=mc.v0_new), ratio.predict(v0=mc.v0_new))


def _records(mc):
    return [Record(W=mc.W[j], F=mc.F[j], w0=mc.w0[j], v0=mc.v0[j], dt=mc.dt) for j in range(3)]


def test_design_conditioning_is_the_worst_cancellation_of_mr_elimination():
    """κ = max_i max(κ_sep, κ_g), recomputed here from its definition; it agrees with the
    ratios MR itself uses (pov_ratios_)."""
    from podbench.sysid.methods.mixed_design import design_conditioning

    mc = mixed_case("coupled")
    recs = _records(mc)
    cond = design_conditioning(recs, 3)
    model = MixedResponse(n_modes=3).fit(recs)
    r_bd, r_bv, r_cd, r_cv = model.pov_ratios_.T
    U = model.modes_
    q = [U.T @ r.F for r in recs]
    R = (r_cv - r_cd) / (r_bv - r_bd)
    k_sep = (abs(r_bv) + abs(r_bd)) / abs(r_bv - r_bd)
    qn = [np.linalg.norm(x, axis=1) for x in q]
    g = q[2] - r_cd[:, None] * q[0] - R[:, None] * (q[1] - r_bd[:, None] * q[0])
    k_g = (qn[2] + abs(r_cd) * qn[0] + abs(R) * (qn[1] + abs(r_bd) * qn[0])) \
        / np.linalg.norm(g, axis=1)
    np.testing.assert_allclose(cond.separation, k_sep, rtol=1e-12)
    np.testing.assert_allclose(cond.force, k_g, rtol=1e-12)
    assert cond.value == pytest.approx(max(k_sep.max(), k_g.max()), rel=1e-12)
    assert cond.n_modes == 3 and cond.admissible and cond.value >= 1


def test_design_conditioning_uses_the_training_records_only():
    """W_b, W_c do not enter (only W_a's POMs, w0, v0, F); a target cannot enter (the
    function has no such input), and the study's κ of a design does not change when the
    targets do."""
    from podbench.sysid.methods.mixed_design import design_conditioning

    mc = mixed_case("coupled")
    recs = _records(mc)
    ref = design_conditioning(recs, 3).value
    recs2 = [recs[0]] + [Record(W=np.zeros_like(r.W), F=r.F, w0=r.w0, v0=r.v0, dt=r.dt)
                         for r in recs[1:]]
    assert design_conditioning(recs2, 3).value == ref
    v0b = 2.0 * mc.v0[1]
    recs3 = [recs[0], Record(W=mc.W[1], F=mc.F[1], w0=mc.w0[1], v0=v0b, dt=mc.dt), recs[2]]
    assert design_conditioning(recs3, 3).value != ref


def test_inseparable_design_is_inadmissible():
    """Case b = 2 × case a's initial conditions: r_bv = r_bd, D and V cannot be separated."""
    from podbench.sysid.methods.mixed_design import design_conditioning

    mc = mixed_case("coupled")
    recs = _records(mc)
    recs[1] = Record(W=mc.W[1], F=mc.F[1], w0=2.0 * mc.w0[0], v0=2.0 * mc.v0[0], dt=mc.dt)
    cond = design_conditioning(recs, 3)
    assert not cond.admissible and cond.value > 1e6


def test_choose_design_is_the_argmin_of_the_rule():
    from podbench.sysid.methods.mixed_design import choose_design, design_conditioning

    cands = {}
    for seed in range(6):
        cands[f"seed{seed}"] = _records(mixed_case("coupled", seed))
    best, values = choose_design(cands, 3)
    assert values == {k: design_conditioning(v, 3).value for k, v in cands.items()}
    assert best == min(values, key=values.get)


@pytest.mark.slow
def test_chapter4_mr_design_is_the_rules_choice_over_the_60_designs():
    """scenarios/mr_designs: 5·4·3 = 60 ordered impulse triples, all admissible on the LTI
    beam; the rule (training records only) picks impulses 3, 19, 11 in, the Chapter 4
    scenario's sets a, b, c; the former design 19, 11, 3 in ranks 59th.
    Measured (LTI beam, finite difference): κ = 1.28 (chosen), 66.4 (former)."""
    from podbench.core.resources import bundled_scenarios
    from podbench.harness.cache import TruthCache
    from podbench.harness.runner import _Truth
    from podbench.study.resolve import resolve_structure
    from podbench.study.scenarios import load_scenario
    from podbench.sysid.methods.mixed_design import choose_design

    sc = load_scenario(bundled_scenarios() / "mr_designs" / "beam_mixed_designs.toml")
    assert len(sc.methods) == 60
    assert len({m.train for m in sc.methods}) == 60
    truth = _Truth(sc, resolve_structure("lti_beam", sc), TruthCache(None), sc.engine)
    cands = {m.label: [truth.train(c) for c in m.train] for m in sc.methods}
    best, values = choose_design(cands, 4)
    assert best == "MR 3 19 11"
    assert values[best] == pytest.approx(1.28, abs=0.01)
    assert values["MR 19 11 3"] == pytest.approx(66.4, abs=0.1)
    assert sorted(values, key=values.get).index("MR 19 11 3") == 58
    assert max(values.values()) < 1e6
    ch4 = load_scenario(bundled_scenarios() / "chapter4" / "beam_mixed.toml")
    picked = [ch4.cases[c].initial_velocity["impulses"][0][0] for c in "abc"]
    assert picked == [3.0, 19.0, 11.0]
