"""Signal conditioning (podbench.conditioning): force window, exponential window with its
correction, detrending, impact detection from the measured force alone."""

import numpy as np
import pytest

from podbench import Record
from podbench.core.response import Response
from podbench.dynamics.excitations import Pulse
from podbench.errors import InputError
from podbench.sysid.conditioning import (
    Conditioning,
    WindowCorrected,
    condition,
    detect_impacts,
    detrend,
    exponential_window,
    force_window,
    unwindow,
)
from podbench.sysid.methods import MultipleLoad
from podbench.sysid.noise import NoiseSpec, noisy

from ._cases import D, forced_case
from ._truth import rel_err

DT, N, M = 1e-4, 400, 6


def _record(shape="half_sine", hits=(), start=None, seed=0):
    """A beam-like record: one loaded row (row 2), smooth responses on every row."""
    p = Pulse("s2", 500.0, 5e-4, shape=shape, hits=hits, start=start)
    F = np.zeros((M, N))
    F[2] = p.history(N, DT)
    t = np.arange(N) * DT
    rng = np.random.default_rng(seed)
    W = np.array([np.convolve(F[2], np.exp(-t / 5e-3) * np.sin(2e3 * (i + 1) * t))[:N] * 1e-6
                  for i in range(M)]) * (1 + rng.random((M, 1)))
    return Response(t=t, W=W, F=F, w0=np.zeros(M), v0=np.zeros(M), dt=DT)


def test_force_window_is_the_identity_on_a_clean_record_when_it_covers_the_pulse():
    for shape in ("rectangular", "half_sine", "triangle"):
        r = _record(shape, hits=[[3e-3, 0.4]])
        out = force_window(r.F, DT, pre=1e-4, post=2e-3)
        np.testing.assert_array_equal(out, r.F)
        c = condition(r, Conditioning(force_window=(1e-4, 2e-3)))
        np.testing.assert_array_equal(c.F, r.F)
        np.testing.assert_array_equal(c.W, r.W)


def test_force_window_keeps_every_hit_and_zeroes_the_noise_elsewhere():
    r = noisy(_record("half_sine", hits=[[3e-3, 0.4], [7e-3, 0.2]]), NoiseSpec(0.05, seed=1),
              "t", "s", "c")
    # three impacts found, at the truth's samples (from the noisy force alone)
    runs = detect_impacts(r.F[2])
    assert len(runs) == 3
    assert [j0 for j0, _ in runs] == pytest.approx([1, 31, 71], abs=2)
    out = force_window(r.F, DT, pre=1e-4, post=5e-4)
    keep = out[2] != 0
    assert not keep[20:28].any() and not keep[45:68].any() and not keep[85:].any()
    np.testing.assert_array_equal(out[2, keep], r.F[2, keep])
    clean = _record("half_sine", hits=[[3e-3, 0.4], [7e-3, 0.2]]).F[2]
    # the window removes noise outside the impacts: the force error drops
    assert np.linalg.norm(out[2] - clean) < 0.5 * np.linalg.norm(r.F[2] - clean)
    assert not out[[0, 1, 3, 4, 5]].any()  # no load cell there: rows stay zero


@pytest.mark.heavy
def test_exponential_window_and_correction_keep_an_exact_ml_fit_exact():
    """ML on the coupled chain (k = m) is exact without noise (3e-15, test_forced_methods);
    windowing W and F by e^{-t/τ} keeps W = C*F with kernel C e^{-t/τ}, so the corrected
    prediction stays exact. Measured: 5e-14 at τ = 0.05 s (record 0.4 s)."""
    fc = forced_case("coupled")
    train = [Record(W=W, F=F, dt=fc.dt) for W, F in zip(fc.W, fc.F, strict=True)]
    target = Record(W=fc.W_new, F=fc.F_new, dt=fc.dt)
    for tau in (0.05, 0.2):
        spec = Conditioning(exponential_window=tau)
        model = MultipleLoad().fit([condition(r, spec) for r in train])
        assert model.n_modes_ == D
        corrected = WindowCorrected(model, tau)
        assert rel_err(corrected.predict(target), fc.W_new) <= 1e-8
        assert corrected.modes_ is model.modes_  # everything else is the method's
        # without the correction the prediction is the windowed response, not the truth
        assert rel_err(model.predict(target), fc.W_new) > 0.1


