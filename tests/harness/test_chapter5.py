"""The Chapter 5 virtual experiment: generator round trip and determinism, the noise it adds,
one-line errors, claims over several scenarios, and the study from one command."""

import io
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from podbench.core.recordfiles import read_record
from podbench.core.resources import bundled_scenarios
from podbench.errors import ScenarioFileError
from podbench.study.claims import evaluate_claims, load_claims, load_claims_file
from podbench.study.experiments import (
    check_experiment,
    generate,
    level_folder,
    load_experiment,
    write_experiment,
)
from podbench.study.scenarios import find_scenarios, load_scenario

CH5 = bundled_scenarios() / "chapter5"
ROOT = Path(__file__).resolve().parents[2]

SMALL = """\
[experiment]
name = "small"
noise_levels = [0.0, 0.01]
noise_seed = 3
precision = "{precision}"

[tests.beam]
structure = "aluminium_beam"
n_samples = 200
dt = 1.0e-4
[tests.beam.cases.a.force]
kind = "pulse"
location = 8.0
amplitude = 2.0
duration = 5.0e-4
hits = [[2.0e-3, 0.4]]
[tests.beam.cases.b]
force = {{ kind = "pulse", location = 12.0, amplitude = 1.0, duration = 5.0e-4 }}
"""


def _small(tmp_path, precision="float64", text=SMALL):
    (tmp_path / "experiment.toml").write_text(text.format(precision=precision))
    return tmp_path


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_round_trip_and_determinism(tmp_path, precision):
    folder = _small(tmp_path, precision)
    files = write_experiment(folder)
    assert len(files) == 4
    exp = load_experiment(folder)
    records = generate(exp)
    for (test, lv, case), rec in records.items():
        back = read_record(folder / "data" / test / lv / f"{case}.npz")
        np.testing.assert_allclose(back.W, rec.W, rtol=0, atol=1e-12 * np.abs(rec.W).max())
        np.testing.assert_allclose(back.F, rec.F, rtol=0, atol=1e-12 * np.abs(rec.F).max())
        assert back.dt == 1e-4 and list(back.sensor_positions) == [0, 4, 8, 12, 16, 20]
        if precision == "float32":  # stored exactly what the generator returned
            assert np.array_equal(back.W, rec.W)
    first = {f: f.read_bytes() for f in files}
    assert check_experiment(folder) == []
    write_experiment(folder)  # regeneration: byte-identical files
    assert {f: f.read_bytes() for f in files} == first
    (folder / "data" / "beam" / "noise_1pct" / "a.npz").write_bytes(b"x")
    (folder / "data" / "beam" / "noise_1pct" / "extra.npz").write_bytes(b"x")
    assert check_experiment(folder) == [str(Path("data/beam/noise_1pct/a.npz")),
                                        str(Path("data/beam/noise_1pct/extra.npz"))]


