"""The podbench Newmark integrator against theory and independent computations."""

import numpy as np
import pytest
import scipy.integrate
from dynamics_systems import cantilever, chain, chain_event, tip_mass

from podbench.dynamics import newmark
from podbench.dynamics.newmark import DENSE_MAX_DOFS
from podbench.errors import ConvergenceError
from podbench.structures import CubicSpring, Structure


def _sdof(k=400.0, m=2.0, c=None, **extra):
    return Structure(
        name="sdof", M=[[m]], K=[[k]], C=None if c is None else [[c]],
        sensor_dofs=np.array([0]), **extra,
    )


def _trapezoidal_state_space(M, C, K, q0, v0, f, h):
    """Independent reference: the trapezoidal rule on the first-order form x' = A x + b(t).

    For a linear structure, average-acceleration Newmark is exactly this scheme (with
    ``f_0`` entering through ``b_0``)."""
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    b = np.vstack([np.zeros_like(f), Minv @ f])
    L = np.eye(2 * n) - 0.5 * h * A
    R = np.eye(2 * n) + 0.5 * h * A
    x = np.zeros((2 * n, f.shape[1]))
    x[:, 0] = np.concatenate([q0, v0])
    for j in range(f.shape[1] - 1):
        x[:, j + 1] = np.linalg.solve(L, R @ x[:, j] + 0.5 * h * (b[:, j] + b[:, j + 1]))
    return x[:n], x[n:]


def _dense_newmark_reference(s, q0, v0, f, h):
    """Independent reference for linear structures: dense solve of the full effective matrix
    ``M(t_{j+1}) + h/2 C + h²/4 K(t_{j+1})`` at every step (no factorization reuse, no
    Sherman–Morrison), K(t) from ``Structure.stiffness(t, dt)``."""
    n_dofs, n = f.shape
    C = s.damping_matrix().toarray()
    t = np.arange(n) * h
    q = np.zeros((n_dofs, n))
    v = np.zeros((n_dofs, n))
    q[:, 0], v[:, 0] = q0, v0
    a = np.linalg.solve(s.mass(t[0]).toarray(),
                        f[:, 0] - C @ v0 - s.stiffness(t[0], dt=h).toarray() @ q0)
    for j in range(n - 1):
        Mt = s.mass(t[j + 1]).toarray()
        Kt = s.stiffness(t[j + 1], dt=h).toarray()
        qp = q[:, j] + h * v[:, j] + h * h / 4 * a
        vp = v[:, j] + h / 2 * a
        a = np.linalg.solve(Mt + h / 2 * C + h * h / 4 * Kt, f[:, j + 1] - C @ vp - Kt @ qp)
        q[:, j + 1] = qp + h * h / 4 * a
        v[:, j + 1] = vp + h / 2 * a
    return q, v


def test_sdof_free_vibration_has_trapezoidal_period_elongation():
    # undamped SDOF, q0 = 1, v0 = 0: the trapezoidal rule rotates the state by
    # θ = ω̃Δt = 2 arctan(ωΔt/2) per step, so q_j = cos(jθ), v_j = -ω sin(jθ) exactly.
    k, m, h, n = 400.0, 2.0, 0.05, 400
    w = np.sqrt(k / m)
    res = newmark(_sdof(k, m), np.array([1.0]), np.array([0.0]), np.zeros((1, n)), h)
    theta = 2.0 * np.arctan(w * h / 2.0)
    j = np.arange(n)
    np.testing.assert_allclose(res.q[0], np.cos(j * theta), rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.v[0], -w * np.sin(j * theta), rtol=0, atol=1e-11)
    # the elongation is real and visible: the exact cos(ωt) differs by > 10 % here
    assert np.max(np.abs(res.q[0] - np.cos(w * j * h))) > 0.1


def test_chain_with_nonproportional_damping_and_force_equals_state_space_trapezoid():
    s = chain(5)
    rng = np.random.default_rng(0)
    n, h = 300, 0.01
    q0, v0 = rng.normal(size=5) * 0.01, rng.normal(size=5) * 0.1
    f = rng.normal(size=(5, n)) * 10.0
    res = newmark(s, q0, v0, f, h)
    q_ref, v_ref = _trapezoidal_state_space(
        s.M.toarray(), s.C.toarray(), s.K.toarray(), q0, v0, f, h
    )
    assert np.linalg.norm(res.q - q_ref) / np.linalg.norm(q_ref) < 1e-12
    assert np.linalg.norm(res.v - v_ref) / np.linalg.norm(v_ref) < 1e-12
    # equilibrium holds at every sample, including t_0 (f_0 enters through a_0)
    eq = s.M @ res.a + s.C @ res.v + s.K @ res.q - f
    assert np.max(np.abs(eq)) < 1e-10 * np.max(np.abs(f))


