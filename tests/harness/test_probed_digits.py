"""The probe rule of podbench.harness.digits (issue 23): a value is written at the significant
digits on which the fit on the records and on the probed records agree."""

import math

import numpy as np

from podbench.harness.digits import (
    ROUNDOFF_PROBE,
    determined,
    determined_digits,
    determined_row,
    probe_perturbation,
)


def test_determined_digits_counts_the_digits_the_gap_leaves():
    # |a - b| = 4e-6 on 0.844511: half a unit of the 5th digit is 5e-6, of the 6th 5e-7
    assert determined_digits(0.844511, 0.844507) == 5
    assert determined(0.844511, 0.844507) == 0.84451
    # a gap of 0.04 on 0.46: one digit (half a unit of the 2nd is 0.005)
    assert determined_digits(0.46, 0.42) == 1
    assert determined(0.46, 0.42) == 0.5
    assert determined_digits(2.0, 2.0) == 6
    assert math.isnan(determined(6.82e-5, 1.63e-4))  # not one digit: NaN


def test_determined_keeps_equal_integers_and_text():
    assert determined(12, 12) == 12
    assert math.isnan(determined(12, 13))
    assert determined("ok", "failed") == "ok"
    row = determined_row({"method": "ERA", "e": 1.2345678, "n": 3}, {"method": "ERA",
                                                                       "e": 1.2345, "n": 3})
    assert row == {"method": "ERA", "e": 1.235, "n": 3}


def test_probe_is_seeded_relative_and_keeps_rest():
    X = np.array([[0.0, 1.0, -2.0], [0.0, 3e5, 4e-7]])
    P = probe_perturbation(X, "s", "c")
    assert np.array_equal(P, probe_perturbation(X, "s", "c"))
    assert P[0, 0] == 0 and P[1, 0] == 0
    rel = np.abs(P[:, 1:] / X[:, 1:] - 1)
    assert np.all(rel > 0) and np.all(rel < 6 * ROUNDOFF_PROBE)
    assert not np.array_equal(P, probe_perturbation(X, "s", "other"))


def test_written_value_unmoved_by_ulp_changes_of_the_input():
    # a computation that amplifies its input 1e6-fold (an ill-conditioned solve): its answer's
    # last digits follow an ulp change of the input, the digits the probe leaves do not
    def solve(x):
        return 0.7 + 1e6 * (x - 0.25)

    x = 0.25 + 3e-9
    probe = float(probe_perturbation(np.array([x]), "t")[0])
    written = determined(solve(x), solve(probe))
    rng = np.random.default_rng(0)
    moved = 0
    for _ in range(200):
        xu = x + rng.integers(-4, 5) * np.spacing(x)
        moved += solve(xu) != solve(x)
        pu = float(probe_perturbation(np.array([xu]), "t")[0])
        assert determined(solve(xu), solve(pu)) == written
    assert moved > 0  # the raw answer does follow the ulp changes
