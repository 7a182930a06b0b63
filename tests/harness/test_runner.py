"""The harness on small structures: exactness where theory says so, the invariants of the error
decomposition, determinism, parallel runs and the truth cache."""

import math
import warnings

import numpy as np
import pytest
from conftest import CHAIN_FORCED, CHAIN_FREE, NL_BEAM

from podbench.errors import PodbenchWarning
from podbench.harness.metrics import TWIN_RTOL
from podbench.harness.runner import SideTasks, run_study, run_unit
from podbench.harness.tables import summary_table

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)


def _rows(res):
    return {(r["structure"], r["method"], r["target"]): r for u in res for r in u.rows}


def test_mds_is_exact_and_carries_only_zero_components_on_the_coupled_chain(write_scenario):
    """k = m = 5 on an LTI chain with non-diagonal M and non-proportional damping: MDS is
    exact (Eq. 3.33 identifies Φ11 exactly), the projection is exact, and POVR's whole error
    is diagonalization error measured against MDS in the same basis."""
    p = write_scenario(CHAIN_FREE)
    rows = _rows([run_unit(p, "chain_coupled")])
    mds = rows[("chain_coupled", "MDS", "x6")]
    assert mds["projection_error"] < 1e-12
    assert mds["total_error"] < 1e-6
    assert mds["diagonalization_error"] == 0.0 and mds["linearization_error"] == 0.0
    povr = rows[("chain_coupled", "POVR", "x6")]
    assert povr["total_error"] > 1e-2  # the diagonal assumption is visibly wrong here
    # with the projection and the twin exact, the diagonalization error is the whole error
    assert povr["diagonalization_error"] == pytest.approx(povr["total_error"], rel=1e-5)
    assert povr["residual_error"] < 1e-6


def test_ml_is_exact_and_sl_error_is_diagonalization_on_the_coupled_chain(write_scenario):
    p = write_scenario(CHAIN_FORCED, "chain_forced")
    rows = _rows([run_unit(p, "chain_coupled")])
    ml, sl = rows[("chain_coupled", "ML", "f6")], rows[("chain_coupled", "SL", "f6")]
    assert ml["projection_error"] < 1e-12
    assert ml["total_error"] < 1e-6
    assert sl["total_error"] > 1e-2
    assert sl["diagonalization_error"] == pytest.approx(sl["total_error"], rel=1e-4)


def test_decomposition_invariants_on_the_nonlinear_beam(write_scenario):
    """Every component is non-negative; total² = projection² + subspace² (predictions lie in
    span U); subspace ≤ diagonalization + linearization + residual (triangle inequality)
    and ≤ own linearization + linear diagonalization + residual; the LTI beam has zero
    linearization errors and the NL beam positive ones; the twin-based attributions are
    undefined (NaN) exactly when the twin's own error exceeds the method's total."""
    p = write_scenario(NL_BEAM, "nl_short")
    res = [run_unit(p, "lti_beam"), run_unit(p, "nl_beam")]
    rows = _rows(res)
    twin_based = ("diagonalization_error", "linearization_error", "residual_error")
    for key, r in rows.items():
        always = ("total_error", "projection_error", "subspace_error", "twin_error",
                  "own_linearization_error")
        assert all(r[c] >= 0 and math.isfinite(r[c]) for c in always), key
        assert r["total_error"] ** 2 == pytest.approx(
            r["projection_error"] ** 2 + r["subspace_error"] ** 2, rel=1e-9), key
        undefined = r["twin_error"] > r["total_error"] * (1 + TWIN_RTOL)
        assert all(math.isnan(r[c]) for c in twin_based) == undefined, key
        if not undefined:
            assert all(r[c] >= 0 for c in twin_based), key
            assert r["subspace_error"] <= (r["diagonalization_error"] + r["linearization_error"]
                                           + r["residual_error"]) * (1 + 1e-12), key
            if math.isfinite(r["linear_diagonalization_error"]):
                assert r["subspace_error"] <= (r["own_linearization_error"]
                                               + r["linear_diagonalization_error"]
                                               + r["residual_error"]) * (1 + 1e-12), key
    for m in ("POVR", "MDS"):
        lti = rows[("lti_beam", m, "w3")]
        assert lti["linearization_error"] == 0.0 and lti["own_linearization_error"] == 0.0
        assert lti["linear_diagonalization_error"] == lti["diagonalization_error"]
    assert rows[("lti_beam", "MDS", "w3")]["diagonalization_error"] == 0.0
    nl_mds = rows[("nl_beam", "MDS", "w3")]
    assert nl_mds["linearization_error"] > 1e-3
    assert nl_mds["diagonalization_error"] == 0.0
    # a coupled method is its own twin: its own linearization error is the twin's
    assert nl_mds["own_linearization_error"] == pytest.approx(nl_mds["linearization_error"],
                                                              rel=1e-12)
    assert nl_mds["linear_diagonalization_error"] == 0.0
    assert rows[("nl_beam", "POVR", "w3")]["own_linearization_error"] > 1e-3


