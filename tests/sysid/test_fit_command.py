"""``podbench fit``, ``podbench predict --model`` and ``pb.fit``/``pb.load_model``: the saved
model predicts exactly as a fresh fit, and its modes are the chain's, computed here
independently (scipy's eigensolver of M, C, K and the trapezoidal map of the test
integrator)."""

import csv
import json
import pickle

import numpy as np
import pandas as pd
import pytest
import scipy.linalg
import scipy.signal

import podbench as pb
from podbench.cli import main
from podbench.core.recordfiles import write_record
from podbench.core.records import Record
from podbench.errors import InputError

from ._cases import forced_case
from ._truth import newmark


def _truth(M, C, K, dt):
    """Frequencies (Hz) and damping ratios of the records' modes: eig of the first-order
    form, z = (1 + sΔt/2)/(1 − sΔt/2) (the trapezoidal rule), s' = ln z/Δt."""
    n = M.shape[0]
    Ac = np.block([[np.zeros((n, n)), np.eye(n)],
                   [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = scipy.linalg.eigvals(Ac)
    lam = lam[lam.imag > 0]
    s = np.log((1 + lam * dt / 2) / (1 - lam * dt / 2)) / dt
    order = np.argsort(np.abs(s))
    return np.abs(s[order]) / (2 * np.pi), -s[order].real / np.abs(s[order])


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """Four input/output files of the coupled 5-mass chain: a force at mass 3 (lbf), the
    displacements of all masses (in); the inputs minimum-phase decays (exact kernels)."""
    case = forced_case("coupled")
    folder = tmp_path_factory.mktemp("chain")
    paths = []
    for j, rate in enumerate((0.6, 0.5, 0.7, 0.55)):
        u = np.zeros((1, case.n))
        u[0, 1:] = 100.0 * (1 + j) * rate ** np.arange(case.n - 1)
        F = np.zeros((5, case.n))
        F[2] = u[0]
        W = newmark(case.M, case.C, case.K, case.dt, case.n, F=F)[0]
        p = folder / f"r{j}.npz"
        write_record(p, Record(u=u, y=W, dt=case.dt, input_units="lbf", output_units="in",
                               input_channels=("f3",),
                               output_channels=tuple(f"m{i}" for i in range(1, 6))),
                     layout="io")
        paths.append(str(p))
    return case, paths


def _assert_modes(table: pd.DataFrame, case, tol_pct: float):
    f, z = _truth(case.M, case.C, case.K, case.dt)
    assert list(table.columns[:3]) == ["mode", "frequency_hz", "damping_ratio"]
    assert list(table.columns[3:]) == [f"shape:m{i}" for i in range(1, 6)]
    assert len(table) == len(f)
    assert np.max(np.abs(table["frequency_hz"].to_numpy() / f - 1)) * 100 < tol_pct
    assert np.max(np.abs(table["damping_ratio"].to_numpy() / z - 1)) * 100 < 10 * tol_pct
    shapes = table.iloc[:, 3:].to_numpy()
    assert np.allclose(np.max(np.abs(shapes), axis=1), 1.0)


@pytest.mark.parametrize("method,options", [("ML", ["--solver", "block"]),
                                            ("ERA", ["--n-modes", "5"])])
def test_fit_writes_the_model_and_the_chains_modes(chain, tmp_path, method, options, capsys):
    case, paths = chain
    out = tmp_path / "fit"
    train = paths[:1] if method == "ML" else paths[:3]  # 'block': one input, one record
    assert main(["fit", "--method", method, "--train", *train, "--out", str(out),
                 *options]) == 0
    assert "5 physical modes" in capsys.readouterr().out
    table = pd.read_csv(out / "modes.csv")
    _assert_modes(table, case, 1e-3 if method == "ML" else 1e-2)  # 6 digits in the csv
    summary = json.loads((out / "model.json").read_text())
    assert summary["format_version"] == 1 and summary["method"] == method
    prov = summary["provenance"]
    assert [f["name"] for f in prov["training_files"]] == [p[-6:] for p in train]
    assert all(len(f["sha256"]) == 64 for f in prov["training_files"])
    assert prov["dt"] == case.dt and prov["output_units"] == "in"
    assert summary["modes_rule"] and summary["realization"]
    if method == "ERA":
        assert summary["parameters"]["order"] == 10  # --n-modes 5: five pole pairs


def test_predict_with_a_saved_model_is_the_fresh_prediction(chain, tmp_path):
    case, paths = chain
    fresh, saved = tmp_path / "fresh", tmp_path / "saved"
    common = ["--target", paths[3], "--coverage", "0.9"]
    assert main(["predict", "--method", "ML", "--train", *paths[:3], "--out", str(fresh),
                 "--solver", "ls", *common]) == 0
    assert main(["fit", "--method", "ML", "--train", *paths[:3], "--out",
                 str(tmp_path / "m"), "--solver", "ls"]) == 0
    assert main(["predict", "--model", str(tmp_path / "m" / "model.npz"), "--out", str(saved),
                 *common]) == 0
    with np.load(fresh / "r3.npz") as a, np.load(saved / "r3.npz") as b:
        for key in ("y_hat", "W_hat", "lower", "upper"):
            assert np.max(np.abs(a[key] - b[key])) <= 1e-12 * np.max(np.abs(a[key])), key
    ra = next(csv.DictReader(open(fresh / "errors.csv")))
    rb = next(csv.DictReader(open(saved / "errors.csv")))
    assert ra == rb
    config = json.loads((saved / "config.json").read_text())
    assert config["model"].endswith("model.npz") and config["train"] == ["r0.npz", "r1.npz",
                                                                         "r2.npz"]


def test_predict_model_refusals_in_one_line(chain, tmp_path, capsys):
    case, paths = chain
    assert main(["fit", "--method", "ML", "--train", paths[0], "--out",
                 str(tmp_path / "m"), "--solver", "block"]) == 0
    model = str(tmp_path / "m" / "model.npz")
    out = tmp_path / "out"
    capsys.readouterr()

    def refused(args, text):
        assert main(["predict", *args, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert text in err and err.count("\n") == 1, err
        assert not out.exists()

    refused(["--model", model, "--method", "ML", "--target", paths[3]], "--method")
    refused(["--model", model, "--train", paths[0], "--target", paths[3]], "--train")
    refused(["--target", paths[3]], "--model")
    pkl = tmp_path / "model.pkl"
    pkl.write_bytes(pickle.dumps({"a": 1}))
    refused(["--model", str(pkl), "--target", paths[3]], "model.pkl: refused: it is a pickle")
    not_model = tmp_path / "x.npz"
    np.savez(not_model, a=np.ones(3))
    refused(["--model", str(not_model), "--target", paths[3]], "x.npz: not a podbench model")
    header, arrays = pb.sysid.models.read_header(model)
    header["format_version"] = 99
    future = tmp_path / "future.npz"
    np.savez(future, __header__=np.array(json.dumps(header)), **arrays)
    refused(["--model", str(future), "--target", paths[3]], "future.npz: field `format_version`")
    other = tmp_path / "other.npz"
    write_record(other, Record(u=np.ones((1, 50)), y=np.ones((5, 50)), dt=0.001,
                               input_units="lbf", output_units="in", input_channels=("f3",),
                               output_channels=tuple(f"m{i}" for i in range(1, 6))),
                 layout="io")
    refused(["--model", model, "--target", str(other)], "other.npz: field `dt`")


def test_fit_refuses_an_option_the_method_lacks(chain, tmp_path, capsys):
    _, paths = chain
    assert main(["fit", "--method", "FIR-LS", "--train", *paths[:3], "--n-modes", "3",
                 "--out", str(tmp_path / "o")]) == 2
    assert "error: --n-modes: FIR-LS has none" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.heavy
def test_python_fit_save_load_modes_and_exports(chain, tmp_path):
    case, paths = chain
    recs = [pb.core.recordfiles.read_record(p) for p in paths]
    model = pb.fit("ML", recs[:1], inputs="measured", n_lags=None, solver="block")
    _assert_modes(model.modes(), case, 1e-4)
    ss = model.to_statespace()
    assert ss.order == 10 and ss.dt == case.dt
    y = model.predict(recs[3])
    _, y_d, _ = scipy.signal.dlsim(model.to_dlti(), recs[3].u.T)
    assert np.max(np.abs(y_d.T - y)) < 1e-8 * np.max(np.abs(y))
    path = model.save(tmp_path / "m.npz")
    back = pb.load_model(path)
    assert np.max(np.abs(back.predict(recs[3]) - y)) <= 1e-12 * np.max(np.abs(y))
    pd.testing.assert_frame_equal(back.modes(), model.modes())
    with pytest.raises(InputError, match="Parameter `out`"):
        pb.fit("ML", recs[:3], tmp_path / "x", inputs="measured")


def test_fir_ls_fits_from_the_command_line(chain, tmp_path, capsys):
    """FIR-LS fixes its inputs, solver and basis: the command line gives it only its own
    parameters (it was given ML's ``inputs``, an internal error)."""
    _, paths = chain
    assert main(["fit", "--method", "FIR-LS", "--train", *paths[:3], "--out",
                 str(tmp_path / "o")]) == 0
    summary = json.loads((tmp_path / "o" / "model.json").read_text())
    assert summary["method"] == "FIR-LS" and summary["chosen"]


def test_fit_names_the_configuration_it_was_asked_for(chain, tmp_path, capsys):
    """A registered configuration (ML-TC: ML with the TC prior) is named as asked, beside
    the method that fits it (the command printed "ML" alone)."""
    _, paths = chain
    assert main(["fit", "--method", "ML-TC", "--train", *paths[:3], "--out",
                 str(tmp_path / "o")]) == 0
    assert capsys.readouterr().out.startswith("ML-TC (ML): model -> ")
    summary = json.loads((tmp_path / "o" / "model.json").read_text())
    assert (summary["configuration"], summary["method"]) == ("ML-TC", "ML")
    assert summary["parameters"]["prior"] == "tc"


@pytest.mark.heavy
def test_fit_on_the_measured_example_lists_each_mode_once(tmp_path, capsys):
    """ML on scenarios/examples/measured (impact tests of the coupled chain, 1 % noise per
    channel, one file per format) with the pole-basis kernel holds each pole once per rank of
    its residue; modes.csv lists each mode once, shaped by its residue, against the chain's
    finite-element modes computed here (fe_modes at the records' Δt = 4 ms): the four modes
    below 30 Hz within 0.1 % in frequency and MAC ≥ 0.99 (each copy's own shape, before,
    had MACs down to 0.34)."""
    from pathlib import Path

    from podbench.core.modeshapes import mac
    from podbench.dynamics.modes import fe_modes

    data = Path(__file__).resolve().parents[2] / "scenarios" / "examples" / "measured" / "data"
    out = tmp_path / "ml"
    train = [str(data / f) for f in ("f1.npz", "f2.mat", "f3.csv", "f5.npz")]
    assert main(["fit", "--method", "ML", "--train", *train, "--out", str(out)]) == 0
    assert "4 physical modes" in capsys.readouterr().out
    table = pd.read_csv(out / "modes.csv")
    f = table["frequency_hz"].to_numpy()
    assert np.all(np.diff(f) / f[:-1] > 0.01)  # no mode twice
    truth = fe_modes(pb.load_structure("chain_coupled"), dt=0.004)
    near = np.array([int(np.argmin(np.abs(truth.frequency_hz - fi))) for fi in f])
    assert near.tolist() == [0, 1, 2, 3]
    assert np.max(np.abs(f / truth.frequency_hz[near] - 1)) < 1e-3
    shapes = table.iloc[:, 3:].to_numpy().T
    assert np.diag(mac(shapes, truth.shapes[:, near])).min() > 0.99
    notes = json.loads((out / "model.json").read_text())["modes_rule"]
    assert any("merged" in n for n in notes)


@pytest.mark.heavy
def test_fit_that_keeps_no_physical_mode_says_what_the_rule_left_out(tmp_path, capsys):
    """ML with the TC prior on three pushes at three different masses: leave-one-record-out
    cannot validate an input channel the other records never load (its error is about 1),
    the kernel is shrunk to nearly nothing and no realized mode passes the rule. The empty
    modes.csv comes with the rule's reasons, not a bare "0 physical modes"."""
    chain = pb.load_structure("chain_coupled")
    dt, n = 0.002, 400
    files = []
    for j in range(3):
        F = np.zeros((5, n))
        F[j, 1:40] = (10.0 + j) * np.sin(np.pi * np.arange(1, 40) / 40)
        files.append(str(tmp_path / f"push{j}.npz"))
        write_record(files[-1], pb.simulate(chain, n, dt, force=F))
    out = tmp_path / "fit"
    assert main(["fit", "--method", "ML-TC", "--train", *files, "--out", str(out)]) == 0
    summary = json.loads((out / "model.json").read_text())
    assert summary["fitted"]["cv_error"] > 0.9
    assert summary["modes_count"] == 0 and len(pd.read_csv(out / "modes.csv")) == 0
    printed = capsys.readouterr().out
    assert f"0 physical modes -> {out}/modes.csv (none kept: " in printed
    assert all(rule in printed for rule in summary["modes_rule"])
