"""Sweeps: the [sweep] table, the noise model, the mode-count and solver axes, and identical
tables whether the points run serially, in local processes or on a Dask cluster."""
# ruff: noqa: E501  (TOML scenario text)

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import CHAIN_FORCED

from podbench import cli
from podbench.core.resources import bundled_scenarios
from podbench.core.response import Response
from podbench.errors import InputError, ScenarioFileError
from podbench.harness.metrics import roundoff_errors
from podbench.harness.runner import NoiseSpec, noisy, run_unit
from podbench.harness.sweep import SWEEP_COLUMNS, plan_sweep, run_sweep
from podbench.harness.tables import table_csv
from podbench.report.sweep import sweep_markdown
from podbench.study.scenarios import apply_overrides, load_scenario

pytestmark = pytest.mark.heavy  # seconds per test: not in the fast tier (README)

ROOT = Path(__file__).resolve().parents[2]
NUMERIC = ["n_modes", "total_error", "projection_error", "diagonalization_error",
           "linearization_error", "residual_error", "subspace_error", "norm_pe_median",
           "norm_pe_p90", "norm_pe_max", "norm_peak_ratio"]

# Two methods of one's own: `Clean` predicts the target's own displacements (so its error is
# zero exactly when the harness hands it the noise-free target), `Echo` returns its first
# training record (so its error against the clean truth of that case is the training noise).
ECHO = '''
import numpy as np

class Clean:
    def __init__(self, *, n_modes=None):
        self.n_modes = n_modes
    def fit(self, records, *, basis=None):
        return self
    def predict(self, record):
        return np.array(record.W)

class Echo:
    def __init__(self, *, n_modes=None):
        self.n_modes = n_modes
    def fit(self, records, *, basis=None):
        self.W_ = np.array(records[0].W)
        return self
    def predict(self, record):
        return self.W_
'''


def sweep_file(write_scenario, table: str, name: str = "chain_sweep", template=CHAIN_FORCED):
    table = textwrap.dedent(table).replace("{", "{{").replace("}", "}}")  # template braces
    return write_scenario(template + "\n[sweep]\n" + table, name)


# ----------------------------------------------------------------------- the [sweep] table
def test_sweep_table_is_read_with_defaults(write_scenario):
    sc = load_scenario(sweep_file(write_scenario, """
        noise = [0, 0.01]
        n_modes = [3, 5]
        seeds = [4, 2]
        solvers = ["ls", { solver = "tls-dt", options = { rcond = 1e-2 }, label = "tls-1e-2" }]
        """))
    sw = sc.sweep
    assert sw.noise == (0.0, 0.01) and sw.n_modes == (3, 5) and sw.seeds == (4, 2)
    assert [(c.label, c.solver, c.options) for c in sw.solvers] == [
        ("ls", "ls", {}), ("tls-1e-2", "tls-dt", {"rcond": 1e-2})]
    assert sw.noise_on == ("W", "F") and sw.coupled_train == "first"
    empty = load_scenario(sweep_file(write_scenario, "", "chain_empty"))
    assert empty.sweep.noise == (0.0,) and empty.sweep.seeds == (0,)
    assert empty.sweep.n_modes is None and empty.sweep.solvers is None
    assert load_scenario(write_scenario(CHAIN_FORCED, "plain")).sweep is None


@pytest.mark.parametrize("table, field", [
    ("nois = [0.1]", "sweep.nois"),
    ("noise = [0.0, -0.1]", "sweep.noise[1]"),
    ("noise = [0.1, 0.1]", "sweep.noise"),
    ("seeds = [1, 1]", "sweep.seeds"),
    ("seeds = [-1]", "sweep.seeds[0]"),
    ("n_modes = [0]", "sweep.n_modes[0]"),
    ('solvers = ["ls", "magic"]', "sweep.solvers[1]"),
    ('solvers = [{ solver = "tls-dt", rcond = 1e-2 }]', "sweep.solvers[0].rcond"),
    ('noise_on = ["W", "X"]', "sweep.noise_on[1]"),
    ('coupled_train = "some"', "sweep.coupled_train"),
])
def test_malformed_sweep_tables_name_the_file_and_field(write_scenario, table, field):
    p = sweep_file(write_scenario, table)
    with pytest.raises(ScenarioFileError) as info:
        load_scenario(p)
    assert f"field `{field}`" in str(info.value) and "chain_sweep.toml" in str(info.value)


