"""The one-sided (bilinear) spring of §5.2: closed-form period, homogeneity, slack and
pre-stretch, the linear twin, and the tip_band table of structure files."""

import dataclasses

import numpy as np
import pytest

from podbench.dynamics import simulate
from podbench.dynamics.excitations import Pulse
from podbench.dynamics.newmark import newmark
from podbench.errors import InputError, StructureFileError
from podbench.structures import OneSidedSpring, Structure
from podbench.structures.files import load_structure


def _upward_crossings(t, x):
    i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def _oscillator(k1, k2, m=1.0, side=1, **kw):
    return Structure(name="bilinear", M=[[m]], K=[[k1]], sensor_dofs=np.array([0]),
                     nonlinear=(OneSidedSpring(dof=0, k=k2, side=side, **kw),))


@pytest.mark.parametrize("side", [1, -1])
def test_bilinear_oscillator_period_matches_closed_form(side):
    # free vibration of m q'' + k1 q + k2 (s q)_+ = 0: half a cycle at w1 = sqrt(k1/m), half at
    # w2 = sqrt((k1 + k2)/m), so T = pi/w1 + pi/w2 whatever the amplitude
    k1, k2, m = (2 * np.pi) ** 2, 3.0 * (2 * np.pi) ** 2, 1.0
    T_exact = np.pi / np.sqrt(k1 / m) + np.pi / np.sqrt((k1 + k2) / m)  # 0.75 s
    s = _oscillator(k1, k2, m, side=side)
    dt, n = 5.0e-4, 6001  # 1500 steps a period, 4 periods
    res = newmark(s, np.zeros(1), np.array([1.7]), np.zeros((1, n)), dt)
    t = np.arange(n) * dt
    tc = _upward_crossings(t, res.q[0])
    periods = np.diff(tc)
    assert periods.size >= 2
    np.testing.assert_allclose(periods, T_exact, rtol=2e-5)
    # the peaks on the two sides are v0/w1 and v0/w2 (one-sided energy balance)
    hi, lo = res.q[0].max(), res.q[0].min()
    soft, stiff = 1.7 / np.sqrt(k1 / m), 1.7 / np.sqrt((k1 + k2) / m)
    np.testing.assert_allclose((hi, -lo), (stiff, soft) if side == 1 else (soft, stiff),
                               rtol=1e-5)
    # Newton at the kink converges in a few iterations
    assert res.newton_iterations.max() <= 4


def test_energy_is_conserved_across_the_kink():
    k1, k2 = 4.0, 12.0
    s = _oscillator(k1, k2)
    dt, n = 1.0e-3, 4001
    res = newmark(s, np.zeros(1), np.array([1.0]), np.zeros((1, n)), dt)
    q, v = res.q[0], res.v[0]
    E = 0.5 * v**2 + 0.5 * k1 * q**2 + 0.5 * k2 * np.maximum(q, 0.0) ** 2
    assert np.max(np.abs(E - 0.5)) < 1e-4


def test_force_slack_prestretch_and_tangent():
    b = OneSidedSpring(dof=0, k=2.0)
    np.testing.assert_allclose(b.force(np.array([-1.0, 0.0, 0.5]), None), [0.0, 0.0, 1.0])
    b = OneSidedSpring(dof=0, k=2.0, side=-1)
    np.testing.assert_allclose(b.force(np.array([-1.0, 0.5]), None), [-2.0, 0.0])
    b = OneSidedSpring(dof=0, k=2.0, slack=0.1)  # engages beyond 0.1
    np.testing.assert_allclose(b.force(np.array([0.05, 0.3, -1.0]), None), [0.0, 0.4, 0.0])
    b = OneSidedSpring(dof=0, k=2.0, prestretch=0.1)  # two-sided until q < -0.1
    np.testing.assert_allclose(b.force(np.array([0.05, -0.05, -1.0]), None), [0.1, -0.1, -0.2])
    assert b.stiffness(np.array([-0.05]), None)[0, 0] == 2.0
    assert b.stiffness(np.array([-0.2]), None)[0, 0] == 0.0


@pytest.mark.parametrize("kw, match", [
    ({"side": 0}, "side"), ({"k": -1.0}, "`k`"), ({"slack": 0.1, "prestretch": 0.1}, "slack"),
    ({"twin": "secant"}, "twin"),
])
def test_bad_parameters(kw, match):
    args = {"dof": 0, "k": 1.0, **kw}
    with pytest.raises(InputError, match=match):
        OneSidedSpring(**args)