def _energy(s, q, v):
    M, K = s.M.toarray(), s.K.toarray()
    return 0.5 * np.einsum("it,ij,jt->t", v, M, v) + 0.5 * np.einsum("it,ij,jt->t", q, K, q)


@pytest.mark.parametrize("structure", ["chain", "beam"])
def test_undamped_lti_conserves_discrete_energy(structure):
    s = chain(6, damping=False) if structure == "chain" else cantilever()
    rng = np.random.default_rng(1)
    q0 = np.linalg.solve(s.K.toarray(), rng.normal(size=s.n_dofs))  # a smooth static shape
    v0 = rng.normal(size=s.n_dofs) * 0.5
    res = newmark(s, q0, v0, np.zeros((s.n_dofs, 500)), 1e-4 if structure == "beam" else 1e-2)
    E = _energy(s, res.q, res.v)
    assert np.max(np.abs(E - E[0])) / E[0] < 1e-8
    # not a trivial pass: the energy moves between kinetic and potential
    Ek = 0.5 * np.einsum("it,ij,jt->t", res.v, s.M.toarray(), res.v)
    assert np.ptp(Ek) > 0.1 * E[0]


def test_variable_mass_sherman_morrison_equals_dense_solve_per_step():
    s = chain(4, variable_mass=tip_mass(3))
    rng = np.random.default_rng(2)
    n, h = 400, 0.01
    q0, v0 = rng.normal(size=4) * 0.01, rng.normal(size=4) * 0.1
    f = rng.normal(size=(4, n))
    res = newmark(s, q0, v0, f, h)
    q_ref, v_ref = _dense_newmark_reference(s, q0, v0, f, h)
    assert np.linalg.norm(res.q - q_ref) / np.linalg.norm(q_ref) < 1e-12
    assert np.linalg.norm(res.v - v_ref) / np.linalg.norm(v_ref) < 1e-12
    # and the mass really varies: the constant-mass run is far away
    res0 = newmark(chain(4), q0, v0, f, h)
    assert np.linalg.norm(res0.q - q_ref) / np.linalg.norm(q_ref) > 1e-2


def test_variable_mass_on_beam_sherman_morrison_equals_dense_solve():
    from dataclasses import replace

    from podbench.structures import VariableMass

    base = cantilever()
    tip = base.n_dofs - 2
    law = VariableMass(tip, lambda t: 0.0135 * (1 + 0.8 * np.sin(600 * t)))
    s = replace(base, variable_mass=law)
    q0 = np.linalg.solve(s.K.toarray(), np.eye(s.n_dofs)[tip] * 100.0)
    f = np.zeros((s.n_dofs, 200))
    res = newmark(s, q0, np.zeros(s.n_dofs), f, 1e-4)
    q_ref, _ = _dense_newmark_reference(s, q0, np.zeros(s.n_dofs), f, 1e-4)
    # round-off accumulated over 200 undamped steps: measured 2e-12 (1e-15 per step)
    assert np.linalg.norm(res.q - q_ref) / np.linalg.norm(q_ref) < 1e-11
    # a wrong mass term (constant tip mass m(0)) would be far away
    const = replace(base, variable_mass=VariableMass(tip, lambda t: 0.0135 + 0 * t))
    q_c = newmark(const, q0, np.zeros(s.n_dofs), f, 1e-4).q
    assert np.linalg.norm(q_c - q_ref) / np.linalg.norm(q_ref) > 1e-3


def test_stiffness_event_takes_effect_at_its_first_sample():
    h, n = 0.05, 100
    ev = chain_event(4, time=1.0)  # first sample 20
    s = chain(4, events=(ev,))
    assert ev.first_sample(h) == 20
    rng = np.random.default_rng(3)
    q0, v0 = rng.normal(size=4) * 0.01, rng.normal(size=4) * 0.1
    f = np.zeros((4, n))
    res = newmark(s, q0, v0, f, h)
    q_ref, _ = _dense_newmark_reference(s, q0, v0, f, h)
    assert np.linalg.norm(res.q - q_ref) / np.linalg.norm(q_ref) < 1e-12
    # up to and including sample 19 the run equals the one without the event, bit for bit
    res0 = newmark(chain(4), q0, v0, f, h)
    np.testing.assert_array_equal(res.q[:, :20], res0.q[:, :20])
    assert np.all(res.q[:, 20] != res0.q[:, 20])
    # an event one step later gives a different response (timing matters)
    late = chain(4, events=(chain_event(4, time=1.0 + h),))
    assert not np.array_equal(newmark(late, q0, v0, f, h).q[:, 20], res.q[:, 20])


