"""podbench predict and the Painter Street study (bundled records)."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import podbench as pb
from podbench.cli import main
from podbench.core.recordfiles import write_record
from podbench.core.records import Record
from podbench.dynamics.excitations import Pulse
from podbench.harness.painter_street import data_folder, load_events
from podbench.sysid.methods import FIRLeastSquares, MultipleLoad, SingleLoad


def measured_ml(**kw):
    """ML on measured inputs with the lag rule (the former ``MultipleLoadIO``'s defaults)."""
    return MultipleLoad(**{"inputs": "measured", "n_lags": "auto", "solver": "ls", **kw})


SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "painter_street"


def _sys_records(tmp_path, lengths, seed=0, units="m/s^2"):
    h = 0.01 * np.exp(-np.arange(30) / 6.0)[None, None, :] * \
        np.random.default_rng(99).normal(size=(2, 2, 1))  # one system for every record
    rng = np.random.default_rng(seed)
    paths = []
    for j, n in enumerate(lengths):
        u = rng.normal(size=(2, n))
        y = np.stack([sum(np.convolve(u[i], h[o, i])[:n] for i in range(2)) for o in range(2)])
        p = tmp_path / f"rec{seed}_{j}.npz"
        write_record(p, Record(u=u, y=y, dt=0.01, input_units=units, output_units=units,
                               input_channels=("g1", "g2"), output_channels=("d1", "d2")),
                     layout="io")
        paths.append(str(p))
    return paths


def test_predict_writes_errors_and_predictions(tmp_path, capsys):
    train = _sys_records(tmp_path, [300, 400, 350])
    target = _sys_records(tmp_path, [500], seed=1)
    out = tmp_path / "out"
    assert main(["predict", "--method", "ML", "--train", *train, "--target", *target,
                 "--out", str(out), "--solver", "ls"]) == 0
    rows = list(csv.DictReader(open(out / "errors.csv")))
    assert [r["target"] for r in rows] == ["rec1_0"] and rows[0]["method"] == "ML"
    assert float(rows[0]["total_error"]) < 1e-10  # an exact 30-lag FIR, 0.25 s ≥ 30 lags
    with np.load(out / "rec1_0.npz", allow_pickle=False) as z:
        assert z["y_hat"].shape == (2, 500) and str(z["units"]) == "m/s^2"
        assert "W_hat" not in z.files and str(z["quantity"]) == "acceleration"
    assert rows[0]["error:d1"] and rows[0]["error:d2"]
    config = json.loads((out / "config.json").read_text())
    assert config["method"] == "ML" and config["parameters"]["inputs"] == "measured"
    assert config["parameters"]["prior"] is None and config["fitted"]["n_lags"] >= 25


def test_a_channel_measured_zero_throughout_gets_an_empty_error_said_in_help_and_stdout(
        tmp_path, capsys):
    train = _sys_records(tmp_path, [300, 400, 350])
    target = _sys_records(tmp_path, [500], seed=1)[0]
    with np.load(target, allow_pickle=False) as z:
        fields = {k: z[k] for k in z.files}
    fields["outputs"] = fields["outputs"].copy()
    fields["outputs"][1] = 0.0  # channel d2 measured 0 throughout
    quiet = tmp_path / "quiet.npz"
    np.savez(quiet, **fields)
    out = tmp_path / "out"
    assert main(["predict", "--method", "ML", "--train", *train, "--target", str(quiet),
                 "--out", str(out), "--solver", "ls"]) == 0
    row = next(csv.DictReader(open(out / "errors.csv")))
    with np.load(out / "quiet.npz", allow_pickle=False) as z:
        y_hat = z["y_hat"]
    y = fields["outputs"]
    # d1: the relative error of its own channel; d2: undefined (‖y‖ = 0), left empty
    assert float(row["error:d1"]) == pytest.approx(
        np.linalg.norm(y_hat[0] - y[0]) / np.linalg.norm(y[0]), rel=1e-5)
    assert row["error:d2"] == ""
    assert float(row["total_error"]) == pytest.approx(
        np.linalg.norm(y_hat - y) / np.linalg.norm(y), rel=1e-5)
    printed = capsys.readouterr().out
    assert "note: quiet: 1 output channel measured zero throughout (d2): error:<channel> " \
           "left empty" in printed
    with pytest.raises(SystemExit):
        main(["predict", "--help"])
    helptext = " ".join(capsys.readouterr().out.split())
    assert "left empty for a channel whose measured output is zero throughout" in helptext


def test_records_the_model_cannot_use_name_their_file(tmp_path, capsys):
    """A training record at rest is refused before any fit; a target longer than the kernel
    a 3-sample record gave is refused naming the target; a target at rest has no relative
    error, and the line says why."""
    chain = pb.load_structure("chain_coupled")
    F = np.zeros((5, 400))
    F[0, 1:40] = 10.0 * np.sin(np.pi * np.arange(1, 40) / 40)
    push = pb.simulate(chain, 400, 0.002, force=F)
    files = {}
    for name, W, Fn in (("push", push.W, push.F), ("rest", 0 * push.W, push.F),
                        ("short", push.W[:, :3], push.F[:, :3])):
        files[name] = str(tmp_path / f"{name}.npz")
        write_record(files[name], Record(W=W, F=Fn, dt=0.002))

    def err(*argv):
        assert main(list(argv)) == 2
        text = capsys.readouterr().err.strip()
        assert "\n" not in text
        return text

    assert err("fit", "--method", "SL", "--train", files["rest"], "--out", str(tmp_path / "a")) \
        == "podbench fit: error: rest.npz: field `outputs`: zero throughout (a " \
           "training record needs a measured response to identify from)"
    assert err("predict", "--method", "SL", "--train", files["short"], "--target", files["push"],
               "--out", str(tmp_path / "b")).startswith(
        f"podbench predict: error: {files['push']}: Parameter `F_new`: 400 samples, "
        "expected n' <= 3")
    assert main(["predict", "--method", "SL", "--train", files["push"], "--target",
                 files["rest"], "--out", str(tmp_path / "c")]) == 0
    assert "rest: SL total_error (none: the target holds no outputs, or they are zero " \
           "throughout)" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["fit", "predict"])
