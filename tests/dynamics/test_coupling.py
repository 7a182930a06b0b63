"""Coupling a finite-element parent with kernel-defined components (Chapter 6, issue 25)."""

from dataclasses import replace

import numpy as np
import pytest

from podbench.dynamics.coupling import (
    Component,
    UnstableCouplingError,
    couple,
    growth_factor,
    newmark_kernel,
    newmark_realization,
    point_mass_kernel,
)
from podbench.dynamics.excitations import Pulse
from podbench.dynamics.newmark import newmark
from podbench.errors import InputError
from podbench.structures import Structure, load_structure
from podbench.structures.assembly import attach

DT, N, TIP = 1e-4, 500, 46


@pytest.fixture(scope="module")
def beam():
    return load_structure("lti_beam")


@pytest.fixture(scope="module")
def load(beam):
    return beam.to_dofs(Pulse(16.0, 500.0, 5e-4).sample(beam, N, DT))


def _chain(scale):
    s = load_structure("chain_coupled")
    return Structure(name=f"chain{scale}", M=s.M * scale, K=s.K * scale, C=s.C * scale,
                     sensor_dofs=s.sensor_dofs)


def _truth(beam, comp_s, f):
    asm = attach(beam, comp_s, [TIP], [4])
    fa = np.vstack([f, np.zeros((asm.n_dofs - beam.n_dofs, f.shape[1]))])
    z = np.zeros(asm.n_dofs)
    return beam.sensor_matrix() @ newmark(asm, z, z, fa, DT).q[:beam.n_dofs]


def _err(Y, Yt):
    return np.linalg.norm(Y - Yt) / np.linalg.norm(Yt)


@pytest.mark.parametrize("scale", [0.01, 1.0])
@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
@pytest.mark.parametrize("memory", ["fir", "realization"])
def test_exact_kernels_reproduce_the_assembled_system(beam, load, scale, quantity, memory):
    cs = _chain(scale)
    H = newmark_kernel(cs.M, cs.C, cs.K, [4], N, DT, quantity=quantity)
    real = newmark_realization(cs.M, cs.C, cs.K, [4], DT, quantity=quantity) \
        if memory == "realization" else None
    comp = Component((TIP,), H, quantity=quantity, realization=real)
    z = np.zeros(beam.n_dofs)
    res = couple(beam, z, z, load, DT, [comp])
    assert _err(beam.sensor_matrix() @ res.q, _truth(beam, cs, load)) <= 1e-10


@pytest.mark.heavy
@pytest.mark.parametrize("scale", [0.01, 1.0])
@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
def test_exact_kernels_on_the_truss_parent(scale, quantity):
    """The 299-DOF satellite truss (intact: its 3 s fracture removed) as the parent, the
    chain at the named DOF ``face50.d_bot`` (mid-span), a 500 lbf × 0.5 ms pulse at
    ``face25.d_bot``: coupled = Newmark on the assembled truss + chain to 1e-10."""
    truss = replace(load_structure("satellite_truss"), events=(), name="truss_intact")
    assert truss.is_time_invariant and truss.n_dofs == 299
    dof = truss.dof_labels.index("face50.d_bot")
    n = 1000
    f = np.zeros((truss.n_dofs, n))
    f[truss.dof_labels.index("face25.d_bot"), 1:6] = 500.0  # lbf, 5 samples = 0.5 ms
    cs = _chain(scale)
    comp = Component((dof,), newmark_kernel(cs.M, cs.C, cs.K, [4], n, DT, quantity=quantity),
                     quantity=quantity,
                     realization=newmark_realization(cs.M, cs.C, cs.K, [4], DT,
                                                     quantity=quantity))
    z = np.zeros(truss.n_dofs)
    res = couple(truss, z, z, f, DT, [comp])
    asm = attach(truss, cs, [dof], [4])
    fa = np.vstack([f, np.zeros((asm.n_dofs - truss.n_dofs, n))])
    za = np.zeros(asm.n_dofs)
    Yt = truss.sensor_matrix() @ newmark(asm, za, za, fa, DT).q[:truss.n_dofs]
    assert _err(truss.sensor_matrix() @ res.q, Yt) <= 1e-10


