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


def test_default_ml_on_clean_records_is_the_exact_answer():
    recs, F_new = _records()
    W, F = [r.W for r in recs], [r.F for r in recs]
    default = MultipleLoad(n_modes=2).fit(W, F, dt=DT)
    ls = MultipleLoad(n_modes=2, solver="ls").fit(W, F, dt=DT)
    assert default.diagnostics_["solver_choice"] == "block"
    assert default.solver_info_["noise_floor"] <= 1e-3
    pred, ref = default.predict(F_new), ls.predict(F_new)
    assert np.linalg.norm(pred - ref) <= 1e-8 * np.linalg.norm(ref)


def test_band_of_ml_with_explicit_modes_equal_to_the_records():
    # k = N records with n_modes given: the cross-validation folds have N − 1 records and
    # fit k − 1 modes (their basis's count), instead of refusing n_modes = k
    recs, F_new = _records()
    model = MultipleLoad(n_modes=2, solver="block").fit(recs)
    target = pb.Record(W=np.zeros((6, F_new.shape[1])), F=F_new, dt=DT)
    pred = model.predict(target, coverage=0.9)
    assert np.array_equal(pred.mean, model.predict(target))
    assert np.all(pred.lower <= pred.mean) and np.all(pred.mean <= pred.upper)
    assert np.any(pred.upper > pred.lower) and np.isfinite(pred.error_estimate)