def _cubic_sdof_rhs(k, m, c, k3):
    def rhs(t, y):
        return [y[1], -(k * y[0] + c * y[1] + k3 * y[0] ** 3) / m]

    return rhs


def test_cubic_spring_sdof_converges_to_fine_reference_at_second_order():
    k, m, c, k3 = 400.0, 2.0, 0.3, 2.0e5
    s = _sdof(k, m, c, nonlinear=(CubicSpring(0, k3),))
    T, q0, v0 = 1.0, 0.1, 0.0  # k3 q0² = 5 k: strongly nonlinear
    ref = scipy.integrate.solve_ivp(
        _cubic_sdof_rhs(k, m, c, k3), (0.0, T), [q0, v0], method="DOP853",
        rtol=1e-12, atol=1e-14, dense_output=True,
    )
    errors = []
    for n in (801, 1601):
        h = T / (n - 1)
        res = newmark(s, np.array([q0]), np.array([v0]), np.zeros((1, n)), h)
        exact = ref.sol(np.arange(n) * h)[0]
        errors.append(np.max(np.abs(res.q[0] - exact)))
        # Newton solved the equation of motion at every sample
        g = k3 * res.q[0] ** 3
        eq = m * res.a[0] + c * res.v[0] + k * res.q[0] + g
        assert np.max(np.abs(eq)) < 1e-10 * k * q0
    assert errors[1] < 1e-3 * q0
    order = np.log2(errors[0] / errors[1])
    assert 1.9 < order < 2.1


def test_cubic_spring_linear_limit_equals_linear_run():
    # k3 = 0 exercises the Newton path; it must reproduce the linear solver
    s = chain(4)
    nl = chain(4, nonlinear=(CubicSpring(3, 0.0),))
    rng = np.random.default_rng(4)
    q0, f = rng.normal(size=4) * 0.01, rng.normal(size=(4, 100))
    a = newmark(s, q0, np.zeros(4), f, 0.01)
    b = newmark(nl, q0, np.zeros(4), f, 0.01)
    assert np.linalg.norm(a.q - b.q) / np.linalg.norm(a.q) < 1e-13
    assert b.newton_iterations[1:].min() >= 1


def test_newton_failure_raises_convergence_error_naming_the_step():
    s = _sdof(400.0, 2.0, nonlinear=(CubicSpring(0, 1e12),))
    with pytest.raises(ConvergenceError, match=r"time step 1 \(t = 0.01 s\)"):
        newmark(s, np.array([1.0]), np.array([0.0]), np.zeros((1, 10)), 0.01, max_iter=2)


def test_nonlinear_variable_mass_and_event_together_satisfy_the_equations():
    """All three features at once, checked against the equations of motion and the Newmark
    relations directly."""
    h, n = 0.01, 200
    s = chain(4, variable_mass=tip_mass(3), events=(chain_event(4, 1.0),),
              nonlinear=(CubicSpring(3, 5e5), CubicSpring(1, 2e5)))
    q0 = np.array([0.01, 0.0, -0.02, 0.03])
    f = np.zeros((4, n))
    f[2, 1:6] = 50.0
    res = newmark(s, q0, np.zeros(4), f, h)
    C = s.C.toarray()
    for j in range(n):
        t = j * h
        g = np.zeros(4)
        g[3] += 5e5 * res.q[3, j] ** 3
        g[1] += 2e5 * res.q[1, j] ** 3
        lhs = (s.mass(t).toarray() @ res.a[:, j] + C @ res.v[:, j]
               + s.stiffness(t, dt=h).toarray() @ res.q[:, j] + g)
        assert np.max(np.abs(lhs - f[:, j])) < 1e-9
    # Newmark relations between samples
    a_sum = res.a[:, 1:] + res.a[:, :-1]
    dq = res.q[:, 1:] - res.q[:, :-1] - h * res.v[:, :-1] - h * h / 4 * a_sum
    assert np.max(np.abs(dq)) < 1e-14


@pytest.mark.heavy
def test_sparse_path_equals_dense_solve():
    big = 230
    assert big > DENSE_MAX_DOFS  # factorized with the sparse LU
    s_big = chain(big)
    rng = np.random.default_rng(5)
    q0 = rng.normal(size=big) * 0.01
    f = np.zeros((big, 15))
    res = newmark(s_big, q0, np.zeros(big), f, 0.01)
    q_ref, _ = _dense_newmark_reference(s_big, q0, np.zeros(big), f, 0.01)
    assert np.linalg.norm(res.q - q_ref) / np.linalg.norm(q_ref) < 1e-12