def test_exponential_window_arithmetic():
    W = np.ones((2, 5))
    Ww, Fw, w0, v0 = exponential_window(W, 2 * W, 0.1, 0.2, np.array([1.0, 2.0]), np.zeros(2))
    e = np.exp(-np.arange(5) * 0.5)
    np.testing.assert_allclose(Ww[0], e, rtol=1e-15)
    np.testing.assert_allclose(Fw[1], 2 * e, rtol=1e-15)
    np.testing.assert_allclose(v0, [-5.0, -10.0])  # v0 - w0/τ
    np.testing.assert_allclose(unwindow(Ww, 0.1, 0.2), W, rtol=1e-14)


@pytest.mark.parametrize("kind", ["mean", "linear"])
def test_detrend_removes_an_added_offset_and_drift_exactly(kind):
    # a pre-trigger part of 30 samples: the response baseline is fitted there
    r = _record("half_sine", start=30 * DT)
    t = np.arange(N) * DT
    trend_f = 12.0 + (300.0 * t if kind == "linear" else 0.0)
    slope = -2e-4 if kind == "linear" else 0.0
    trend_w = np.outer(np.arange(1, M + 1), 1e-5 + slope * t)
    F = r.F.copy()
    F[2] += trend_f
    W, Fd = detrend(r.W + trend_w, F, kind)
    np.testing.assert_allclose(Fd, r.F, rtol=0, atol=1e-10 * 500)
    np.testing.assert_allclose(W, r.W, rtol=0, atol=1e-10 * np.abs(r.W).max())
    # without a pre-trigger part (the pulse at sample 1) the responses are left alone
    r1 = _record("half_sine")
    F1 = r1.F.copy()
    F1[2] += trend_f
    W1, F1d = detrend(r1.W + trend_w, F1, kind)
    np.testing.assert_allclose(F1d, r1.F, rtol=0, atol=1e-10 * 500)
    np.testing.assert_array_equal(W1, r1.W + trend_w)


def test_detrend_removes_the_noise_models_offset_and_drift():
    r = _record("rectangular")
    spec = NoiseSpec(0.0, force_offset=0.03, force_drift=-0.02)
    d = noisy(r, spec, "t", "s", "c")
    assert not np.array_equal(d.F, r.F) and not d.F[[0, 1, 3, 4, 5]].any()
    c = condition(d, Conditioning(detrend="linear"))
    np.testing.assert_allclose(c.F, r.F, rtol=0, atol=1e-9)


def test_conditioning_reads_only_the_noisy_arrays():
    """The same noisy arrays give the same output whether a clean record exists or not:
    the conditioning takes the record alone and never the truth."""
    spec = Conditioning(detrend="linear", force_window=(1e-4, 1e-3), exponential_window=0.02)
    clean = _record("half_sine", hits=[[3e-3, 0.5]])
    measured = noisy(clean, NoiseSpec(0.02, seed=4, force_offset=0.01), "t", "s", "c")
    a = condition(measured, spec)
    # the arrays alone, copied into a fresh record: the clean one is gone
    alone = Record(W=measured.W.copy(), F=measured.F.copy(), w0=measured.w0.copy(),
                   v0=measured.v0.copy(), dt=measured.dt)
    del clean
    b = condition(alone, spec)
    assert isinstance(a, Response) and isinstance(b, Record)
    for q in ("W", "F", "w0", "v0"):
        np.testing.assert_array_equal(getattr(a, q), getattr(b, q))


def test_conditioning_rejects_bad_parameters():
    with pytest.raises(InputError, match="detrend"):
        Conditioning(detrend="quadratic")
    with pytest.raises(InputError, match="force_window"):
        Conditioning(force_window=(-1.0, 1e-3))
    with pytest.raises(InputError, match="exponential_window"):
        Conditioning(exponential_window=0.0)
    assert condition(_record(), Conditioning()) is not None
