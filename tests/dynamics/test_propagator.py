"""Newmark's transition-matrix path (``newmark(..., propagator=True)``, and several runs
stepped together by ``newmark_batch``) against an independent whole-system Newmark with a
full Newton iteration, and against the default path."""

import dataclasses

import numpy as np
import pytest
from dynamics_systems import chain

from podbench.dynamics import newmark
from podbench.dynamics.excitations import Pulse
from podbench.dynamics.newmark import newmark_batch
from podbench.errors import DimensionError
from podbench.structures import CubicSpring, OneSidedSpring
from podbench.structures.files import load_structure


def _full_newton_reference(s, q0, v0, f, h):
    """Independent reference: average-acceleration Newmark with the whole tangent
    ``M + h/2 (C + C_g) + h²/4 (K + K_g)`` solved densely at every Newton iteration (no
    factorization reuse, no condensation), iterated to a fixed point in floating point."""
    M, K = s.M.toarray(), s.K.toarray()
    C = s.damping_matrix().toarray()
    n_dofs, n = f.shape

    def restoring(q, v):
        g, Kg, Cg = np.zeros(n_dofs), np.zeros((n_dofs, n_dofs)), np.zeros((n_dofs, n_dofs))
        for el in s.nonlinear:
            d = np.asarray(el.dofs)
            g[d] += el.force(q[d], v[d])
            Kg[np.ix_(d, d)] += el.stiffness(q[d], v[d])
            Cg[np.ix_(d, d)] += el.damping(q[d], v[d])
        return g, Kg, Cg

    q = np.zeros((n_dofs, n))
    q[:, 0] = q0
    v = np.array(v0, dtype=float)
    a = np.linalg.solve(M, f[:, 0] - C @ v - K @ q0 - restoring(q0, v)[0])
    for j in range(n - 1):
        qp = q[:, j] + h * v + h * h / 4 * a
        vp = v + h / 2 * a
        a_new = a.copy()
        for _ in range(50):
            qn, vn = qp + h * h / 4 * a_new, vp + h / 2 * a_new
            g, Kg, Cg = restoring(qn, vn)
            r = f[:, j + 1] - M @ a_new - C @ vn - K @ qn - g
            J = M + h / 2 * (C + Cg) + h * h / 4 * (K + Kg)
            da = np.linalg.solve(J, r)
            a_new = a_new + da
            if np.linalg.norm(da) <= 1e-15 * np.linalg.norm(a_new):
                break
        a = a_new
        q[:, j + 1] = qp + h * h / 4 * a
        v = vp + h / 2 * a
    return q


_ELEMENTS = [
    OneSidedSpring(dof=3, k=3.0e4, slack=0.002),
    OneSidedSpring(dof=3, k=3.0e4, prestretch=0.002, side=-1),
    CubicSpring(3, 5.0e6),
]
"""The nonlinear end elements of the 4-DOF chain: a slack and a prestretched one-sided
spring (each switches during the run) and a stiffening cubic spring."""


@pytest.mark.parametrize("element", _ELEMENTS)
def test_propagator_equals_a_full_newton_newmark(element):
    # a damped 4-DOF chain (non-proportional damping), one nonlinear element at its end,
    # loaded by a short pulse and started from a displacement: 600 steps
    s = chain(4, nonlinear=(element,))
    h, n = 2.0e-3, 601
    f = np.zeros((4, n))
    f[1, 1:8] = 40.0
    q0 = np.array([0.0, 0.004, -0.002, 0.006])
    ref = _full_newton_reference(s, q0, np.zeros(4), f, h)
    fast = newmark(s, q0, np.zeros(4), f, h, propagator=True)
    default = newmark(s, q0, np.zeros(4), f, h)
    scale = np.abs(ref).max()
    assert np.abs(fast.q - ref).max() <= 1e-12 * scale
    assert np.abs(default.q - ref).max() <= 1e-12 * scale
    # the element switched or stiffened: the case exercises the Newton iteration
    assert fast.newton_iterations[1:].max() >= 2