def _tip_response(s, peak, n=2001, dt=1e-4):
    f = Pulse(4.0, peak, 1.0e-3, shape="half_sine")
    return simulate(s, n_samples=n, dt=dt, force=f).W[-1]


def test_rubber_band_beam_is_positively_homogeneous_without_slack():
    s = load_structure("rubber_band_beam")
    w1 = _tip_response(s, 0.36)
    w5 = _tip_response(s, 1.8)
    assert np.max(np.abs(w1)) > 1e-3  # the band is active on both sides of zero
    assert np.max(np.abs(w5 / 5.0 - w1)) / np.max(np.abs(w1)) < 1e-10
    # ... but it is not linear: reversing the load changes the response's shape
    wm = _tip_response(s, -1.8)
    assert np.max(np.abs(wm + w5)) / np.max(np.abs(w5)) > 0.05


def _period(s, v0, dt=5.0e-4, n=6001):
    res = newmark(s, np.zeros(1), np.array([v0]), np.zeros((1, n)), dt)
    return np.mean(np.diff(_upward_crossings(np.arange(n) * dt, res.q[0])))


@pytest.mark.heavy
def test_slack_oscillator_period_matches_closed_form_and_falls_with_amplitude():
    # m = 1, k1 = w1^2, band k2 engaged beyond q = d. From q = 0 at speed v0: soft up to d
    # (time t1 = asin(d w1 / v0) / w1, speed v1 = sqrt(v0^2 - w1^2 d^2)), then an oscillation
    # at w2 = sqrt(w1^2 + k2) about q* = k2 d / w2^2 entering at y0 = d - q* with speed v1,
    # which leaves after (pi - 2 phi) / w2, phi = atan2(y0 w2, v1); then the soft half cycle.
    w1, k2, d = 2 * np.pi, 3.0 * (2 * np.pi) ** 2, 0.05
    w2 = np.sqrt(w1**2 + k2)
    s = _oscillator(w1**2, k2, slack=d)
    periods = []
    for v0 in (0.5 * d * w1, 2.0 * d * w1, 8.0 * d * w1):
        T = _period(s, v0)
        if v0 <= d * w1:
            T_exact = 2 * np.pi / w1  # the band never engages
        else:
            t1 = np.arcsin(d * w1 / v0) / w1
            v1 = np.sqrt(v0**2 - (w1 * d) ** 2)
            phi = np.arctan2((d - k2 * d / w2**2) * w2, v1)
            T_exact = np.pi / w1 + 2 * t1 + (np.pi - 2 * phi) / w2
        assert T == pytest.approx(T_exact, rel=5e-5)
        periods.append(T)
    # stiffening: the period falls (the frequency rises) with amplitude, towards pi/w1 + pi/w2
    assert periods[0] > periods[1] > periods[2] > np.pi / w1 + np.pi / w2


def test_prestretch_oscillator_is_two_sided_when_small_and_softens_with_amplitude():
    w1, k2, p = 2 * np.pi, 3.0 * (2 * np.pi) ** 2, 0.05
    w2 = np.sqrt(w1**2 + k2)
    s = _oscillator(w1**2, k2, prestretch=p)
    T_small = _period(s, 0.5 * p * w2)  # never slack: the linear two-sided spring
    assert T_small == pytest.approx(2 * np.pi / w2, rel=5e-5)
    T_mid, T_big = _period(s, 2.0 * p * w2), _period(s, 50.0 * p * w2, n=4001)
    assert T_small < T_mid < T_big < np.pi / w1 + np.pi / w2
    assert T_big == pytest.approx(np.pi / w1 + np.pi / w2, rel=0.05)


def test_linear_twin_rules():
    s = load_structure("rubber_band_beam")
    f_bare = s.linear_twin().natural_frequencies(1)[0]
    assert s.linear_twin().is_linear and abs(f_bare - 10.0455) < 1e-3
    band = s.nonlinear[0]
    two = dataclasses.replace(s, nonlinear=(dataclasses.replace(band, twin="two_sided"),))
    pre = dataclasses.replace(s, nonlinear=(dataclasses.replace(band, prestretch=0.01),))
    f_two = two.linear_twin().natural_frequencies(1)[0]
    assert f_two > f_bare * 1.05
    assert pre.linear_twin().natural_frequencies(1)[0] == pytest.approx(f_two, rel=1e-12)
    # independent check: tip stiffness of the bare cantilever 3EI/L^3 = 0.6104 lbf/in
    K = s.linear_twin().K.toarray()
    tip = s.metadata["tip_dof"]
    flex = np.linalg.solve(K, np.eye(K.shape[0])[:, tip])[tip]
    assert 1.0 / flex == pytest.approx(0.6103515625, rel=1e-9)