def test_an_experiment_record_from_another_cpu_is_kept(tmp_path):
    """``podbench experiment`` keeps a committed record that ``--check`` calls the same
    (W moved by a fraction of a float32 step) and rewrites one that moved further."""
    folder = _small(tmp_path, "float32")
    files = write_experiment(folder)
    rec = files[0]
    with np.load(rec, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    W = arrays["W"].copy()
    i = np.unravel_index(np.argmax(np.abs(W)), W.shape)
    for steps, kept in [(1, True), (100, False)]:
        arrays["W"] = W.copy()
        arrays["W"][i] = np.float32(W[i]) * np.float32(1 + steps * 2.0**-23)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        rec.write_bytes(buf.getvalue())
        other = rec.read_bytes()
        assert (check_experiment(folder) == []) is kept
        write_experiment(folder)
        assert (rec.read_bytes() == other) is kept


def test_noise_is_per_measured_channel(tmp_path):
    exp = load_experiment(_small(tmp_path))
    rec = generate(exp)
    clean, noisy = rec[("beam", "noise_0pct", "a")], rec[("beam", "noise_1pct", "a")]
    dW, dF = noisy.W - clean.W, noisy.F - clean.F
    rms = np.sqrt(np.mean(clean.W**2, axis=1))
    assert np.all(dW[0] == 0) and np.all(clean.W[0] == 0)  # the clamp: no signal, no noise
    ratio = dW[1:].std(axis=1) / rms[1:]
    assert np.all((ratio > 0.008) & (ratio < 0.012)), ratio  # 1 % of each channel's RMS
    loaded = np.flatnonzero(np.abs(clean.F).max(axis=1) > 0)
    assert list(loaded) == [2]  # the load cell at 8 in
    assert np.all(dF[np.arange(6) != 2] == 0) and dF[2].std() > 0
    assert level_folder(0.005) == "noise_0.5pct" and level_folder(0.05) == "noise_5pct"


def test_bundled_records_are_what_the_experiment_generates():
    assert check_experiment(CH5) == []
    exp = load_experiment(CH5)
    assert exp.noise_levels == (0.0, 0.001, 0.01, 0.02, 0.05)
    W = read_record(CH5 / "data/linear_beam/noise_0pct/load8.npz").W
    assert W.shape == (6, 1024)
    s = np.linalg.svd(W, compute_uv=False)
    energy = np.cumsum(s**2) / np.sum(s**2)
    # §5.1 "the first two POMs ... corresponding to 90%": here POM 1 alone carries 88.6 %
    assert energy[0] == pytest.approx(0.8863, abs=5e-4) and energy[1] > 0.998


@pytest.mark.parametrize("edit, field", [
    (("noise_levels = [0.0, 0.01]", "noise_levels = [0.0, 1.5]"), "experiment.noise_levels[1]"),
    (("noise_levels = [0.0, 0.01]", "noise_levels = [0.01, 0.01]"), "experiment.noise_levels"),
    (('precision = "{precision}"', 'precision = "half"'), "experiment.precision"),
    (('structure = "aluminium_beam"', 'structure = "nope"'), "tests.beam"),
    (("location = 8.0", "location = 6.0"), "tests.beam.cases.a.force"),
    (("n_samples = 200", "n_samples = 1"), "tests.beam.n_samples"),
    (('kind = "pulse", location = 12.0', 'kind = "static_displacement", location = 12.0'),
     "tests.beam.cases.b.force.kind"),
    (("[tests.beam]", "[tests.beam]\nnoise_on = 1"), "tests.beam.noise_on"),
])
def test_bad_experiment_fields_give_one_line(tmp_path, edit, field):
    text = SMALL.replace(*edit)
    folder = _small(tmp_path, text=text)
    with pytest.raises(ScenarioFileError) as ei:
        write_experiment(folder)
    msg = str(ei.value)
    assert "\n" not in msg and "experiment.toml" in msg and field in msg, msg
    assert not (folder / "data").exists()  # refused before anything was written


def test_missing_experiment_file(tmp_path):
    with pytest.raises(ScenarioFileError, match="no such experiment file"):
        load_experiment(tmp_path)


def test_experiment_file_is_not_a_scenario():
    names = [p.name for p in find_scenarios([CH5])]
    assert "experiment.toml" not in names and "claims.toml" not in names
    assert "linear_beam_noise_0pct.toml" in names
    sc = load_scenario(CH5 / "linear_beam_noise_2pct.toml")
    assert sc.cases["load8"].file == "data/linear_beam/noise_2pct/load8.npz"
    assert sc.cases["load4_clean"].file == "data/linear_beam/noise_0pct/load4.npz"


TABLE = pd.DataFrame([
    {"scenario": s, "structure": "b", "method": m, "target": "t", "total_error": e}
    for s, m, e in [("clean", "A", 0.20), ("clean", "B", 0.30), ("n1", "A", 0.21),
                    ("n1", "B", 0.25), ("n5", "A", 0.40), ("n5", "B", 0.35)]])


def test_claims_over_scenarios_and_cross_scenario_operands(tmp_path):
    p = tmp_path / "claims.toml"
    p.write_text('''
[[claims]]
id = "x"
source = "s"
quote = "q"
scenario = ["n1", "n5"]
structure = "b"
target = "t"
checks = ["A.total_error <= 1.1*clean:A.total_error", "A.total_error < B.total_error"]
''')
    claims, _ = load_claims(p)
    assert claims[0].all_scenarios() == ("n1", "n5")
    e = evaluate_claims(claims, TABLE)[0]
    # n1: 0.21 <= 0.22 and 0.21 < 0.25; n5: 0.40 > 0.22
    assert e.by_scenario == {"n1": "reproduced", "n5": "not reproduced"}
    assert e.verdict == "not reproduced"
    assert "1.1*clean:A.total_error = 0.22" in e.details[0].shown
    only = evaluate_claims(claims, TABLE, scenarios={"n1"})[0]
    assert only.verdict == "reproduced" and list(only.by_scenario) == ["n1"]
    p.write_text(p.read_text().replace("clean:A", "nowhere:A"))
    e = evaluate_claims(load_claims(p)[0], TABLE)[0]
    assert e.verdict == "not reproduced"  # n5 fails its second check; n1 unmeasurable
    assert e.by_scenario["n1"] == "not measured"


def test_bundled_chapter5_claims_quote_the_seed():
    seed = Path("/work/shared/seed/allison2007_pod_system_identification.txt")
    if not seed.is_file():
        pytest.skip("seed text not available")
    text = " ".join(seed.read_text(encoding="utf-8").split())
    f = load_claims_file(CH5 / "claims.toml")
    claims = f.claims
    names = {p.stem for p in find_scenarios([CH5])} | {f.nonlinearity.name}
    for c in claims:
        assert " ".join(c.quote.split()) in text, c.id
        assert set(c.all_scenarios()) <= names, c.id


@pytest.mark.slow
def test_study_runs_from_one_command(tmp_path):
    """`podbench run` on a copy of the undamped scenario (3 fits, ~10-30 s): the rows, and
    ML's error against an independent fit on the same record files."""
    study = tmp_path / "ch5"
    shutil.copytree(CH5, study)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "podbench", "run", "-q", "--no-figures",
                        "--no-cache", "-o", str(out), str(study / "linear_beam_undamped.toml")],
                       capture_output=True, text=True, cwd=tmp_path,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    df = pd.read_csv(out / "summary.csv")
    assert sorted(df.method.unique()) == ["ML-ls", "SL-ls"]
    # independent: ML with the dense least squares on the same records
    from podbench.sysid.methods import MultipleLoad

    d = study / "data/linear_beam_undamped/noise_0pct"
    recs = [read_record(d / f"{c}.npz") for c in ("load8", "load12", "load4")]
    ml = MultipleLoad(n_modes=2, solver="ls").fit(recs[:2])
    e = np.linalg.norm(ml.predict(recs[2]) - recs[2].W) / np.linalg.norm(recs[2].W)
    row = df[(df.method == "ML-ls") & (df.target == "load4")].iloc[0]
    assert row.total_error == pytest.approx(e, rel=1e-5)