def test_an_attribution_against_a_failing_twin_is_undefined():
    """decompose: a twin whose own error exceeds the method's total attributes nothing."""
    from podbench.harness.metrics import decompose

    rng = np.random.default_rng(1)
    W = rng.standard_normal((6, 40))
    U = np.linalg.qr(rng.standard_normal((6, 6)))[0]  # k = m: projection error 0
    good, bad = W + 0.01 * rng.standard_normal(W.shape), W + rng.standard_normal(W.shape)
    ok = decompose(W, good, U, W_twin=W + 0.001 * rng.standard_normal(W.shape))
    assert math.isfinite(ok["diagonalization_error"]) and ok["linearization_error"] == 0.0
    out = decompose(W, good, U, W_twin=bad)
    assert out["twin_error"] > out["total_error"]
    assert all(math.isnan(out[c]) for c in ("diagonalization_error", "linearization_error",
                                            "residual_error", "linear_diagonalization_error"))
    assert out["own_linearization_error"] == 0.0  # linear: defined without any twin


@pytest.mark.usefixtures("pool_at_once")
def test_runs_are_deterministic_and_independent_of_jobs(write_scenario, tmp_path):
    a = write_scenario(CHAIN_FREE)
    b = write_scenario(CHAIN_FORCED, "chain_forced")
    t1 = summary_table(run_study([a, b], jobs=1))
    t1b = summary_table(run_study([a, b], jobs=1))
    # another stage's tasks in the same pool (as podbench run's noise seeds and nonlinearity
    # checks): the units' table unchanged, the tasks' results in task order
    side = [SideTasks("sums", math.fsum, [[0.1] * k for k in range(1, 7)])]
    t2 = summary_table(run_study([a, b], jobs=2, cache_dir=tmp_path / "cache",
                                 also=lambda: side))
    assert t1.to_csv() == t1b.to_csv()
    assert t1.to_csv() == t2.to_csv()
    assert side[0].results == [math.fsum([0.1] * k) for k in range(1, 7)]


def test_cache_hits_and_corrupt_entries_are_resimulated(write_scenario, tmp_path):
    p = write_scenario(CHAIN_FREE)
    cache = tmp_path / "cache"
    first = run_unit(p, "chain_coupled", cache)
    assert first.simulated == 6 and first.cached == 0
    second = run_unit(p, "chain_coupled", cache)
    assert second.simulated == 0 and second.cached == 6
    entries = sorted(cache.rglob("*.npz"))
    assert len(entries) == 6
    entries[0].write_bytes(b"not a zip file")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        third = run_unit(p, "chain_coupled", cache)
    assert third.simulated == 1
    assert any(issubclass(x.category, PodbenchWarning) and "unusable" in str(x.message)
               for x in w)
    assert [r["total_error"] for r in third.rows] == [r["total_error"] for r in first.rows]


def test_a_changed_structure_file_misses_the_cache(write_scenario, tmp_path):
    src = (tmp_path / "scenarios")
    p = write_scenario(CHAIN_FREE.replace('"chain_coupled"', '"my_chain.toml"'))
    from podbench.structures.files import find_structure

    text = find_structure("chain_coupled").read_text().replace('"chain_coupled"', '"my_chain"')
    (src / "my_chain.toml").write_text(text)
    cache = tmp_path / "cache"
    assert run_unit(p, "my_chain.toml", cache).simulated == 6
    assert run_unit(p, "my_chain.toml", cache).simulated == 0
    (src / "my_chain.toml").write_text(text.replace("mass_coupling = 0.25",
                                                    "mass_coupling = 0.2"))
    assert run_unit(p, "my_chain.toml", cache).simulated == 6


def test_a_failing_method_gets_a_row_with_its_reason(write_scenario):
    # MDS with a repeated training case: linearly dependent initial profiles
    p = write_scenario(CHAIN_FREE.replace('train = ["x1", "x2", "x3", "x4", "x5"]',
                                          'train = ["x1", "x2", "x3", "x4", "x4"]'))
    rows = _rows([run_unit(p, "chain_coupled")])
    mds = rows[("chain_coupled", "MDS", "x6")]
    assert mds["status"].startswith("failed: IllConditionedError")
    assert math.isnan(mds["total_error"])
    povr = rows[("chain_coupled", "POVR", "x6")]
    assert povr["status"].startswith("twin failed")
    assert np.isfinite(povr["total_error"]) and math.isnan(povr["diagonalization_error"])