def test_rubber_band_beam_file():
    s = load_structure("rubber_band_beam")
    assert s.metadata["tip_band"] == {"k": 0.12, "side": 1, "slack": 0.0, "prestretch": 0.0,
                                      "twin": "tangent"}
    assert s.n_dofs == 40 and s.n_sensors == 6
    np.testing.assert_allclose(s.sensor_positions, [0, 4, 8, 12, 16, 20])
    # the §5.1 modal damping of the band-free beam: Φᵀ C Φ = diag(2 ζ ω) with ζ = 0.005
    import scipy.linalg
    w2, phi = scipy.linalg.eigh(s.K.toarray(), s.M.toarray())
    modal = phi.T @ s.C.toarray() @ phi
    np.testing.assert_allclose(np.diag(modal), 2 * 0.005 * np.sqrt(w2), rtol=1e-8)
    assert np.abs(modal - np.diag(np.diag(modal))).max() < 1e-8 * np.abs(np.diag(modal)).max()


BASE = """
name = "b"
kind = "cantilever_beam"
units = "inch, lbf, second"
description = "x"
[beam]
length = 20.0
width = 1.0
depth = 0.125
E = 10.0e6
density_lbm_per_ft3 = 168.48
n_elements = 4
[tip_band]
"""


@pytest.mark.parametrize("band, match", [
    ('side = "positive"', r"b\.toml: .*tip_band\.k"),
    ('k = 0.12', r"b\.toml: .*tip_band\.side"),
    ('k = 0.12\nside = "up"', r"b\.toml: .*tip_band\.side"),
    ('k = -0.12\nside = "positive"', r"b\.toml: .*tip_band\.k"),
    ('k = 0.12\nside = "positive"\nslack = -1.0', r"b\.toml: .*tip_band\.slack"),
    ('k = 0.12\nside = "positive"\nslack = 0.1\nprestretch = 0.1',
     r"b\.toml: .*tip_band\.prestretch"),
    ('k = 0.12\nside = "positive"\ntwin = "secant"', r"b\.toml: .*tip_band\.twin"),
    ('k = 0.12\nside = "positive"\nslak = 0.1', r"b\.toml: .*slak"),
])
def test_tip_band_file_errors_are_one_line(tmp_path, band, match):
    p = tmp_path / "b.toml"
    p.write_text(BASE + band + "\n")
    with pytest.raises(StructureFileError, match=match) as e:
        load_structure(p)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("kw", [{}, {"side": -1}, {"slack": 0.003}, {"prestretch": 0.002},
                                {"side": -1, "prestretch": 0.002}])
def test_scalar_terms_are_the_array_methods_numbers(kw):
    # Newmark's one-DOF Newton loop evaluates the band on floats (scalar_terms); it must give
    # bit for bit the numbers of force / stiffness / damping, or the integration would move
    el = OneSidedSpring(dof=0, k=0.12, **kw)
    rng = np.random.default_rng(3)
    qs = np.concatenate([rng.normal(scale=0.01, size=200), [0.0, -0.0, 0.003, -0.002, 0.002]])
    for q in qs:
        v = float(rng.normal())
        g, kq, cv = el.scalar_terms(float(q), v)
        qa, va = np.array([q]), np.array([v])
        assert np.array_equal(np.array([g]), el.force(qa, va))
        assert kq == el.stiffness(qa, va)[0, 0] and cv == el.damping(qa, va)[0, 0]


def test_newmark_scalar_path_equals_array_path():
    # the same band without scalar_terms (the array evaluation) integrates to the same bits
    class ArrayOnly:
        def __init__(self, el):
            self.el, self.dofs = el, el.dofs

        def force(self, q, v):
            return self.el.force(q, v)

        def stiffness(self, q, v):
            return self.el.stiffness(q, v)

        def damping(self, q, v):
            return self.el.damping(q, v)

    s = load_structure("rubber_band_beam")
    band = dataclasses.replace(s.nonlinear[0], slack=0.002)
    fast = dataclasses.replace(s, nonlinear=(band,))
    slow = dataclasses.replace(s, nonlinear=(ArrayOnly(band),))
    F = Pulse(4.0, 1.8, 1e-3, shape="half_sine").sample(s, 900, 1e-4)
    a = simulate(fast, n_samples=900, dt=1e-4, force=F, dof_histories=False)
    b = simulate(slow, n_samples=900, dt=1e-4, force=F, dof_histories=False)
    assert np.array_equal(a.W, b.W) and np.abs(a.W).max() > 0