def test_a_measured_case_is_described_as_its_file():
    from podbench.report.figures import describe_case

    sc = load_scenario(CH5 / "linear_beam_noise_1pct.toml")
    assert describe_case(sc.cases["load8"], dt=1e-4, t_end=0.1) == (
        "measured record data/linear_beam/noise_1pct/load8.npz")
    assert describe_case(sc.cases["load4_clean"], dt=1e-4, t_end=0.1).startswith("the clean")


# ----------------------------------------------------------------------------------------
# §5.2: the rubber-band beam
# ----------------------------------------------------------------------------------------


def test_rubber_band_records_and_the_decomposition_scenario_share_the_loads():
    """The simulated decomposition scenario runs exactly the experiment's clean loads, and
    the clean record is the noise-free simulation of the structure (independent run)."""
    from podbench.dynamics import simulate
    from podbench.dynamics.excitations import Pulse
    from podbench.structures.files import load_structure

    test = load_experiment(CH5).tests["rubber_band_beam"]
    sc = load_scenario(CH5 / "rubber_band_beam_decomposition.toml")
    assert set(test.cases) == {"load4", "load12", "load16"} == set(sc.cases)
    for name, force in test.cases.items():
        assert tuple(sc.cases[name].force) == tuple(force), name
    for p in (0, 1, 2, 5):
        noisy = load_scenario(CH5 / f"rubber_band_beam_noise_{p}pct.toml")
        assert noisy.structures == ("rubber_band_beam",) or list(noisy.structures) == [
            "rubber_band_beam"]
        assert noisy.cases["load4"].file.endswith(f"noise_{p}pct/load4.npz")
    # hits spread over up to 6 ms ("sometime for as long as 6 ms after the initial impact")
    last = max(h[0] for f in test.cases.values() for h in f[0]["hits"])
    assert 5.0e-3 <= last <= 6.0e-3
    rec = read_record(CH5 / "data/rubber_band_beam/noise_0pct/load4.npz")
    assert rec.W.shape == (6, 1024)
    f = test.cases["load4"][0]
    pulse = Pulse(f["location"], f["amplitude"], f["duration"], shape=f["shape"],
                  hits=[tuple(h) for h in f["hits"]])
    W = simulate(load_structure("rubber_band_beam"), n_samples=1024, dt=1e-4, force=pulse,
                 dof_histories=False).W
    assert np.linalg.norm(rec.W - W) / np.linalg.norm(W) < 1e-6  # float32 records