def test_an_unknown_unit_option_is_refused_even_for_files_that_carry_theirs(tmp_path, capsys,
                                                                           command):
    train = _sys_records(tmp_path, [300, 400])  # they state m/s^2
    extra = ["--target", train[0]] if command == "predict" else []
    assert main([command, "--method", "ML", "--train", *train, *extra, "--out",
                 str(tmp_path / "out"), "--output-units", "furlong"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"podbench {command}: error: --output-units: unknown unit 'furlong' (known: N, lbf, m, "
        "in, m/s, in/s, m/s^2, in/s^2, strain, V)")
    assert not (tmp_path / "out").exists()


def test_predict_refuses_bad_records_before_writing(tmp_path, capsys):
    train = _sys_records(tmp_path, [300, 400])
    bad = tmp_path / "bad.npz"
    write_record(bad, Record(u=np.ones((2, 300)), y=np.ones((2, 300)), dt=0.02,
                             input_units="m/s^2", output_units="m/s^2",
                             input_channels=("g1", "g2"), output_channels=("d1", "d2")),
                 layout="io")
    out = tmp_path / "out"
    assert main(["predict", "--method", "ML", "--train", *train, "--target", str(bad),
                 "--out", str(out)]) == 2
    assert "bad.npz: field `dt`: 0.02 s differs" in capsys.readouterr().err
    assert not out.exists()
    nan = tmp_path / "nan.npz"
    np.savez(nan, inputs=np.full((2, 300), np.nan), outputs=np.ones((2, 300)), dt=0.01,
             input_units="m/s^2", output_units="m/s^2")
    assert main(["predict", "--method", "ML", "--train", *train, "--target", str(nan),
                 "--out", str(out)]) == 2
    assert "nan.npz: field `inputs`: NaN or Inf at index (0, 0)" in capsys.readouterr().err
    assert main(["predict", "--method", "ML", "--train", *train, "--target", train[0],
                 "--out", str(out), "--coverage", "0.9"]) == 2
    assert "--coverage: the band is calibrated by leave-one-record-out over the training " \
        "records" in capsys.readouterr().err  # two training records: too few for its folds
    assert not out.exists()


def test_predict_si_and_inch_lbf_files_give_the_same_prediction(tmp_path):
    si = _sys_records(tmp_path, [300, 400, 350, 500])
    d = tmp_path / "ip"
    d.mkdir()
    ip = []
    for p in si:
        with np.load(p) as z:
            q = d / Path(p).name
            write_record(q, Record(u=z["inputs"] / 0.0254, y=z["outputs"] / 0.0254,
                                   dt=0.01, input_units="in/s^2", output_units="in/s^2",
                                   input_channels=("g1", "g2"), output_channels=("d1", "d2")),
                         layout="io")
            ip.append(str(q))
    for files, out in ((si, "a"), (ip, "b")):
        assert main(["predict", "--method", "ML", "--train", *files[:3], "--target",
                     files[3], "--out", str(tmp_path / out), "--units", "SI"]) == 0
    a = np.load(tmp_path / "a" / "rec0_3.npz")["y_hat"]
    b = np.load(tmp_path / "b" / "rec0_3.npz")["y_hat"]
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12 * np.abs(a).max())


