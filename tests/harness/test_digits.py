"""Fit diagnostics whose last digits move between BLAS kernels are written to two digits."""

import math
from types import SimpleNamespace

from podbench.harness.digits import coverage_digits, diagnostic_digits
from podbench.harness.tables import fits_table, table_csv


def test_conditioning_and_iterations_are_written_to_two_digits():
    # the pairs measured on two OpenBLAS kernels land on the same written value
    assert diagnostic_digits("solver_iterations", 188) == diagnostic_digits(
        "solver_iterations", 189) == 190.0
    assert diagnostic_digits("condition_number", 117.568) == 120.0
    assert diagnostic_digits("solver_noise_floor", 1.87089e-06) == 1.9e-06
    # auto's noise floor: round-off written as 0 (2.7e-15 and 3.1e-15 can be the same fit on
    # two kernels), an estimate above 1e-9 to two digits
    assert diagnostic_digits("solver_noise_floor", 2.7e-15) == 0.0
    assert diagnostic_digits("solver_noise_floor", 8.3e-11) == 0.0
    assert diagnostic_digits("solver_noise_floor", 2.7412e-07) == 2.7e-07
    # other columns, zeros and NaN are left alone
    assert diagnostic_digits("fit_residual", 0.123456) == 0.123456
    assert diagnostic_digits("solver_iterations", 0) == 0
    assert math.isnan(diagnostic_digits("condition_number", float("nan")))


def test_fits_table_applies_them():
    unit = SimpleNamespace(fits=[{"scenario": "s", "structure": "b", "method": "ML",
                                  "condition_number": 341.241, "solver_iterations": 279,
                                  "fit_residual": 0.25}])
    text = table_csv(fits_table([unit]))
    assert text.splitlines()[1] == "s,b,ML,340,0.25,280"


def test_coverage_is_written_to_two_decimals():
    # the pair measured on two OpenBLAS kernels (one sample of 12,500 on the band's edge)
    assert coverage_digits(0.63792) == coverage_digits(0.638) == 0.64
    assert coverage_digits(0.9) == 0.9 and math.isnan(coverage_digits(float("nan")))