def test_propagator_on_the_rubber_band_beam_equals_the_default_path():
    # the nonlinearity checks' use: sensor loads through Sᵀ, the tip sensor recorded
    s = load_structure("rubber_band_beam")
    s = dataclasses.replace(s, nonlinear=(dataclasses.replace(s.nonlinear[0], slack=0.004),))
    n, dt = 3001, 1.0e-4
    F = Pulse(4.0, 1.8, 1.0e-3, shape="half_sine").sample(s, n, dt)
    S = s.sensor_matrix()
    zero = np.zeros(s.n_dofs)
    default = newmark(s, zero, zero, F, dt, force_map=S.T, record=S)
    fast = newmark(s, zero, zero, F, dt, force_map=S.T, record=S[-1:], propagator=True)
    tip = default.q[-1]
    # round-off level: the default path itself moves by 2.9e-12 of the amplitude between two
    # OpenBLAS kernels; the two paths differ by 1.6e-12 on SkylakeX, less on Haswell
    assert np.abs(fast.q[0] - tip).max() <= 1e-11 * np.abs(tip).max()
    assert np.abs(fast.v[0] - default.v[-1]).max() <= 1e-11 * np.abs(default.v[-1]).max()


def test_propagator_is_ignored_where_it_does_not_apply():
    # linear structure, and nonlinear elements on two DOFs: the default path, bit for bit
    rng = np.random.default_rng(3)
    f = rng.normal(size=(4, 50))
    q0 = 0.01 * rng.normal(size=4)
    for s in (chain(4), chain(4, nonlinear=(CubicSpring(3, 5e5), CubicSpring(1, 2e5)))):
        a = newmark(s, q0, np.zeros(4), f, 0.01)
        b = newmark(s, q0, np.zeros(4), f, 0.01, propagator=True)
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.newton_iterations, b.newton_iterations)


@pytest.mark.parametrize("element", _ELEMENTS)
def test_batch_equals_single_runs_and_the_full_newton_reference(element):
    # three loads of different sizes and places stepped together (the runs switch the
    # element at different steps): each run equals its own propagator run to round-off
    # and the independent full-Newton Newmark to 1e-12 of its amplitude
    s = chain(4, nonlinear=(element,))
    h, n = 2.0e-3, 601
    f = np.zeros((3, 4, n))
    f[0, 1, 1:8] = 40.0
    f[1, 1, 1:8] = 5.0
    f[2, 2, 3:6] = -60.0
    zero = np.zeros(4)
    batch = newmark_batch(s, f, h)
    assert batch.shape == (3, 4, n)
    for c in range(3):
        single = newmark(s, zero, zero, f[c], h, propagator=True).q
        ref = _full_newton_reference(s, zero, zero, f[c], h)
        scale = np.abs(ref).max()
        assert np.abs(batch[c] - single).max() <= 1e-13 * scale
        assert np.abs(batch[c] - ref).max() <= 1e-12 * scale
    # the runs differ (not one run copied)
    assert not np.allclose(batch[2], batch[0], rtol=1e-3)


def test_batch_records_through_the_output_matrix_and_falls_back_where_needed():
    rng = np.random.default_rng(5)
    f = rng.normal(size=(2, 4, 40))
    R = np.array([[0.0, 0.0, 0.0, 1.0]])
    zero = np.zeros(4)
    for s in (chain(4), chain(4, nonlinear=(CubicSpring(3, 5e5), CubicSpring(1, 2e5))),
              chain(4, nonlinear=(CubicSpring(3, 5e5),))):
        batch = newmark_batch(s, f, 0.01, record=R)
        for c in range(2):
            single = newmark(s, zero, zero, f[c], 0.01, record=R, propagator=True).q
            np.testing.assert_allclose(batch[c], single, rtol=0, atol=1e-13 * np.abs(single).max())
    with pytest.raises(DimensionError, match="`f`"):
        newmark_batch(chain(4), f[0], 0.01)