def test_bundled_records_are_the_shared_samples():
    recs = load_events()
    assert len(recs) == 14 and recs[0].units == "SI"
    assert recs[0].input_channels == ("3", "17", "20")
    assert recs[0].output_channels == ("7", "9", "4")
    assert (data_folder() / "LICENSE.md").read_text().startswith("BSD 2-Clause License")
    assert "CESMD" in (data_folder() / "README.md").read_text()
    if SHARED.is_dir():
        with np.load(SHARED / f"{recs[3].name}.npz", allow_pickle=False) as z:
            np.testing.assert_array_equal(recs[3].u, z["inputs"].astype(float))
            np.testing.assert_array_equal(recs[3].y, z["outputs"].astype(float))
    g = load_events(inputs="ground")
    assert g[0].input_channels == ("1", "2", "3", "15", "16", "17", "18", "19", "20")
    np.testing.assert_array_equal(g[5].u[2], recs[5].u[0])  # channel 3 in both


@pytest.mark.heavy
def test_the_fir_baseline_reproduces_the_issue_number():
    """Leave-one-event-out, three inputs, 1-s lags: the issue measured 0.399."""
    from podbench.core.threads import single_blas_thread

    recs = load_events()
    errs = []
    with single_blas_thread():
        for j, t in enumerate(recs):
            tr = recs[:j] + recs[j + 1:]
            yh = FIRLeastSquares(n_lags=100).fit(tr).predict(t)
            errs.append(np.linalg.norm(yh - t.y) / np.linalg.norm(t.y))
            if j < 3:
                ym = measured_ml(n_lags=100).fit(tr).predict(t)
                np.testing.assert_allclose(ym, yh, rtol=1e-7, atol=1e-10 * np.abs(yh).max())
    assert np.mean(errs) == pytest.approx(0.3988, abs=5e-4)


@pytest.mark.slow
def test_run_painter_street_writes_the_study(tmp_path):
    out = tmp_path / "ps"
    assert main(["run", "painter_street", "-o", str(out), "-q"]) == 0
    rows = {(r["inputs"], r["method"]): r for r in csv.DictReader(open(out / "summary.csv"))}
    fir, tc = float(rows[("three", "FIR-LS")]["mean_error"]), \
        float(rows[("three", "ML-TC")]["mean_error"])
    assert tc <= fir
    assert rows[("three", "SL")]["status"] == "refused"
    assert (out / "figures" / "deck_acceleration.png").is_file()


@pytest.fixture(scope="module")
def wf_files(tmp_path_factory):
    """Displacement/force files (W in in, F in lbf) of the LTI beam: four training pulses
    and one held-out target, with the simulated records themselves."""
    folder = tmp_path_factory.mktemp("wf")
    s = pb.load_structure("lti_beam")
    recs, paths = [], []
    for i, x in enumerate((2.0, 8.0, 14.0, 20.0, 11.0)):
        r = pb.simulate(s, n_samples=400, dt=1e-4, force=Pulse(x, 500.0, 5e-4))
        paths.append(str(write_record(folder / f"wf{i}.npz", r)))
        recs.append(r)
    return paths, recs


def test_predict_on_displacement_force_files_runs_the_dissertations_ml(wf_files, tmp_path):
    """On W/F files --method ML is MultipleLoad (Eqs. 3.46-3.49) fitted on the same records,
    not the input/output kernel of every force channel (which needs 2500 samples there)."""
    paths, recs = wf_files
    ref = MultipleLoad(n_modes=4, solver="block").fit(recs[:4]).predict(recs[4])
    truth_err = np.linalg.norm(ref - recs[4].W) / np.linalg.norm(recs[4].W)
    for units, factor, unit in ((None, 1.0, "in"), ("SI", 0.0254, "m")):
        out = tmp_path / f"out{units}"
        argv = ["predict", "--method", "ML", "--n-modes", "4", "--solver", "block",
                "--train", *paths[:4], "--target", paths[4], "--out", str(out)]
        assert main(argv + (["--units", units] if units else [])) == 0
        row = next(csv.DictReader(open(out / "errors.csv")))
        assert row["units"] == unit
        assert float(row["total_error"]) == pytest.approx(truth_err, rel=1e-5)
        with np.load(out / "wf4.npz", allow_pickle=False) as z:
            assert str(z["units"]) == unit
            np.testing.assert_allclose(z["W_hat"], factor * ref, rtol=0,
                                       atol=1e-12 * np.abs(ref).max())


