"""Claim checks: the grammar, the verdicts on a known table, and the decomposition helpers."""

import math

import numpy as np
import pandas as pd
import pytest

from podbench.errors import ScenarioFileError
from podbench.harness.claims import evaluate_claims, load_claims
from podbench.harness.metrics import decompose, norm_summaries

TABLE = pd.DataFrame([
    {"scenario": "s", "structure": "a", "method": "POVR", "target": "t", "total_error": 0.3,
     "projection_error": 0.01},
    {"scenario": "s", "structure": "a", "method": "MDS", "target": "t", "total_error": 0.02,
     "projection_error": 0.01},
    {"scenario": "s", "structure": "b", "method": "MDS", "target": "t", "total_error": 0.2,
     "projection_error": float("nan")},
])


def _claims(tmp_path, body):
    p = tmp_path / "claims.toml"
    p.write_text(body)
    return load_claims(p)


def test_verdicts(tmp_path):
    claims, remarks = _claims(tmp_path, """
[[claims]]
id = "one"
source = "§x"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["MDS.total_error < 0.05", "MDS.total_error < POVR.total_error"]
[[claims]]
id = "two"
source = "§x"
quote = "q"
scenario = "s"
structure = ["a", "b"]
target = "t"
checks = ["MDS.total_error <= 0.1"]
[[claims]]
id = "three"
source = "§x"
quote = "q"
scenario = "s"
structure = "b"
target = "t"
checks = ["MDS.projection_error < 1", "POVR.total_error > 0"]
[[remarks]]
title = "r"
text = "t"
""")
    v = {e["claim"].id: e["verdict"] for e in evaluate_claims(claims, TABLE)}
    assert v == {"one": "reproduced", "two": "not reproduced", "three": "not measured"}
    assert remarks == [{"title": "r", "text": "t"}]


@pytest.mark.parametrize("check", ["MDS.total_error", "MDS.total_error == 1", "< 3",
                                   "MDS.total_error < < 2"])
def test_bad_checks_are_rejected(tmp_path, check):
    with pytest.raises(ScenarioFileError, match="checks"):
        _claims(tmp_path, f"""
[[claims]]
id = "x"
source = "s"
quote = "q"
scenario = "s"
structure = "a"
target = "t"
checks = ["{check}"]
""")


def test_decompose_on_constructed_matrices():
    rng = np.random.default_rng(0)
    U, _ = np.linalg.qr(rng.standard_normal((8, 3)))
    W = rng.standard_normal((8, 40))
    PW = U @ U.T @ W
    W_hat = PW + U @ rng.standard_normal((3, 40)) * 0.1
    d = decompose(W, W_hat, U, coupled=True)
    N = np.linalg.norm(W)
    assert d["projection_error"] == pytest.approx(np.linalg.norm(W - PW) / N)
    assert d["diagonalization_error"] == 0 and d["linearization_error"] == 0
    assert d["residual_error"] == pytest.approx(np.linalg.norm(W_hat - PW) / N)
    # with the full basis the projection error vanishes
    Q, _ = np.linalg.qr(rng.standard_normal((8, 8)))
    assert decompose(W, W, Q, coupled=True)["projection_error"] < 1e-14
    # zero truth: every error is undefined rather than infinite
    assert all(math.isnan(v) for v in decompose(0 * W, W, U).values())
    s = norm_summaries(W, 1.1 * W)
    assert s["norm_pe_median"] == pytest.approx(10.0) and s["norm_peak_ratio"] == pytest.approx(1.1)
