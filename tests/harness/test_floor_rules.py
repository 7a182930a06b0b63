"""Numbers only round-off decides (issue 23):

* a relative residual an iterative solver drives to its floor is written at the digits its
  stopping tolerance and the BLAS kernel's round-off leave it (``residual_digits``), as its
  decade when not even one (``decade_bound``: the clean ML-``stls`` fit of Chapter 5,
  3.43e-6 / 3.36e-6 on two OpenBLAS kernels);
* a numerically singular direct solve (condition number written ``inf``: Chapter 5's
  SL-``ls`` at 5 % noise, 3.644e7 / 3.64399e7 on two kernels) moves by less than one unit of
  its sixth digit, which podbench.harness.rewrite absorbs; it keeps the tables' digits.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from podbench.deconvolution import CGLS, STLS

from podbench.harness.digits import (
    decade_bound,
    floor_digits,
    iterative_row,
    residual_digits,
    residual_written,
    solver_digits,
)

ROOT = Path(__file__).resolve().parents[2]
CH5 = ROOT / "scenarios" / "chapter5"


def test_residual_digits_follow_their_own_measurements():
    # stls: a decade of tolerance moves the clean fit's residual by 2.1 % (= 21*sqrt(1e-6)):
    # two digits determined; the kernels move it by 3.2 %: not one digit three digits above
    # that round-off -> 0, the decade only
    rule = STLS.stopping
    assert rule.residual_gain * 1e-6 ** rule.residual_power == pytest.approx(2.1e-2)
    assert residual_digits("stls") == 0 and residual_digits("stls", 1e-8) == 0
    # cgls: 7.2e-4 per decade (4 digits), 3.4e-5 between kernels -> 5 - 3 = 2 digits
    rule = CGLS.stopping
    assert rule.residual_gain * 1e-10 ** rule.residual_power == pytest.approx(7.2e-4)
    assert residual_digits("cgls") == 2 and residual_digits("realization") == 2
    # a looser cgls tolerance decides: 1e-7 moves it by 0.72 -> one digit; kernel's 1e-6: 0
    assert residual_digits("cgls", 1e-7) == 1 and residual_digits("kernel") == 0
    # a direct solver's residual keeps the tables' digits; a superposition the fewest
    assert residual_digits("ls") is None and residual_digits("ls+stls") == 0
    # these differ from the digits of the same fits' errors
    assert solver_digits("stls") == 3 and solver_digits("cgls") == 3


def test_decade_bound():
    # the clean ML-stls residual on the two kernels: one written value, an upper bound
    assert decade_bound(3.43e-6) == decade_bound(3.36e-6) == 1e-5
    assert decade_bound(3.43e-6) >= 3.43e-6
    assert decade_bound(1e-6) == 1e-6 and decade_bound(1.0000001e-6) == 1e-5
    assert decade_bound(-2.2e-3) == -1e-2 and decade_bound(0.0) == 0.0
    assert np.isnan(decade_bound(float("nan"))) and decade_bound(7) == 7
    assert residual_written(3.43e-6, 0) == 1e-5
    # calibration's clean cgls residual, 4.44e-7 / 4.45e-7 at three digits: one value at two
    assert residual_written(4.4449e-7, 2) == residual_written(4.4451e-7, 2) == 4.4e-7


def test_an_iterative_row_writes_its_residuals_at_their_digits():
    row = {"method": "ML-stls", "fit_residual": 3.4687e-6, "solver_residual": 3.4687e-6,
           "solver_objective": 6.314113e-5, "total_error": 0.27238892, "solver_iterations": 170,
           "projection_error": 0.2455961}
    det = STLS().determined()
    out = iterative_row(row, det.digits, det.residual_digits)
    assert out["fit_residual"] == out["solver_residual"] == 1e-5
    assert out["total_error"] == 0.272 and out["solver_objective"] == 6.31e-5
    assert np.isnan(out["solver_iterations"]) and out["projection_error"] == 0.2455961
    # without residual digits, the residual is at the row's digits (as before)
    assert iterative_row(row, 3)["fit_residual"] == 3.47e-6
    det = CGLS().determined()
    assert iterative_row({"fit_residual": 5.58539e-8}, det.digits,
                         det.residual_digits)["fit_residual"] == 5.6e-8


def _chapter5(name):
    from podbench.harness.runner import read_case
    from podbench.study.resolve import resolve_structure
    from podbench.study.scenarios import load_scenario
    sc = load_scenario(CH5 / f"{name}.toml")
    st = resolve_structure(sc.structures[0], sc)
    return sc, {c: read_case(sc, c, st) for c in sc.cases}


@pytest.mark.slow
def test_a_stls_residual_is_known_only_to_its_decade():
    """The clean ML-stls fit of Chapter 5: a decade of tolerance moves its relative
    residual by percents while its error stays put; written as its decade, it is one
    value at every tolerance, and an upper bound of each."""
    from podbench.harness.metrics import decompose
    from podbench.harness.runner import fit_method
    sc, recs = _chapter5("linear_beam_noise_0pct")
    spec = sc.method("ML-stls")
    residuals, errors = [], []
    for tol in (1e-5, 1e-6, 1e-7):
        s = dataclasses.replace(spec, options={**spec.options, "solver_options": {"tol": tol}})
        est = fit_method(s, sc, recs.__getitem__, None)
        residuals.append(est.diagnostics_["fit_residual"])
        W = recs["load4_clean"].W
        errors.append(decompose(W, np.asarray(est.predict(recs["load4_clean"])))["total_error"])
    residuals = np.array(residuals)
    # the residual moves by far more than stls's three digits of its errors allow (5e-4
    # of a value with leading digit 1, less for larger): 2 % here
    spread = np.ptp(residuals) / residuals.min()
    assert spread > 5e-3
    assert np.ptp(errors) / min(errors) < 1e-6  # the prediction is determined
    assert len({floor_digits(e, solver_digits("stls")) for e in errors}) == 1
    # written at its rule: one value, above every residual the tolerances gave
    written = {residual_written(v, residual_digits("stls")) for v in residuals}
    assert len(written) == 1 and all(v <= min(written) for v in residuals)
    assert min(written) == 1e-5  # residuals 3.4e-6 ... 3.5e-6


@pytest.mark.slow
def test_a_singular_solves_digits_are_amplified_roundoff():
    """SL-ls on Chapter 5's 5 % records: its system is singular (condition ``inf``); records
    perturbed at the last bits (1e-15 relative) move its predicted maximum by far more than
    that (round-off amplified) and by less than one unit of the sixth digit the tables write
    (at least 1e-6 of the value), which a regeneration keeps (podbench.harness.rewrite)."""
    from podbench.harness.metrics import norm_summaries
    from podbench.harness.rewrite import same_number
    from podbench.harness.runner import fit_method
    from podbench.harness.tables import FLOAT_FORMAT
    sc, recs = _chapter5("linear_beam_noise_5pct")
    spec = sc.method("SL-ls")
    z = np.random.default_rng(1).standard_normal(recs["load8"].W.shape)

    def perturbed(c):
        r = recs[c]
        return dataclasses.replace(r, W=r.W * (1 + 1e-15 * z)) if c == "load8" else r

    maxima = []
    for train in (recs.__getitem__, perturbed):
        est = fit_method(spec, sc, train, None)
        assert est.diagnostics_["solver_condition"] >= 1e14  # written inf
        target = recs["load4_clean"]
        maxima.append(norm_summaries(target.W, np.asarray(est.predict(target)))["norm_pe_max"])
    move = abs(maxima[1] - maxima[0]) / maxima[0]
    assert 1e-12 < move < 1e-6  # amplified round-off (~1e-8), below a sixth-digit unit
    assert same_number(FLOAT_FORMAT % maxima[0], FLOAT_FORMAT % maxima[1])