@pytest.mark.heavy
def test_predict_sl_on_a_displacement_force_file_and_its_band(wf_files, tmp_path, capsys):
    paths, recs = wf_files
    out = tmp_path / "sl"
    assert main(["predict", "--method", "SL", "--train", *paths[:2], "--target", paths[4],
                 "--out", str(out)]) == 2
    assert "--train: SL identifies from exactly 1 training file(s), got 2" in \
        capsys.readouterr().err
    assert not out.exists()
    assert main(["predict", "--method", "SL", "--n-modes", "4", "--train", paths[0],
                 "--target", paths[4], "--out", str(out), "--coverage", "0.9"]) == 0
    ref = SingleLoad(n_modes=4).fit(recs[0]).predict(recs[4])
    row = next(csv.DictReader(open(out / "errors.csv")))
    assert float(row["error_estimate"]) > 0 and 0 <= float(row["coverage"]) <= 1
    with np.load(out / "wf4.npz", allow_pickle=False) as z:
        np.testing.assert_allclose(z["W_hat"], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
        assert np.all(z["lower"] <= z["W_hat"]) and np.all(z["W_hat"] <= z["upper"])


@pytest.fixture(scope="module")
def free_files(tmp_path_factory):
    """Free responses of the coupled chain (files holding W in in, dt, w0: no F): three
    training decays from independent initial displacements and a held-out one."""
    folder = tmp_path_factory.mktemp("free")
    s = pb.load_structure("chain_coupled")
    rng = np.random.default_rng(5)
    paths, recs = [], []
    for i in range(4):
        w0 = rng.normal(size=s.n_dofs) * 1e-2
        r = pb.simulate(s, n_samples=300, dt=2e-3, initial_displacement=w0)
        p = folder / f"free{i}.npz"
        np.savez(p, W=r.W, dt=r.dt, w0=r.w0)
        paths.append(str(p))
        recs.append(pb.Record(W=r.W, w0=r.w0, dt=r.dt))
    return paths, recs


@pytest.mark.parametrize("method, n_train", [("MDS", 3), ("POVR", 1), ("mds", 3)])
def test_predict_mds_and_povr_on_free_response_files_with_bands(free_files, tmp_path,
                                                                 capsys, method, n_train):
    """--method MDS / POVR on files holding W, dt, w0 (no F): the prediction equals the
    class's own on the same records, and --coverage gives a band and an error estimate."""
    from podbench.sysid.methods import MDS, POVR

    paths, recs = free_files
    cls = MDS if method.upper() == "MDS" else POVR
    ref = cls(n_modes=3).fit(recs[:n_train] if n_train > 1 else recs[0]).predict(recs[3])
    out = tmp_path / method
    assert main(["predict", "--method", method, "--n-modes", "3", "--train",
                 *paths[:n_train], "--target", paths[3], "--out", str(out),
                 "--coverage", "0.9"]) == 0
    row = next(csv.DictReader(open(out / "errors.csv")))
    assert row["method"] == method.upper()
    err = np.linalg.norm(ref - recs[3].W) / np.linalg.norm(recs[3].W)
    assert float(row["total_error"]) == pytest.approx(err, rel=1e-5)
    assert float(row["error_estimate"]) > 0 and 0 <= float(row["coverage"]) <= 1
    with np.load(out / "free3.npz", allow_pickle=False) as z:
        np.testing.assert_allclose(z["W_hat"], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
        np.testing.assert_array_equal(z["y_hat"], z["W_hat"])
        assert np.all(z["lower"] <= z["W_hat"]) and np.all(z["W_hat"] <= z["upper"])
        assert str(z["quantity"]) == "displacement"


def test_predict_warns_when_a_target_is_a_training_file(free_files, tmp_path, capsys):
    paths, _ = free_files
    out = tmp_path / "same"
    assert main(["predict", "--method", "MDS", "--train", *paths[:3], "--target",
                 paths[0], "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "warning: target" in err and "is also a training file" in err


def test_predict_names_an_unknown_method_and_refuses_an_option_it_lacks(free_files,
                                                                         tmp_path, capsys):
    paths, _ = free_files
    out = tmp_path / "x"
    assert main(["predict", "--method", "MSD", "--train", *paths[:3], "--target", paths[3],
                 "--out", str(out)]) == 2
    assert "did you mean 'MDS'?" in capsys.readouterr().err
    assert main(["predict", "--method", "MDS", "--solver", "block", "--train", *paths[:3],
                 "--target", paths[3], "--out", str(out)]) == 2
    assert "--solver: MDS takes no deconvolution solver" in capsys.readouterr().err
    assert not out.exists()