def test_example_sweep_file_loads_and_plans():
    path = bundled_scenarios() / "sweeps" / "beam_forced_noise.toml"
    sc = load_scenario(path)
    assert [c.solver for c in sc.sweep.solvers] == ["ls", "tls-dt", "cgls", "fft", "realization",
                                                    "subspace", "stls", "auto"]
    _, tasks = plan_sweep([path])
    n_levels, n_seeds = len(sc.sweep.noise), len(sc.sweep.seeds)
    assert len(tasks) == len(sc.structures) * n_levels * n_seeds


# ----------------------------------------------------------------------- noise model
def _response(rng, m=40, n=2500):
    W = rng.standard_normal((m, n)) * np.linspace(1.0, 3.0, m)[:, None]
    F = np.zeros((m, n))
    F[3, 5:9] = 500.0
    return Response(t=np.arange(n) * 1e-4, W=W, F=F, w0=W[:, 0].copy(),
                    v0=np.ones(m), dt=1e-4)


def test_noise_is_relative_gaussian_seeded_and_scales_with_the_level():
    """The former model (per_entry_rms), kept as a named option; the per-channel default is
    tested in tests/sysid/test_noise.py."""
    r = _response(np.random.default_rng(7))
    rms_w = np.sqrt(np.mean(r.W ** 2))
    old = "per_entry_rms"
    a = noisy(r, NoiseSpec(0.02, seed=3, model=old), "sc", "beam", "load1")
    dW = a.W - r.W
    # standard deviation level × RMS(W), mean zero (100,000 draws: 0.2 % sampling error)
    assert np.std(dW) / rms_w == pytest.approx(0.02, rel=0.01)
    assert abs(np.mean(dW)) < 3 * 0.02 * rms_w / np.sqrt(dW.size)
    rms_f = np.sqrt(np.mean(r.F ** 2))
    assert np.std(a.F - r.F) / rms_f == pytest.approx(0.02, rel=0.01)
    # initial profiles untouched by default; added on request
    assert np.array_equal(a.w0, r.w0) and np.array_equal(a.v0, r.v0)
    b = noisy(r, NoiseSpec(0.02, seed=3, on=("v0",), model=old), "sc", "beam", "load1")
    assert np.array_equal(b.W, r.W) and not np.array_equal(b.v0, r.v0)
    # deterministic; the same pattern at every level (common random numbers)
    again = noisy(r, NoiseSpec(0.02, seed=3, model=old), "sc", "beam", "load1")
    assert np.array_equal(again.W, a.W)
    double = noisy(r, NoiseSpec(0.04, seed=3, model=old), "sc", "beam", "load1")
    np.testing.assert_allclose(double.W - r.W, 2 * dW, rtol=1e-12, atol=1e-14)
    # another seed or another case: independent draws
    for other in (noisy(r, NoiseSpec(0.02, seed=4, model=old), "sc", "beam", "load1"),
                  noisy(r, NoiseSpec(0.02, seed=3, model=old), "sc", "beam", "load2")):
        corr = np.corrcoef((other.W - r.W).ravel(), dW.ravel())[0, 1]
        assert abs(corr) < 0.02
    assert noisy(r, NoiseSpec(0.0, seed=3), "sc", "beam", "load1") is r
    zero = Response(t=r.t, W=r.W, F=np.zeros_like(r.W), w0=r.w0, v0=r.v0, dt=r.dt)
    assert not noisy(zero, NoiseSpec(0.1), "sc", "beam", "x").F.any()


def test_noise_reaches_the_training_data_and_never_the_targets(write_scenario):
    # SL and ML ride along with the dense "ls" stated: the default "auto" would run its noise
    # test and the robust solver on every noisy fit, minutes here, for nothing this test checks
    base = CHAIN_FORCED.replace('targets = ["f6"]', 'targets = ["f1", "f6"]')
    for name in ("SL", "ML"):
        base = base.replace(f'method = "{name}"\n', f'method = "{name}"\noptions = {{{{ solver = "ls" }}}}\n')
    p = write_scenario(base + """
[[methods]]
label = "clean"
method = "echo.py:Clean"
train = ["f1"]

[[methods]]
label = "echo"
method = "echo.py:Echo"
train = ["f1"]
""", "chain_echo")
    (p.parent / "echo.py").write_text(ECHO, encoding="utf-8")
    level = 0.01
    rows = {(r["method"], r["target"]): r
            for r in run_unit(p, "chain_coupled", noise=NoiseSpec(level, seed=1)).rows}
    for t in ("f1", "f6"):
        assert rows[("clean", t)]["total_error"] == 0.0  # the target handed over is clean
    # Echo returns noisy training record f1: its error against clean f1 is the noise,
    # ‖level·RMS·Z‖/‖W‖ = level·‖Z‖/√(mn), i.e. level within the sampling error (m·n = 600)
    assert rows[("echo", "f1")]["total_error"] == pytest.approx(level, rel=0.1)
    clean = {(r["method"], r["target"]): r for r in run_unit(p, "chain_coupled").rows}
    assert clean[("echo", "f1")]["total_error"] == 0.0


