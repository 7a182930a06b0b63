"""The laboratory noise model (podbench.noise): per measured channel, on measured channels
only; SNR in dB; force offset and drift; double and triple hits as an excitation."""

import numpy as np
import pytest

from podbench.core.response import Response
from podbench.dynamics.excitations import Pulse, excitation_from_dict
from podbench.errors import InputError
from podbench.harness import runner
from podbench.sysid.noise import (
    NoiseSpec,
    force_channels,
    level_from_snr_db,
    noise_generator,
    noisy,
    snr_db_from_level,
)


def _response(m=25, n=4000, loaded=(3,)):
    rng = np.random.default_rng(7)
    # rows of very different size: a per-matrix RMS would drown the small ones
    W = rng.standard_normal((m, n)) * np.logspace(-3, 0, m)[:, None]
    F = np.zeros((m, n))
    for i in loaded:
        F[i, 5:10] = 500.0
    return Response(t=np.arange(n) * 1e-4, W=W, F=F, w0=W[:, 0].copy(), v0=np.ones(m), dt=1e-4)


def test_noise_is_per_channel_scaled_by_each_channels_own_rms():
    r = _response()
    a = noisy(r, NoiseSpec(0.02, seed=3), "sc", "beam", "load1")
    rel = np.std(a.W - r.W, axis=1) / np.sqrt(np.mean(r.W**2, axis=1))
    # every sensor row at 2 % of its own RMS (4000 draws per row: 1.1 % sampling error)
    np.testing.assert_allclose(rel, 0.02, rtol=0.05)
    # only the loaded row of F is measured; the 24 others stay exactly zero
    assert list(force_channels(r.F)) == [3]
    np.testing.assert_array_equal(a.F[np.arange(25) != 3], 0.0)
    rms_f = np.sqrt(np.mean(r.F[3] ** 2))
    assert np.std(a.F[3] - r.F[3]) / rms_f == pytest.approx(0.02, rel=0.05)
    # streams keyed by (seed, scenario, structure, case, quantity, channel)
    z = noise_generator(3, "sc", "beam", "load1", "W", "7").standard_normal(4000)
    np.testing.assert_allclose(a.W[7], r.W[7] + 0.02 * np.sqrt(np.mean(r.W[7] ** 2)) * z,
                               rtol=1e-15, atol=0)
    # the same pattern at every level; channels independent
    b = noisy(r, NoiseSpec(0.04, seed=3), "sc", "beam", "load1")
    np.testing.assert_allclose(b.W - r.W, 2 * (a.W - r.W), rtol=0, atol=1e-15)
    dz = (a.W - r.W) / np.sqrt(np.mean(r.W**2, axis=1))[:, None]
    assert abs(np.corrcoef(dz[0], dz[1])[0, 1]) < 0.06
    # initial profiles per sensor on request, scaled by the profile's RMS
    c = noisy(r, NoiseSpec(0.02, seed=3, on=("v0",)), "sc", "beam", "load1")
    assert np.array_equal(c.W, r.W) and np.std(c.v0 - r.v0) == pytest.approx(0.02, rel=0.4)


def test_the_old_model_stays_a_named_option_and_differs():
    r = _response()
    old = noisy(r, NoiseSpec(0.02, seed=3, model="per_entry_rms"), "sc", "beam", "load1")
    assert np.count_nonzero(old.F) == old.F.size  # every entry of F, loaded or not
    rms = np.sqrt(np.mean(r.W**2))
    assert np.std(old.W - r.W) / rms == pytest.approx(0.02, rel=0.02)
    with pytest.raises(InputError, match="noise model"):
        NoiseSpec(0.01, model="white")


def test_snr_in_db_is_a_level():
    assert level_from_snr_db(40) == pytest.approx(0.01, rel=1e-14)
    assert level_from_snr_db(20 * np.log10(20)) == pytest.approx(0.05, rel=1e-14)
    assert snr_db_from_level(0.01) == pytest.approx(40.0)
    assert NoiseSpec.from_snr_db(40, seed=2) == NoiseSpec(level_from_snr_db(40), seed=2)


def test_force_offset_and_drift_on_the_measured_force_only():
    r = _response(loaded=(3, 9))
    d = noisy(r, NoiseSpec(0.0, force_offset=0.01, force_drift=0.02), "sc", "b", "c")
    np.testing.assert_array_equal(d.W, r.W)  # no sensor noise at level 0
    n = r.F.shape[1]
    for i in (3, 9):
        expect = r.F[i] + 500.0 * (0.01 + 0.02 * np.arange(n) / (n - 1))
        np.testing.assert_allclose(d.F[i], expect, rtol=1e-14)
    assert not d.F[[0, 1, 2, 4]].any()
    assert noisy(r, NoiseSpec(0.0), "sc", "b", "c") is r


def test_runner_keeps_the_old_names_importable():
    assert runner.NoiseSpec is NoiseSpec and runner.noisy is noisy
    assert runner.noise_generator is noise_generator


def test_double_and_triple_hits_are_part_of_the_excitation():
    dt, n = 1e-4, 200
    single = Pulse(2.0, 500.0, 5e-4).history(n, dt)
    triple = Pulse(2.0, 500.0, 5e-4, hits=[[2e-3, 0.3], [4.5e-3, 0.1]]).history(n, dt)
    np.testing.assert_array_equal(triple[:20], single[:20])
    np.testing.assert_array_equal(triple[21:26], 150.0)  # 2 ms later, 30 %
    np.testing.assert_array_equal(triple[46:51], 50.0)   # 4.5 ms later, 10 %
    assert np.count_nonzero(triple) == 15
    # from a scenario table, round trip through to_dict
    d = {"kind": "pulse", "location": 2.0, "amplitude": 500.0, "duration": 5e-4,
         "hits": [[2e-3, 0.3]]}
    p = excitation_from_dict(d)
    assert p.to_dict()["hits"] == [[2e-3, 0.3]]
    np.testing.assert_array_equal(excitation_from_dict(p.to_dict()).history(n, dt),
                                  p.history(n, dt))
    with pytest.raises(InputError, match="delay_s > 0"):
        Pulse(2.0, 500.0, 5e-4, hits=[[0.0, 0.3]])
    with pytest.raises(InputError, match="delay_s > 0"):
        Pulse(2.0, 500.0, 5e-4, hits=[[1e-3]])
