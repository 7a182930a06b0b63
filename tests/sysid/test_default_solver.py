"""The forced methods' default solver is ``"auto"`` (issue 23, "Defaults are the fast, safe
ones"): on clean records it returns the exact answer (the dense least squares of the
dissertation, computed independently here with ``solver="ls"``) through ``"block"``."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import podbench as pb
from podbench.structures.chain import chain
from podbench.sysid.methods import MixedResponse, MultipleLoad, SingleLoad

DT = 1e-3


@pytest.mark.parametrize("cls", [SingleLoad, MultipleLoad, MixedResponse])
def test_default_solver_is_auto(cls):
    assert inspect.signature(cls).parameters["solver"].default == "auto"
    assert cls().get_params()["solver"] == "auto"


def _records(n=120):
    s = chain(6, masses=1.0, springs=400.0, rayleigh=(0.2, 1e-4))
    out = []
    for j in range(2):
        F = np.zeros((6, n))
        F[5 - 2 * j, 1:4] = 5.0
        out.append(pb.simulate(s, n_samples=n, dt=DT, force=F))
    F = np.zeros((6, n))
    F[4, 1:6] = 3.0 * np.sin(np.pi * np.arange(5) / 5)
    return out, F


@pytest.mark.heavy
def test_default_ml_on_clean_records_is_the_exact_answer():
    recs, F_new = _records()
    W, F = [r.W for r in recs], [r.F for r in recs]
    default = MultipleLoad(n_modes=2).fit(W, F, dt=DT)
    ls = MultipleLoad(n_modes=2, solver="ls").fit(W, F, dt=DT)
    assert default.diagnostics_["solver_choice"] == "block"
    assert default.solver_info_["noise_test"] == "kernel"
    assert default.solver_info_["noise_floor"] < 1e-12  # round-off: the records are exact
    pred, ref = default.predict(F_new), ls.predict(F_new)
    assert np.linalg.norm(pred - ref) <= 1e-8 * np.linalg.norm(ref)


@pytest.mark.heavy
def test_auto_kernel_test_reads_the_noise_level():
    """Noise on the responses only (the force channels clean): block solves, and the Hankel
    floor of its kernel against that of reference noise at the threshold reads the level:
    round-off on exact records, below the threshold on records rounded to single precision,
    above it from 0.3 % per-channel noise on (an estimate of the level within a factor 3)."""
    from podbench.sysid.noise import NoiseSpec, noisy

    recs, _ = _records()
    W, F = [r.W for r in recs], [r.F for r in recs]
    clean = MultipleLoad(n_modes=2).fit(W, F, dt=DT).solver_info_
    assert clean["noise_test"] == "kernel" and clean["noise_floor"] < 1e-12
    single = [w.astype(np.float32).astype(float) for w in W]
    info = MultipleLoad(n_modes=2).fit(single, F, dt=DT).solver_info_
    assert info["choice"] == "block" and 1e-9 < info["noise_floor"] < 1e-5
    for level in (3e-3, 1e-2, 5e-2):
        nz = [noisy(r, NoiseSpec(level=level, on=("W",)), "t", str(j))
              for j, r in enumerate(recs)]
        info = MultipleLoad(n_modes=2).fit([r.W for r in nz], F, dt=DT).solver_info_
        assert info["noise_test"] == "kernel" and info["choice"] == "subspace"
        assert max(level / 3, 1e-3) < info["noise_floor"] < 30 * level


@pytest.mark.heavy
def test_hankel_floor_sees_finite_order_and_scales_with_the_kernel():
    from podbench.sysid.deconvolution.auto import hankel_floor

    n, t = 200, np.arange(200) * 0.01
    # a 2-input, 2-output impulse response of order 4 (two damped modes): rank 4
    modes = [np.exp(-0.5 * t) * np.sin(6 * t), np.exp(-0.8 * t) * np.cos(15 * t)]
    X = np.zeros((n, 2, 2))
    for i, mode in enumerate(modes):
        X += mode[:, None, None] * np.outer([1, i + 1], [2, -i])[None]
    top = np.linalg.norm(X)
    assert hankel_floor(X) < 1e-13 * top
    noise = 1e-4 * np.random.default_rng(0).standard_normal(X.shape)
    assert hankel_floor(X + noise) > 1e-6 * top
    assert hankel_floor(1e-3 * (X + noise)) == pytest.approx(1e-3 * hankel_floor(X + noise),
                                                             rel=1e-9)