# ----------------------------------------------------------------------- what a sweep computes
def test_noise_free_points_equal_podbench_run_for_every_seed(write_scenario):
    p = sweep_file(write_scenario, "noise = [0.0]\nseeds = [0, 5]")
    _, df = run_sweep([p])
    assert list(df.columns) == list(SWEEP_COLUMNS)
    # as summary.csv writes them: round-off errors as 0
    ref = roundoff_errors(pd.DataFrame(run_unit(p, "chain_coupled").rows))
    assert list(df.seed) == [0, 0, 5, 5]
    for seed in (0, 5):
        sub = df[df.seed == seed].reset_index(drop=True)
        assert list(sub.method) == list(ref.method) == ["SL", "ML"]
        assert list(sub.solver) == ["auto", "auto"]  # the methods' own (default) solver
        np.testing.assert_array_equal(sub[NUMERIC].to_numpy(float), ref[NUMERIC].to_numpy(float))


@pytest.mark.slow  # a sweep over noise levels and seeds: about 30 s on two cores
def test_ml_error_is_first_order_in_the_noise_level(write_scenario):
    """ML on the coupled chain (k = m = 5) is exact without noise; least squares is smooth
    in its data, so with the same noise pattern scaled by ε the error is c·ε + O(ε²): doubling
    a small level doubles the error."""
    p = sweep_file(write_scenario, "noise = [0.0, 1e-5, 2e-5]\nseeds = [0, 1]")
    _, df = run_sweep([p])
    ml = df[df.method == "ML"].set_index(["noise", "seed"])["total_error"]
    assert ml[(0.0, 0)] < 1e-12
    for seed in (0, 1):
        assert 1e-7 < ml[(1e-5, seed)] < 1e-4
        assert ml[(2e-5, seed)] / ml[(1e-5, seed)] == pytest.approx(2.0, rel=0.01)
    assert ml[(1e-5, 0)] != ml[(1e-5, 1)]  # seeds are different realizations


def test_mode_axis_and_coupled_training_sets(write_scenario):
    p = sweep_file(write_scenario, "n_modes = [3, 5]")
    scenarios, df = run_sweep([p])
    got = df.set_index(["method", "modes"])
    assert got.loc[("SL", 3), "n_modes"] == 3 and got.loc[("SL", 5), "n_modes"] == 5
    # "first": ML with k = 3 is ML trained on the first three loads, exactly
    first3 = write_scenario(CHAIN_FORCED.replace('train = ["f1", "f2", "f3", "f4", "f5"]',
                                                 'train = ["f1", "f2", "f3"]'), "ml3")
    ref = {r["method"]: r for r in run_unit(first3, "chain_coupled").rows}["ML"]
    assert got.loc[("ML", 3), "n_modes"] == 3
    assert got.loc[("ML", 3), "total_error"] == ref["total_error"]
    assert (df.status == "ok").all()
    md = sweep_markdown(df, scenarios["chain_sweep"])
    assert "| chain_coupled | ML | f6 | 5 | auto | " in md
    # "all": least squares over the five loads with three modes, a different fit
    q = sweep_file(write_scenario, 'n_modes = [3]\ncoupled_train = "all"', "chain_all")
    _, df_all = run_sweep([q])
    ml_all = df_all[df_all.method == "ML"].iloc[0]
    assert ml_all["n_modes"] == 3 and ml_all["total_error"] != ref["total_error"]