def test_the_realization_is_the_kernel():
    cs = _chain(1.0)
    H = newmark_kernel(cs.M, cs.C, cs.K, [4], 50, DT)
    A, B, C, D = newmark_realization(cs.M, cs.C, cs.K, [4], DT)
    Hr = [D] + [C @ np.linalg.matrix_power(A, k - 1) @ B for k in range(1, 50)]
    assert np.allclose(np.array(Hr), H, rtol=1e-10, atol=1e-12 * np.abs(H).max())


def test_time_varying_tip_mass_rebuilds_ltv_beam(beam, load):
    ltv = load_structure("ltv_beam")
    z = np.zeros(beam.n_dofs)
    Yt = ltv.sensor_matrix() @ newmark(ltv, z, z, load, DT).q
    m = ltv.variable_mass(np.arange(N) * DT)
    res = couple(beam, z, z, load, DT, [Component((TIP,), point_mass_kernel(m))])
    assert _err(beam.sensor_matrix() @ res.q, Yt) <= 1e-10


@pytest.mark.heavy
@pytest.mark.parametrize("scale", [0.01, 1.0])
def test_implicit_growth_factor_at_most_one(beam, scale):
    cs = _chain(scale)
    comp = Component((TIP,), newmark_kernel(cs.M, cs.C, cs.K, [4], 10, DT),
                     realization=newmark_realization(cs.M, cs.C, cs.K, [4], DT))
    assert growth_factor(beam, [comp], DT, "implicit") <= 1 + 1e-6


@pytest.mark.heavy
def test_implicit_growth_factor_time_varying_tip(beam):
    m = load_structure("ltv_beam").variable_mass(np.arange(N) * DT)
    comp = Component((TIP,), point_mass_kernel(m))
    assert growth_factor(beam, [comp], DT, "implicit") <= 1 + 1e-6


@pytest.mark.heavy
def test_two_step_refused_where_it_diverges(beam, load):
    cs = _chain(1.0)
    comp = Component((TIP,), newmark_kernel(cs.M, cs.C, cs.K, [4], N, DT),
                     realization=newmark_realization(cs.M, cs.C, cs.K, [4], DT))
    z = np.zeros(beam.n_dofs)
    assert growth_factor(beam, [comp], DT, "two-step") > 1
    with pytest.raises(UnstableCouplingError, match="two-step scheme diverges") as info:
        couple(beam, z, z, load, DT, [comp], scheme="two-step")
    assert "\n" not in str(info.value)
    res = couple(beam, z, z, load, DT, [comp], scheme="two-step", check=False, limit=1.0)
    assert 0 < res.diverged_at_step < N and np.all(np.isnan(res.q[:, res.diverged_at_step:]))


def test_two_step_runs_where_it_is_stable():
    """A light point mass on a stiff spring-mass parent: growth < 1, the two-step converges
    to the assembled response as dt shrinks (first order: the force lags one step)."""
    M = np.diag([1.0, 1.0])
    K = np.array([[2.0, -1.0], [-1.0, 1.0]]) * 1e4
    parent = Structure(name="two", M=M, K=K, sensor_dofs=np.array([0, 1]))
    m = 0.01
    errs = []
    for dt in (1e-3, 5e-4):
        n = int(0.2 / dt)
        f = np.zeros((2, n))
        f[0, 1:4] = 100.0
        comp = Component((1,), point_mass_kernel(m))
        assert growth_factor(parent, [comp], dt, "two-step") < 1
        z = np.zeros(2)
        y2 = couple(parent, z, z, f, dt, [comp], scheme="two-step").q
        asm = Structure(name="asm", M=M + np.diag([0.0, m]), K=K, sensor_dofs=np.array([0, 1]))
        yt = newmark(asm, z, z, f, dt).q
        errs.append(_err(y2, yt))
    assert errs[1] < errs[0] < 0.2


def test_interface_must_start_at_rest(beam, load):
    comp = Component((TIP,), point_mass_kernel(0.01))
    q0 = np.zeros(beam.n_dofs)
    q0[TIP] = 1e-3
    with pytest.raises(InputError, match="at rest"):
        couple(beam, q0, np.zeros(beam.n_dofs), load, DT, [comp])


def test_bad_kernel_shape():
    with pytest.raises(InputError, match="kernel must be"):
        Component((1, 2), np.zeros((5, 1, 1)))
