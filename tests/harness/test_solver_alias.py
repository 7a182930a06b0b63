"""A former solver name (``"tls"``, now ``"tls-dt"``) keeps working wherever a user names a
solver — a scenario's ``options.solver``, ``sweep.solvers``, ``podbench sweep --solvers``,
``podbench methods NAME`` — through one alias table (``RENAMED``): it runs the new solver,
warns once per process with the new name, and the tables name what ran."""

import warnings

import pytest
from conftest import CHAIN_FORCED

from podbench import api
from podbench.errors import PodbenchWarning
from podbench.harness.runner import run_unit
from podbench.study.scenarios import load_scenario
from podbench.sysid import deconvolution as dc
from podbench.sysid.deconvolution import _api

pytestmark = pytest.mark.heavy  # fits and a small sweep: seconds


@pytest.fixture
def fresh_alias():
    """The once-per-process warning re-armed for the test (and left armed after it)."""
    _api._WARNED.clear()
    yield
    _api._WARNED.clear()


def _alias_warnings(caught) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, PodbenchWarning)
            and "is now named" in str(w.message)]


def _forced(solver: str) -> str:
    """CHAIN_FORCED (a template: braces doubled) with SL's solver named."""
    return CHAIN_FORCED.replace('train = ["f1"]\n',
                                f'train = ["f1"]\noptions = {{{{ solver = "{solver}" }}}}\n')


def test_current_name_is_the_one_alias_table(fresh_alias):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert dc.current_name("tls") == "tls-dt"
        assert dc.current_name("TLS") == "tls-dt"  # letter case of a former name aside
        assert dc.current_name("tls") == "tls-dt"
        for name in dc.available_solvers():
            assert dc.current_name(name) == name
        assert dc.current_name("nonsense") == "nonsense"  # unknown: left to the caller
    msgs = _alias_warnings(caught)
    assert len(msgs) == 1, msgs
    assert "'tls' is now named 'tls-dt'" in msgs[0]
    assert set(dc.RENAMED) == {"tls"} and all(new in dc.available_solvers()
                                              for new, _ in dc.RENAMED.values())


def test_a_scenario_naming_tls_fits_as_tls_dt_with_one_warning(write_scenario, fresh_alias):
    old = write_scenario(_forced("tls"), "chain_forced_old")
    new = write_scenario(_forced("tls-dt"), "chain_forced_new")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scenario(old)
        rows_old = {r["method"]: r for r in run_unit(old, "chain_coupled").rows}
    assert sc.method("SL").options["solver"] == "tls-dt"  # rewritten when the file is read
    assert len(_alias_warnings(caught)) == 1
    rows_new = {r["method"]: r for r in run_unit(new, "chain_coupled").rows}
    sl_old, sl_new = rows_old["SL"], rows_new["SL"]
    assert sl_old["total_error"] > 1e-3  # a real fit (SL on the coupled chain is not exact)
    assert sl_old["total_error"] == sl_new["total_error"]  # the same solver, bit for bit
    assert sl_old["projection_error"] == sl_new["projection_error"]


def test_sweep_solvers_tls_runs_and_names_tls_dt(write_scenario, tmp_path, fresh_alias):
    p = write_scenario(CHAIN_FORCED, "chain_forced")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        api.sweep(p, out=tmp_path / "sw", solvers=["tls", "ls"], noise=[0.0], jobs=1,
                  cache=tmp_path / "c")
    assert len(_alias_warnings(caught)) == 1
    text = (tmp_path / "sw" / "chain_forced" / "sweep.csv").read_text(encoding="utf-8")
    solvers = {line.split(",")[3] for line in text.splitlines()[1:]}
    assert solvers == {"tls-dt", "ls"}
    with pytest.raises(Exception, match="listed twice"):  # tls and tls-dt are one solver
        api.sweep(p, out=tmp_path / "sw2", solvers=["tls", "tls-dt"], noise=[0.0],
                  jobs=1, cache=tmp_path / "c")


def test_a_sweep_file_naming_tls_is_read_as_tls_dt(write_scenario, fresh_alias):
    text = CHAIN_FORCED + '\n[sweep]\nsolvers = ["tls", {{ solver = "tls", label = "mine" }}]\n'
    p = write_scenario(text, "chain_forced_sweep")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scenario(p)
    assert [(c.label, c.solver) for c in sc.sweep.solvers] == [("tls-dt", "tls-dt"),
                                                              ("mine", "tls-dt")]
    assert len(_alias_warnings(caught)) == 1


def test_worker_processes_do_not_warn_again(write_scenario, tmp_path, pool_at_once,
                                            fresh_alias, capfd):
    """The calling process reads every file (and warns) before any task; the spawned
    workers, which read the files again, take the former names as warned about."""
    from podbench.harness.runner import run_study

    paths = [write_scenario(_forced("tls"), f"chain_forced_{i}") for i in (1, 2)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for p in paths:
            load_scenario(p)
        res = run_study(paths, jobs=2, cache_dir=tmp_path / "cache")
    assert len(_alias_warnings(caught)) == 1
    assert {r["method"] for u in res for r in u.rows} == {"SL", "ML"}
    assert "is now named" not in capfd.readouterr().err
