"""Fit diagnostics whose last digits move between BLAS kernels are written to two digits."""

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd

from podbench.core.validation import condition_number
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


def test_a_numerically_singular_systems_condition_is_written_inf_whatever_its_roundoff():
    # a 300 × 300 product of 300 × 295 and 295 × 300 random factors has rank 295: its five
    # smallest computed singular values are the SVD's round-off (they differ for the same
    # matrix with its rows permuted, and between BLAS kernels)
    rng = np.random.default_rng(3)
    A = rng.standard_normal((300, 295)) @ rng.standard_normal((295, 300))
    perm = rng.permutation(A.shape[0])
    c1 = condition_number(np.linalg.svd(A, compute_uv=False))
    c2 = condition_number(np.linalg.svd(A[perm], compute_uv=False))
    assert np.isfinite(c1) and np.isfinite(c2)
    assert min(c1, c2) >= 1e14          # σ_min at round-off
    assert diagnostic_digits("condition_number", c1) == math.inf
    assert diagnostic_digits("solver_condition", c2) == math.inf
    # a well-posed system of condition 1e12 keeps its two digits
    s = np.logspace(0, -12, 50)
    assert diagnostic_digits("condition_number", condition_number(s)) == 1e12


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


def test_round_off_errors_are_written_as_zero_and_nothing_above_the_floor():
    # an exact fit leaves relative errors of 1e-16..1e-14 whose digits depend on the process
    from podbench.harness.metrics import ERROR_ROUNDOFF, roundoff_errors
    df = pd.DataFrame({"total_error": [1.84e-15, 2.05e-15, 0.5 * ERROR_ROUNDOFF,
                                       2 * ERROR_ROUNDOFF, float("nan")],
                       "norm_pe_max": [1.8e-13, 5e-9, 2e-8, 0.3, float("nan")],
                       "norm_peak_ratio": [1e-12, 1.0, 1.0, 1.0, 1.0]})
    out = roundoff_errors(df.copy())
    assert out["total_error"].tolist()[:4] == [0.0, 0.0, 0.0, 2 * ERROR_ROUNDOFF]
    assert out["norm_pe_max"].tolist()[:4] == [0.0, 0.0, 2e-8, 0.3]  # percent: 100 × floor
    assert np.isnan(out["total_error"].iloc[4]) and np.isnan(out["norm_pe_max"].iloc[4])
    assert out["norm_peak_ratio"].tolist() == df["norm_peak_ratio"].tolist()  # a ratio, kept