@pytest.mark.parametrize(("table", "axes", "message"), [
    # k = 6 > the chain's 5 sensors: no POD method can have six POMs
    ("n_modes = [3, 6]", {}, "sweep axis `sweep.n_modes` = 6 on chain_coupled: 6 modes, but "
     "SL's POMs number at most 5 (5 sensors)"),
    ("", {"n_modes": [40]}, "sweep axis `--n-modes` = 40 on chain_coupled: 40 modes"),
    # ML trained on three loads cannot identify a 4 x 4 matrix, "first" or "all"
    ('n_modes = [4]\ncoupled_train = "all"', {}, "4 modes, but ML's POMs number at most 3 "
     "(3 training cases"),
])
def test_a_mode_count_no_method_can_use_is_refused_before_any_work(
        write_scenario, monkeypatch, table, axes, message):
    import podbench.harness.sweep as sweep_module
    monkeypatch.setattr(sweep_module, "run_unit", None)  # nothing may be fitted
    base = CHAIN_FORCED.replace('train = ["f1", "f2", "f3", "f4", "f5"]', 'train = ["f1", "f2", "f3"]')
    p = sweep_file(write_scenario, table, template=base)
    with pytest.raises(ScenarioFileError, match="chain_sweep.toml: ") as exc:
        run_sweep([p], **axes)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_cli_sweep_point_that_measured_nothing_exits_2_with_the_count(write_scenario, tmp_path,
                                                                      capsys):
    """A fit failing at run time is a row; a point none of whose rows was measured is an
    error (exit 2, counted), after the tables are written for inspection."""
    p = write_scenario(CHAIN_FORCED.split("[[methods]]")[0] + """
[[methods]]
label = "picky"
method = "picky.py:Picky"
train = ["f1"]

[[methods]]
label = "clean"
method = "picky.py:Picky"
train = ["f1"]
options = {{ limit = 3 }}
[sweep]
n_modes = [2, 3, 4]
""", "chain_picky")
    (p.parent / "picky.py").write_text("""
import numpy as np

class Picky:
    def __init__(self, *, n_modes=None, limit=2):
        self.n_modes, self.limit = n_modes, limit
    def fit(self, records, *, basis=None):
        if self.n_modes > self.limit:
            raise ValueError(f"{self.n_modes} modes is more than {self.limit}")
        return self
    def predict(self, record):
        return np.array(record.W)
""", encoding="utf-8")
    out = tmp_path / "res"
    assert cli.main(["sweep", str(p), "-o", str(out), "-q", "--no-cache"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("podbench sweep: error: 1 of 3 sweep points measured nothing") and "\n" not in err
    assert "k 4, seed 0: picky: failed" in err
    df = pd.read_csv(out / "chain_picky" / "sweep.csv")
    status = df.set_index(["method", "modes"])["status"]
    assert status[("picky", 2)] == "ok" and status[("clean", 3)] == "ok"
    assert status[("picky", 3)].startswith("failed")  # one row of a measured point: kept, exit 0
    assert "1 row has a failed method" not in captured.out  # three rows failed, the note counts them
    assert "3 rows have a failed method or twin" in captured.out


def test_solver_axis_expands_deconvolving_methods_and_their_twins():
    mixed = load_scenario(bundled_scenarios() / "chapter4" / "beam_mixed.toml")
    from podbench.study.scenarios import SolverChoice

    sc = apply_overrides(mixed, solvers=[SolverChoice("ls", "ls"),
                                         SolverChoice("t2", "tls-dt", {"rcond": 1e-2})])
    mr = sc.method("MR [t2]")
    assert mr.options["solver"] == "tls-dt" and mr.options["solver_options"] == {"rcond": 1e-2}
    assert mr.twin == "MDS+MDS+ML [t2]" and (mr.base_label, mr.solver_label) == ("MR", "t2")
    sup = sc.method("MDS+MDS+ML [t2]")
    assert sup.parts == ("MDS (w0)", "MDS (v0)", "ML (F) [t2]")
    assert "solver" not in sc.method("MDS (w0)").options  # nothing to deconvolve: kept once
    assert [m.label for m in sc.reported_methods()] == ["MR [ls]", "MR [t2]"]


def test_each_solver_is_compared_with_a_twin_using_the_same_solver(write_scenario):
    """SL's basis is the five POMs of f1, as ML's: the twin (ML in SL's basis) is the reported
    ML, so SL's residual error equals ML's subspace error, solver by solver."""
    p = sweep_file(write_scenario, 'solvers = ["ls", "tls-dt"]')
    _, df = run_sweep([p])
    got = df.set_index(["method", "solver"])
    for s in ("ls", "tls-dt"):
        assert got.loc[("SL", s), "residual_error"] == pytest.approx(
            got.loc[("ML", s), "subspace_error"], rel=1e-9, abs=1e-13)
    # the two solvers differ visibly on ML (truncated TLS drops directions)
    assert got.loc[("ML", "ls"), "total_error"] < 1e-12 < got.loc[("ML", "tls-dt"), "total_error"]


# ----------------------------------------------------------------------- execution
SMALL = """
noise = [0.0, 0.02]
seeds = [0, 1]
solvers = ["ls", "tls-dt"]
"""


@pytest.mark.usefixtures("pool_at_once")
def test_serial_and_local_parallel_sweeps_are_identical(write_scenario, tmp_path):
    p = sweep_file(write_scenario, SMALL)
    _, serial = run_sweep([p])
    _, parallel = run_sweep([p], jobs=2, cache_dir=tmp_path / "cache")
    assert serial.attrs["tasks"] == 3  # the noise-free point once, then once per seed
    assert len(serial) == 2 * 2 * 2 * 1 * 2  # noise × seeds × methods × targets × solvers
    # the tables as written are identical: a number's last bits can depend on the process
    # that computed it (diagonalization_error 0.043685 differed in its last bits between the
    # calling process and a worker when the test ran after others), far below the six
    # digits written; an exact fit's round-off errors (1e-16..1e-14, whose leading digits
    # differ too) are written as 0
    assert table_csv(serial) == table_csv(parallel)


def test_dask_local_cluster_gives_the_same_table(write_scenario):
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    # a user's solver class, named in the file, is imported where the scenario is read
    p = sweep_file(write_scenario, SMALL.replace(
        'solvers = ["ls", "tls-dt"]',
        'solvers = ["ls", "tls-dt", {solver = "plain.py:Plain", label = "plain"}]'))
    (p.parent / "plain.py").write_text(
        "import numpy as np\n"
        "from podbench.deconvolution import DenseSolver\n\n"
        "class Plain(DenseSolver):\n"
        "    name = 'plain'\n"
        "    def _solve_matrix(self, A, B):\n"
        "        return np.linalg.lstsq(A, B, rcond=None)[0]\n")
    _, serial = run_sweep([p])
    assert set(serial["solver"]) >= {"ls", "tls-dt", "plain"}
    mine = serial[(serial.solver == "plain") & (serial.noise == 0)]
    assert (mine.status == "ok").all() and len(mine) > 0
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp",
                      host="127.0.0.1", dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        _, dask = run_sweep([p], scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(serial, dask, check_exact=True)


def test_unreachable_scheduler_is_an_input_error(write_scenario):
    p = sweep_file(write_scenario, SMALL)
    with pytest.raises(InputError, match="Dask"):
        run_sweep([p], scheduler="nonsense://nowhere")


# ----------------------------------------------------------------------- command line
def test_cli_sweep_writes_csv_and_markdown_identically_twice(write_scenario, tmp_path, capsys):
    p = sweep_file(write_scenario, "noise = [0.0]")
    out = tmp_path / "res"
    args = ["sweep", str(p), "-o", str(out), "-q", "--no-cache", "--noise", "0,0.01",
            "--seeds", "0-1", "--solvers", "ls,tls-dt"]
    assert cli.main(args) == 0
    csv, md = out / "chain_sweep" / "sweep.csv", out / "chain_sweep" / "sweep.md"
    df = pd.read_csv(csv, keep_default_na=False)
    assert list(df.columns) == list(SWEEP_COLUMNS)
    assert len(df) == 2 * 2 * 2 * 2 and set(df.noise) == {0.0, 0.01}
    assert set(df.solver) == {"ls", "tls-dt"} and (df.status == "ok").all()
    text = md.read_text(encoding="utf-8")
    assert "| chain_coupled | ML | f6 | 5 | tls-dt |" in text and "noise 0.01" in text
    first = csv.read_bytes(), md.read_bytes()
    assert cli.main(args) == 0
    assert (csv.read_bytes(), md.read_bytes()) == first


@pytest.mark.parametrize("extra", [
    ["--noise", "0,abc"], ["--noise", "-0.1"], ["--seeds", "3-1"], ["--n-modes", "0"],
    ["--solvers", "ls,magic"], ["--jobs", "0"], ["--jobs", "2", "--scheduler", "tcp://x:1"],
    ["--scheduler", "nonsense://nowhere"],
])
def test_cli_sweep_bad_input_exits_2_with_one_line(write_scenario, tmp_path, capsys, extra):
    p = sweep_file(write_scenario, "noise = [0.0]")
    assert cli.main(["sweep", str(p), "-o", str(tmp_path / "res"), "-q", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("podbench sweep: error:") and "\n" not in err
    assert not (tmp_path / "res").exists()


def test_cli_sweep_defaults_to_jobs_auto(write_scenario, tmp_path, capsys, monkeypatch):
    """``podbench sweep`` without ``--jobs`` hands the executor ``auto`` resolved: the cores
    this process may run on (three, faked here, so the default is neither 1 nor 2)."""
    from podbench.harness import executor, sweep

    monkeypatch.setattr(executor.os, "sched_getaffinity", lambda pid: {0, 1, 2},
                        raising=False)
    seen = []

    def recording(*args, **kwargs):
        seen.append(kwargs["jobs"])
        return executor.execute(*args, **kwargs)

    monkeypatch.setattr(sweep, "execute", recording)
    assert cli._parser().parse_args(["sweep"]).jobs is None  # not given: auto or --scheduler
    p = sweep_file(write_scenario, "noise = [0.0]")
    assert cli.main(["sweep", str(p), "-o", str(tmp_path / "res"), "-q", "--no-cache"]) == 0
    assert seen == [3]
    assert " on 3 processes at most " in capsys.readouterr().out
    seen.clear()
    assert cli.main(["sweep", str(p), "-o", str(tmp_path / "res"), "-q", "--no-cache",
                     "--jobs", "1"]) == 0
    assert seen == [1]
    assert " on 1 process " in capsys.readouterr().out


@pytest.mark.parametrize("jobs", ["1", "2", "auto"])
def test_explicit_jobs_with_a_scheduler_is_refused_naming_both(write_scenario, tmp_path,
                                                                capsys, jobs):
    """An explicit ``--jobs`` (even 1 or auto) with ``--scheduler`` is a contradiction: one
    line naming both options, before any work; the default ``--jobs`` is no conflict (the
    scheduler's own address is then what fails, unreachable here)."""
    p = sweep_file(write_scenario, "noise = [0.0]")
    base = ["sweep", str(p), "-o", str(tmp_path / "res"), "-q"]
    assert cli.main([*base, "--jobs", jobs, "--scheduler", "tcp://x:1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"podbench sweep: error: --jobs {jobs} and --scheduler tcp://x:1: give one "
                   "(the Dask cluster sets the parallelism)")
    assert cli.main([*base, "--scheduler", "nonsense://nowhere"]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot connect to the Dask scheduler 'nonsense://nowhere'" in err
    assert "--jobs" not in err and "\n" not in err
    assert not (tmp_path / "res").exists()


@pytest.mark.usefixtures("pool_at_once")
def test_cli_sweep_files_identical_with_jobs_1_2_and_the_default(write_scenario, tmp_path):
    """sweep.csv and sweep.md byte-identical whether the points run in this process alone
    (``--jobs 1``), in two (workers spawned at once here) or with the default ``auto``."""
    p = sweep_file(write_scenario, SMALL)
    got = []
    for extra in (["--jobs", "1"], ["--jobs", "2"], []):
        out = tmp_path / f"res{len(got)}"
        assert cli.main(["sweep", str(p), "-o", str(out), "-q", "--cache",
                         str(tmp_path / "cache"), *extra]) == 0
        got.append(tuple((out / "chain_sweep" / f).read_bytes()
                         for f in ("sweep.csv", "sweep.md")))
    assert got[0][0].count(b"\n") == 1 + 2 * 2 * 2 * 2  # header, noise × seeds × methods × solvers
    assert got[0] == got[1] == got[2]


def test_cli_sweep_missing_path_exits_2(tmp_path, capsys):
    assert cli.main(["sweep", str(tmp_path / "nothing.toml"), "-q"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_sweep_noise_model_snr_and_force_disturbances_are_read(write_scenario):
    sc = load_scenario(sweep_file(write_scenario, """
        snr_db = [40, 20]
        noise_model = "per_entry_rms"
        force_offset = 0.01
        force_drift = -0.02
    """))
    assert sc.sweep.noise == pytest.approx((0.01, 0.1), rel=1e-14)
    assert sc.sweep.noise_model == "per_entry_rms"
    assert (sc.sweep.force_offset, sc.sweep.force_drift) == (0.01, -0.02)
    assert load_scenario(sweep_file(write_scenario, "seeds = [0]", "d")).sweep.noise_model == (
        "per_channel")
    with pytest.raises(ScenarioFileError, match="not both"):
        load_scenario(sweep_file(write_scenario, "snr_db = [40]\nnoise = [0.01]", "both"))
    with pytest.raises(ScenarioFileError, match="noise_model"):
        load_scenario(sweep_file(write_scenario, 'noise_model = "white"', "bad"))
