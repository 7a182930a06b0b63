"""One contract for every method of a scenario: options bound to the constructor when the file
is read (one line, exit 2, nothing simulated), a user's method class gets exactly a built-in's
columns (twins included), a user's solver class works in worker processes."""

import textwrap

import numpy as np
import pandas as pd
import pytest
from conftest import CHAIN_FORCED

from podbench import cli
from podbench.errors import ScenarioFileError
from podbench.harness.runner import run_study
from podbench.study.scenarios import load_scenario

# A user's method that is SL by delegation (so its rows must equal SL's to the last digit),
# and a user's solver that is plain least squares by SciPy (so it must equal "ls").
USER_CODE = '''
import numpy as np
import scipy.linalg

from podbench.deconvolution import DenseSolver
from podbench.methods import SingleLoad


class MySL:
    """A method of one's own: the contract is fit(records, *, basis=None) -> self,
    predict(record) -> (m, n), modes_; nothing else is required."""

    def __init__(self, *, n_modes=None, solver="auto"):  # SL's own default
        self.n_modes = n_modes
        self.solver = solver

    def fit(self, records, *, basis=None):
        self.inner_ = SingleLoad(n_modes=self.n_modes, solver=self.solver).fit(records,
                                                                                basis=basis)
        self.modes_ = self.inner_.modes_
        return self

    def predict(self, record):
        return self.inner_.predict(record)


class SciPyLS(DenseSolver):
    """Minimum-norm least squares by scipy.linalg.lstsq (gelsd); DenseSolver's constructor
    (its one option, max_dense_bytes) is inherited."""

    name = "scipy-ls"

    def _solve_matrix(self, A, B):
        return scipy.linalg.lstsq(A, B, lapack_driver="gelsd")[0]
'''


@pytest.fixture
def chain(write_scenario, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios").mkdir(exist_ok=True)
    (tmp_path / "scenarios" / "mine.py").write_text(textwrap.dedent(USER_CODE))

    def write(extra_methods: str = "", replace: tuple = ()):
        text = CHAIN_FORCED
        for old, new in replace:  # the template doubles TOML's braces
            assert old in text
            text = text.replace(old, new.replace("{", "{{").replace("}", "}}"))
        extra = textwrap.dedent(extra_methods).replace("{", "{{").replace("}", "}}")
        return write_scenario(text + extra, "chain_forced")

    return write


def _run_cli(path, tmp_path, capsys, *extra):
    cache = tmp_path / "cache"
    code = cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--cache", str(cache),
                     "-q", "--no-figures", *extra])
    err = capsys.readouterr().err
    simulated = sorted(p.name for p in cache.rglob("*") if p.is_file()) if cache.exists() else []
    return code, err, simulated


@pytest.mark.parametrize("replace, field, needle", [
    (('method = "ML"\n', 'method = "ML"\noptions = { solverr = "ls" }\n'),
     "methods[1].options.solverr",
     "not an option of MultipleLoad; did you mean 'solver'? (its options: n_modes, solver"),
    (('method = "SL"\n', 'method = "SL"\noptions = { energy = 2.0 }\n'),
     "methods[0].options.energy", "expected a number in (0, 1], got 2.0"),
    (('method = "ML"\n', 'method = "ML"\noptions = { solver = "wiener" }\n'),
     "methods[1].options.solver", "unknown solver 'wiener'"),
    (('method = "ML"\n', 'method = "ML"\noptions = { solver = "tsl" }\n'),
     "methods[1].options.solver", "unknown solver 'tsl'"),
    (('method = "ML"\n',
      'method = "ML"\noptions = { solver = "cgls", solver_options = { regg = 1 } }\n'),
     "methods[1].options.solver_options", "unknown option 'regg'"),
    (('method = "ML"\n',
      'method = "ML"\noptions = { solver = "tls-dt", solver_options = { rcond = -1 } }\n'),
     "methods[1].options.solver_options.rcond", "expected a number in (0, 1), got -1"),
    (('method = "SL"\n', 'method = "missing.py:Nope"\n'),
     "methods[0].method", "no such file"),
    (('method = "SL"\n', 'method = "mine.py:Nope"\n'),
     "methods[0].method", 'has no "Nope"'),
    (('method = "SL"\n', 'method = "SLL"\n'),
     "methods[0].method", 'unknown method "SLL"; did you mean \'SL\'?'),
    (('n_modes = 5\n', 'n_modes = 0\n'), "methods[0].n_modes", "expected an integer >= 1"),
])
def test_bad_method_entries_fail_at_load_on_one_line(chain, tmp_path, capsys, replace, field,
                                                     needle):
    p = chain(replace=(replace,))
    with pytest.raises(ScenarioFileError, match="chain_forced.toml: field"):
        load_scenario(p)
    code, err, simulated = _run_cli(p, tmp_path, capsys)
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"field `{field}`" in err and needle in err, err
    assert simulated == []  # checked before any simulation


def test_a_user_method_gets_the_columns_of_a_built_in_twins_included(chain, tmp_path):
    p = chain("""
        [[methods]]
        label = "MySL"
        method = "mine.py:MySL"
        n_modes = 5
        train = ["f1"]
        twin = "ML"
        """)
    df = pd.DataFrame([r for u in run_study([p]) for r in u.rows]).set_index("method")
    sl, mine = df.loc["SL"], df.loc["MySL"]
    cols = [c for c in df.columns if c.endswith("_error") or c.startswith("norm_")]
    assert np.isfinite(sl["diagonalization_error"]) and sl["diagonalization_error"] > 1e-3
    for c in cols + ["n_modes", "status"]:
        assert mine[c] == sl[c], c


@pytest.mark.usefixtures("pool_at_once")
def test_a_user_solver_class_works_in_worker_processes(chain, tmp_path):
    p = chain("""
        [[methods]]
        label = "ML scipy"
        method = "ML"
        train = ["f1", "f2", "f3", "f4", "f5"]
        options = { solver = "mine.py:SciPyLS" }
        """)
    # a second unit (another structure) so that --jobs 2 really uses two processes
    text = p.read_text().replace('structures = ["chain_coupled"]',
                                 'structures = ["chain_coupled", "chain_ideal"]')
    p.write_text(text)
    serial = [r for u in run_study([p], jobs=1) for r in u.rows]
    parallel = [r for u in run_study([p], jobs=2) for r in u.rows]
    assert pd.DataFrame(serial).equals(pd.DataFrame(parallel))
    df = pd.DataFrame(serial).set_index(["structure", "method"])
    for s in ("chain_coupled", "chain_ideal"):
        mine, ls = df.loc[(s, "ML scipy")], df.loc[(s, "ML")]
        assert mine["status"] == "ok"
        # gelsd and podbench's "ls" driver agree to round-off; ML is exact here (k = m)
        assert mine["total_error"] < 1e-9 and ls["total_error"] < 1e-9
