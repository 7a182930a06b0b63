"""The digits podbench's tables write for fit diagnostics: those whose last digits move between
BLAS kernels are rounded where they are recorded, so that a table regenerates byte-identically
on any CPU."""

from __future__ import annotations

import numpy as np

__all__ = ["ESTIMATE_COLUMNS", "DIAGNOSTIC_COLUMNS", "ROUNDOFF_COLUMNS", "ROUNDOFF_FLOOR",
           "COVERAGE_DECIMALS", "CONDITION_COLUMNS", "SINGULAR_CONDITION", "diagnostic_digits",
           "coverage_digits"]

#: Estimates in ``fits.csv`` written to two significant digits: the noise floor that ``auto``
#: compares with its threshold (1e-3) is an evidence estimate, and on clean single-precision
#: records (1e-7…1e-6, the rounding of the file) its fourth digit differs between OpenBLAS
#: kernels (measured: 1.87089e-06 against 1.87098e-06 for the same fit).
ESTIMATE_COLUMNS = ("solver_noise_floor",)

#: Conditioning diagnostics and iteration counts in ``fits.csv`` and ``sweep.csv`` written to
#: two significant digits: a condition number of an ill-conditioned system, the amplification
#: and growth of a triangular solve, and the iteration at which a stopping rule is met all
#: move between OpenBLAS kernels (measured: the ``ls`` condition number in its third digit,
#: cgls stopping at iteration 188 against 189, stls at 279 against 281); what they tell — the
#: order of magnitude, roughly how many iterations — is in the first two digits.
DIAGNOSTIC_COLUMNS = ("condition_number", "solver_condition", "solver_amplification",
                      "solver_growth", "solver_iterations", "solver_solves")


#: Estimates that are round-off on clean data, written as 0 below :data:`ROUNDOFF_FLOOR`
#: (and to two significant digits above): ``auto``'s noise floor from its kernel test is a
#: ratio of Hankel singular values, 1e-15…8e-11 on exact double-precision records (digits
#: that are round-off and differ between BLAS kernels), 3e-8…8e-5 on records rounded to
#: single precision, at least 2.5e-3 with 0.3 % noise (benchmarks/auto_test.py).
ROUNDOFF_COLUMNS = ("solver_noise_floor",)
ROUNDOFF_FLOOR = 1e-9

#: Condition numbers ``σ_max/σ_min`` written as ``inf`` at or above :data:`SINGULAR_CONDITION`
#: (``σ_min ≤ 1e-14·σ_max``): such a ``σ_min`` is the SVD's round-off of a numerically
#: singular matrix (about ``n·ε·σ_max``, ε = 2.2e-16), not a property of the data. Measured
#: on Chapter 5's 2048-sample force matrices: 1.6e16…4.6e16 on the SkylakeX OpenBLAS kernel,
#: 4.2e16 against 4.6e16 for the same fit on the Haswell kernel; every well-posed system of
#: the committed studies reads below 1e13.
CONDITION_COLUMNS = ("condition_number", "solver_condition")
SINGULAR_CONDITION = 1e14


def diagnostic_digits(name: str, value):
    """``value`` of diagnostic ``name`` at the digits the tables write (:data:`ESTIMATE_COLUMNS`,
    :data:`DIAGNOSTIC_COLUMNS`: two significant digits; :data:`ROUNDOFF_COLUMNS`: 0 below
    :data:`ROUNDOFF_FLOOR`, else two significant digits; :data:`CONDITION_COLUMNS`: ``inf``
    at or above :data:`SINGULAR_CONDITION`); other values unchanged."""
    if name in ESTIMATE_COLUMNS + DIAGNOSTIC_COLUMNS + ROUNDOFF_COLUMNS \
            and isinstance(value, (int, float)) and not isinstance(value, bool) \
            and np.isfinite(value) and value != 0:
        if name in ROUNDOFF_COLUMNS and abs(value) < ROUNDOFF_FLOOR:
            return 0.0
        if name in CONDITION_COLUMNS and abs(value) >= SINGULAR_CONDITION:
            return float("inf")
        return float(f"{value:.2g}")
    return value


#: A band's realized coverage (the fraction of the truth's samples inside it) is written to
#: two decimals: the band's edges move in their sixth digit between OpenBLAS kernels, so a
#: sample of the truth lying on an edge falls in or out (measured on the MR designs: 0.63792
#: against 0.638, one sample of 12,500). The coverage is judged against 0.85–0.95.
COVERAGE_DECIMALS = 2


def coverage_digits(value: float) -> float:
    """``value`` to :data:`COVERAGE_DECIMALS` decimals (NaN unchanged)."""
    return round(float(value), COVERAGE_DECIMALS) if np.isfinite(value) else float(value)
