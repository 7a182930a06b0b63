"""The §5.2 nonlinearity checks: the lag estimator on sinusoids with known lag, the
superposition measure, the reference period and the local modal damping."""

import numpy as np
import pytest

from podbench.errors import InputError
from podbench.harness.nonlinearity import (
    ImpulseSet,
    band_variant,
    impulse_responses,
    modal_damping,
    phase_lag,
    phase_lags,
    reference_period,
    superposition_check,
)
from podbench.structures.files import load_structure

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

T = 0.1
W = 2 * np.pi / T
t = np.arange(0, 2.3, 1e-4)


@pytest.mark.parametrize("tau", [0.0, 0.0123, -0.031, 0.0004567])
def test_constant_lag_of_a_shifted_signal_with_a_second_mode(tau):
    def x(tt):
        return np.sin(W * tt) + 0.3 * np.sin(6.27 * W * tt + 0.4)

    lag = phase_lag(t, x(t), x(t - tau), [0.5, 1.0, 1.5, 2.0], T)
    np.testing.assert_allclose(lag, tau, atol=2e-6)  # 0.002 % of the period


def test_growing_lag_is_tracked_past_half_a_period():
    # sig = sin(w' t): it reaches ref's phase w t at t w / w', a lag t (w / w' - 1);
    # with w' = w / 1.04 that is 0.04 t: 80 % of the period at 2 s (beyond +-T/2: unwrapped)
    ws = W / 1.04
    times = np.array([0.5, 1.0, 1.5, 2.0])
    lag = phase_lag(t, np.sin(W * t), np.sin(ws * t), times, T)
    np.testing.assert_allclose(lag, 0.04 * times, atol=2e-5)
    # and a faster signal leads (negative lag)
    lag = phase_lag(t, np.sin(W * t), np.sin(1.01 * W * t), times, T)
    np.testing.assert_allclose(lag, (1 / 1.01 - 1) * times, atol=2e-5)


def test_lowpass_keeps_the_fundamentals_lag_under_a_strong_second_mode():
    # a second mode as strong as the first, at 6.27 times the frequency, with its own
    # (different) drift: only the fundamental's lag 0.02 t is wanted
    times = np.array([0.5, 1.0, 1.5, 2.0])
    ref = np.sin(W * t) + np.sin(6.27 * W * t)
    sig = np.sin(W / 1.02 * t) + np.sin(6.27 * W / 1.001 * t + 1.0)
    lag = phase_lag(t, ref, sig, times, T, lowpass=2.0 / T)
    np.testing.assert_allclose(lag, 0.02 * times, atol=5e-5)


def test_lag_needs_a_record_beyond_the_last_time():
    with pytest.raises(InputError, match="times"):
        phase_lag(t[:20000], np.sin(W * t[:20000]), np.sin(W * t[:20000]), [2.0], T)


def test_superposition_and_lag_of_a_linear_set_are_null_and_of_a_softening_set_are_not():
    ref = np.sin(W * t) * np.exp(-0.3 * t)
    data = ImpulseSet(t=t, peaks=(1.0, 2.0), impulses=np.array([1.0, 2.0]),
                      tip=np.array([ref, 2 * ref]))
    sup = superposition_check(data, T)
    assert sup["spread"] < 1e-15 and np.all(sup["deviation"] < 1e-15)
    assert sup["trend_rms"] == sup["trend_away"] == sup["trend_toward"] == "equal"
    np.testing.assert_allclose(phase_lags(data, [1.0], T), 0.0, atol=1e-9)  # % of T
    # the small load responds with a bigger scaled amplitude and 1 % lower frequency
    small = 1.1 * np.sin(W / 1.01 * t) * np.exp(-0.3 * t)
    data = ImpulseSet(t=t, peaks=(1.0, 2.0), impulses=np.array([1.0, 2.0]),
                      tip=np.array([small, 2 * ref]))
    sup = superposition_check(data, T)
    assert sup["trend_away"] == sup["trend_toward"] == sup["trend_rms"] == "falls"
    m = t <= T
    rms_small, rms_big = np.sqrt(np.mean(small[m] ** 2)), np.sqrt(np.mean(ref[m] ** 2))
    assert sup["spread"] == pytest.approx(1 - rms_big / rms_small, rel=1e-12)
    assert 0.09 < sup["spread"] < 0.1  # about 1 - 1/1.1
    np.testing.assert_allclose(phase_lags(data, [1.0, 2.0], T)[0], [1.0 * 10, 2.0 * 10],
                               rtol=2e-3)  # 0.01 t / T in %


def test_reference_period_is_the_bare_beams_and_matches_euler_bernoulli():
    s = load_structure("rubber_band_beam")
    m = s.metadata
    w1 = 1.8751040687**2 * np.sqrt(m["EI"] / (m["rho_A"] * m["length"] ** 4))
    assert reference_period(s) == pytest.approx(2 * np.pi / w1, rel=1e-5)
    assert reference_period(s) == pytest.approx(0.09955, abs=1e-5)


def test_modal_damping_gives_the_stated_ratio():
    s = load_structure("rubber_band_beam")
    sd = modal_damping(s, 0.005)
    # modal damping: Φᵀ C Φ = diag(2 ζ ω_r) in the mass-normalized modes
    import scipy.linalg
    K, M, C = sd.K.toarray(), sd.M.toarray(), sd.C.toarray()
    w2, phi = scipy.linalg.eigh(K, M)
    c = phi.T @ C @ phi
    np.testing.assert_allclose(np.diag(c)[:5], 2 * 0.005 * np.sqrt(w2[:5]), rtol=1e-8)
    assert np.max(np.abs(c - np.diag(np.diag(c)))) < 1e-8 * np.max(np.diag(c))


def test_homogeneous_band_gives_null_checks_on_the_beam():
    s = load_structure("rubber_band_beam")
    T0 = reference_period(s)
    data = impulse_responses(s, (0.9, 1.8), t_end=0.4)
    sup = superposition_check(data, T0)
    assert sup["spread"] < 1e-10 and sup["deviation"][0] < 1e-10
    np.testing.assert_allclose(phase_lags(data, [0.2], T0), 0.0, atol=1e-9)  # % of T
    # with a slack of half the amplitude the small load lags (band engaged less: softer)
    A = np.max(np.abs(data.tip[-1, data.t <= T0]))
    data = impulse_responses(band_variant(s, slack=0.5 * A), (0.36, 1.8), t_end=0.4)
    assert phase_lags(data, [0.2], T0)[0, 0] > 0.5


def test_response_nonlinearity_is_zero_when_the_band_never_engages():
    from podbench.dynamics.excitations import Pulse
    from podbench.harness.nonlinearity import response_nonlinearity

    s = load_structure("rubber_band_beam")
    f = Pulse(4.0, 1.8, 1e-3, shape="half_sine")
    # a slack far beyond the tip amplitude: the structure is its own twin (the bare beam);
    # round-off only (Newton's solve vs the linear solve; 1.8e-12 measured with another
    # OpenBLAS kernel), against 0.19 with the band engaging (below)
    assert response_nonlinearity(band_variant(s, slack=1.0), f, 400, 1e-4) < 1e-10
    # a pre-stretch far beyond the amplitude: the band never goes slack, twin = two-sided band
    assert response_nonlinearity(band_variant(s, prestretch=1.0), f, 400, 1e-4) < 1e-10
    assert response_nonlinearity(s, f, 400, 1e-4) > 0.01
