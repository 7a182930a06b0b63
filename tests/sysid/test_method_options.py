"""podbench's own options beyond the dissertation: ML/MDS ``basis="all"``, kernel truncation
``n_lags`` of SL/ML and predictions longer than the training records, and ERA from free
decays beside MDS."""

from __future__ import annotations

import numpy as np
import pytest

from podbench import Record
from podbench.errors import DimensionError, InputError
from podbench.sysid.methods import ERA, MDS, MultipleLoad, SingleLoad
from podbench.sysid.methods.forced import KERNEL_TAIL, kernel_lags
from podbench.sysid.pod import snapshot_svd

from ._cases import D, forced_case, free_case
from ._truth import coupled_chain, newmark, pulse, rel_err, smooth_load

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _forced_records(case):
    return [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W, case.F, strict=True)]


def _free_records(case, excitation):
    key = "w0" if excitation == "displacement" else "v0"
    return ([Record(W=W, dt=case.dt, **{key: x}) for W, x in zip(case.W, case.x0, strict=True)],
            Record(W=case.W_new, dt=case.dt, **{key: case.x0_new}))


# ---------------------------------------------------------------------- basis = "all"
def test_ml_basis_all_is_the_pom_basis_of_all_records_and_exact_at_k_equal_m():
    c = forced_case("coupled")
    ml = MultipleLoad(solver="block", basis="all").fit(_forced_records(c))
    U = snapshot_svd(np.hstack(c.W)).modes[:, :D]
    assert np.allclose(np.abs(U.T @ ml.modes_), np.eye(D), atol=1e-10)
    assert rel_err(ml.predict(c.F_new), c.W_new) < 1e-12
    # the fit keyword overrides the hyperparameter
    U1 = snapshot_svd(c.W[0]).modes
    ml1 = MultipleLoad(solver="block", basis="all").fit(_forced_records(c), basis=U1)
    assert np.array_equal(ml1.modes_, U1)


def test_mds_basis_all_is_exact_on_the_coupled_chain():
    recs, tgt = _free_records(free_case("coupled", "displacement"), "displacement")
    mds = MDS(basis="all").fit(recs)
    assert rel_err(mds.predict(tgt), tgt.W) < 1e-12
    U = snapshot_svd(np.hstack([r.W for r in recs])).modes[:, :D]
    assert np.allclose(np.abs(U.T @ mds.modes_), np.eye(D), atol=1e-10)


@pytest.mark.parametrize("cls", [MultipleLoad, MDS])
def test_bad_basis_choice_is_one_line_naming_it(cls):
    with pytest.raises(InputError, match=r"^Parameter `basis`: 'every'"):
        cls(basis="every")._validate_params()


# ---------------------------------------------------------------------- n_lags
def test_kernel_lags_rule_leaves_at_most_the_tail_fraction():
    e = 0.5 ** np.arange(40)  # kernel amplitudes halving every lag
    kernel = e[None, None, :] * np.ones((2, 2, 1))
    L = kernel_lags(kernel)
    energy = e**2
    assert energy[L:].sum() <= KERNEL_TAIL * energy.sum() < energy[L - 1:].sum()
    # 0.25^L / (1 − 0.25^40) <= 1e-6 first at L = 10
    assert L == 10


@pytest.mark.parametrize("n_lags", [0, -3, 2.5, "all", True])
def test_bad_n_lags_is_one_line_naming_it(n_lags):
    with pytest.raises(InputError, match=r"^Parameter `n_lags`"):
        MultipleLoad(n_lags=n_lags)._validate_params()


def test_truncated_kernel_is_zero_beyond_n_lags_and_kept_before():
    c = forced_case("coupled")
    full = MultipleLoad(solver="block").fit(_forced_records(c))
    cut = MultipleLoad(solver="block", n_lags=50).fit(_forced_records(c))
    assert cut.n_lags_ == 50 and cut.diagnostics_["n_lags"] == 50
    assert np.array_equal(cut.kernel_[:, :, :50], full.kernel_[:, :, :50])
    assert not np.any(cut.kernel_[:, :, 50:])
    sl = SingleLoad(n_modes=3, n_lags="auto").fit(_forced_records(c)[0])
    assert 1 <= sl.n_lags_ <= c.n and sl.coupled_twin().n_lags == "auto"


