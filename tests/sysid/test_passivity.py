"""Discrete passivity of a component's interface kernel and its enforcement (issue 25)."""

import numpy as np
import pytest

from podbench.dynamics.coupling import GROWTH_TOL, Component, growth_factor, newmark_kernel
from podbench.errors import InputError
from podbench.structures import Structure, load_structure
from podbench.sysid.components import kernel_realization
from podbench.sysid.passivity import enforce_passivity, passivity_margin, realization_kernel

DT, L, TIP = 1e-4, 500, 46


def _chain(scale=1.0):
    s = load_structure("chain_coupled")
    return Structure(name="chain", M=s.M * scale, K=s.K * scale, C=s.C * scale,
                     sensor_dofs=s.sensor_dofs)


def _exact(quantity, scale=1.0):
    cs = _chain(scale)
    H = newmark_kernel(cs.M, cs.C, cs.K, [4], L, DT, quantity=quantity)
    return H, kernel_realization(H, 10)


def _supply(real, quantity, g):
    """Σ h v̄ ḡ from rest (the energy the component receives), ``v`` from the kernel's
    response by the trapezoidal rule (acceleration), the mean (velocity) or the displacement
    difference."""
    g = np.concatenate([[0.0], g[1:]])  # podbench's convention: g_0 = 0, from rest
    A, B, C, D = real
    x, y = np.zeros(A.shape[0]), np.empty(g.size)
    for j, gj in enumerate(g):
        y[j] = C[0] @ x + D[0, 0] * gj
        x = A @ x + B[:, 0] * gj
    gbar = (g[1:] + g[:-1]) / 2
    if quantity == "acceleration":
        v = np.concatenate([[0.0], np.cumsum(DT / 2 * (y[1:] + y[:-1]))])
        vbar = (v[1:] + v[:-1]) / 2
    elif quantity == "velocity":
        vbar = (y[1:] + y[:-1]) / 2
    else:
        vbar = np.diff(y) / DT
    return DT * np.cumsum(vbar * gbar)


def _nonpassive(quantity):
    H, (A, B, C, D) = _exact(quantity)
    rng = np.random.default_rng(3)
    return H, (A, B, C * (1 + 0.3 * rng.standard_normal(C.shape)), D)


@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
@pytest.mark.parametrize("scale", [0.01, 1.0])
def test_exact_newmark_kernels_are_passive(quantity, scale):
    _, real = _exact(quantity, scale)
    assert passivity_margin(real, quantity)[0] >= -1e-9


@pytest.mark.heavy
@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
def test_the_frequency_condition_is_the_energy_balance(quantity):
    """An independent check of the criterion: driven at the frequency where the margin is
    most negative, a non-passive kernel gives back more energy than it received (the
    supply turns negative); the exact kernel never does, whatever the force."""
    _, bad = _nonpassive(quantity)
    margin, w = passivity_margin(bad, quantity)
    assert margin < 0
    n = np.arange(40000)  # long enough for the lightly damped resonance to settle
    g = np.sin(w * n) * np.minimum(1.0, n / 2000)
    assert _supply(bad, quantity, g)[-1] < 0
    _, good = _exact(quantity)
    for drive in (g[:10000], np.random.default_rng(0).standard_normal(10000)):
        s = _supply(good, quantity, drive)
        assert s.min() >= -1e-9 * np.abs(s).max()


@pytest.mark.heavy
@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
def test_enforcement_makes_the_coupling_stable(quantity):
    beam = load_structure("lti_beam")
    H, bad = _nonpassive(quantity)
    raw = Component((TIP,), realization_kernel(bad, L), quantity=quantity, realization=bad)
    assert growth_factor(beam, [raw], DT) > 1 + 1e-6
    res = enforce_passivity(bad, quantity, n_lags=L)
    assert res.info["margin_before"] < 0 <= res.info["margin_after"] + 1e-9
    assert passivity_margin(res.realization, quantity)[0] >= -1e-9
    fixed = Component((TIP,), realization_kernel(res.realization, L), quantity=quantity,
                      realization=res.realization)
    # stable: 1 to the round-off of an undamped parent's eigenvalues (GROWTH_TOL)
    assert growth_factor(beam, [fixed], DT) <= 1 + GROWTH_TOL
    # the perturbation stays small next to the error that was put in
    Hb, Hp = realization_kernel(bad, L), realization_kernel(res.realization, L)
    assert np.linalg.norm(Hp - Hb) < np.linalg.norm(Hb - H)


@pytest.mark.heavy
@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
def test_a_passive_kernel_is_left_alone_and_units_do_not_matter(quantity):
    _, real = _exact(quantity)
    H = realization_kernel(real, L)
    out = enforce_passivity(real, quantity, n_lags=L)
    Hp = realization_kernel(out.realization, L)
    assert np.linalg.norm(Hp - H) <= 1e-6 * np.linalg.norm(H)
    _, bad = _nonpassive(quantity)
    k = 4.448  # force in newtons instead of lbf: the kernel scales by 1/k
    A, B, C, D = bad
    scaled = enforce_passivity((A, B, C / k, D / k), quantity, n_lags=L)
    ref = realization_kernel(enforce_passivity(bad, quantity, n_lags=L).realization, L)
    got = realization_kernel(scaled.realization, L) * k
    assert np.linalg.norm(got - ref) <= 1e-6 * np.linalg.norm(ref)


def test_bad_quantity():
    _, real = _exact("acceleration")
    with pytest.raises(InputError, match="quantity must be one of"):
        enforce_passivity(real, "jerk", n_lags=L)
