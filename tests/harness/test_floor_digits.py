"""ERA's rows at the digits its round-off floor leaves the same on every BLAS kernel (issue 23)."""

import math

from podbench.harness.digits import FLOOR_DIGITS, floor_digits, floor_row


def test_the_measured_kernel_pairs_agree_at_the_floor_digits():
    # ERA on the peers study, OpenBLAS Haswell against SkylakeX (sixth digits differ)
    pairs = [(0.725049, 0.725047), (526.002, 526.014), (1039.19, 1039.2), (0.551121, 0.551123),
             (7591.55, 7591.54), (0.477128, 0.477131), (83.8248, 83.8247)]
    for a, b in pairs:
        assert a != b
        assert floor_digits(a) == floor_digits(b)
    assert FLOOR_DIGITS == 3
    assert floor_digits(0.725049) == 0.725 and floor_digits(1039.19) == 1040.0


def test_integers_labels_and_nan_stay():
    row = {"method": "ERA", "order": 12, "total_error": 0.844511, "coverage": float("nan"),
           "seed": 0.123456}
    out = floor_row(row, keep=("seed",))
    assert out["method"] == "ERA" and out["order"] == 12 and out["seed"] == 0.123456
    assert out["total_error"] == 0.845 and math.isnan(out["coverage"])