def _damped_chain_case(n: int):
    """The coupled chain with 40·M more damping (every mode decays at >= 20.7 1/s): its
    kernel falls to ~1e-7 of its peak within n = 400 samples of 2 ms."""
    M, C, K = coupled_chain(D)
    C = C + 40.0 * M
    dt = 0.002
    F = [pulse(D, n, j, start=1, width=5) for j in range(D)]
    recs = [Record(W=newmark(M, C, K, dt, n, F=Fj)[0], F=Fj, dt=dt) for Fj in F]
    F2 = np.zeros((D, 2 * n))
    F2[:, :n] = smooth_load(D, n, np.random.default_rng(13))
    W2 = newmark(M, C, K, dt, 2 * n, F=F2)[0]
    return recs, F2, W2


def test_a_truncated_kernel_predicts_a_record_twice_as_long_as_the_training_ones():
    n = 400
    recs, F2, W2 = _damped_chain_case(n)
    # without truncation: refused, naming the option that allows it
    ml = MultipleLoad(solver="block").fit(recs)
    with pytest.raises(DimensionError, match=r"`F_new`: 800 samples, expected n' <= 400.*"
                                             r"set `n_lags`"):
        ml.predict(F2)
    # n_lags = n: the kernel of the whole record, zero beyond (it has decayed to ~e^-16)
    full = MultipleLoad(solver="block", n_lags=n).fit(recs)
    assert rel_err(full.predict(F2), W2) < 1e-6
    # causal: the first n samples of the long prediction are the short prediction
    assert np.allclose(full.predict(F2)[:, :n], full.predict(F2[:, :n]), rtol=0, atol=1e-15)
    # "auto" drops a tail of <= 1e-6 of the kernel energy: an error of that amplitude order
    auto = MultipleLoad(solver="block", n_lags="auto").fit(recs)
    assert auto.n_lags_ < n
    assert 1e-6 < rel_err(auto.predict(F2), W2) < 30 * np.sqrt(KERNEL_TAIL)
    # SL (diagonal kernel) predicts the long record too
    sl = SingleLoad(n_modes=D, n_lags=n).fit(recs[0])
    assert sl.predict(F2).shape == (D, 2 * n)


# ---------------------------------------------------------------------- ERA from free decay
@pytest.mark.parametrize("excitation", ["displacement", "velocity"])
def test_era_free_is_exact_on_the_coupled_chain_like_mds(excitation):
    recs, tgt = _free_records(free_case("coupled", excitation), excitation)
    era = ERA(excitation=excitation, order=2 * D).fit(recs)
    assert era.excitation_kind == "free" and era.required_fields()[1] in ("w0", "v0")
    assert rel_err(era.predict(tgt), tgt.W) < 1e-11
    assert rel_err(MDS(excitation=excitation).fit(recs).predict(tgt), tgt.W) < 1e-12
    # the hold-out rule finds the state dimension 2m of Newmark's (w, ẇ)
    auto = ERA(excitation=excitation).fit(recs)
    assert auto.order_ == 2 * D
    assert rel_err(auto.predict(tgt), tgt.W) < 1e-11
    # the free-decay Markov parameters are MDS's Φ(t_i) in the same basis
    mds = MDS(excitation=excitation).fit(recs, basis=era.modes_)
    assert np.allclose(era.markov_, mds.Phi_, rtol=0, atol=1e-9 * np.abs(mds.Phi_).max())
    twin = era.coupled_twin()
    assert isinstance(twin, MDS) and twin.excitation == excitation


def test_era_free_predicts_beyond_the_training_length():
    c = free_case("coupled", "displacement")
    recs, _ = _free_records(c, "displacement")
    era = ERA(excitation="displacement", order=2 * D).fit(recs)
    W2 = newmark(c.M, c.C, c.K, c.dt, 2 * c.n, w0=c.x0_new)[0]
    assert rel_err(era.predict(Record(W=W2, w0=c.x0_new, dt=c.dt)), W2) < 1e-10


def test_era_free_bad_excitation_and_too_few_profiles():
    with pytest.raises(InputError, match=r"^Parameter `excitation`: 'free'"):
        ERA(excitation="free")._validate_params()
    recs, _ = _free_records(free_case("coupled", "displacement"), "displacement")
    with pytest.raises(InputError, match="fewer than k = 5"):
        ERA(excitation="displacement", n_modes=5).fit(recs[:3])
