"""A record too short for the model is one line naming the file, its length and what the
model needs, in ``podbench fit``, ``podbench predict`` and a scenario run on its own
record files; ``fit`` and ``predict`` share one definition of their fit arguments."""

from __future__ import annotations

import re

import numpy as np
import pytest

from podbench import api
from podbench.cli import _parser, main
from podbench.core.recordfiles import write_record
from podbench.core.records import Record
from podbench.errors import RecordTooShortError, ScenarioFileError
from podbench.sysid.methods.peers.era import ERA


def _records(folder, n: int, count: int = 3) -> list[str]:
    """``count`` input/output files of ``n`` samples (a force at one of 3 channels)."""
    rng = np.random.default_rng(0)
    paths = []
    for j in range(count):
        u = rng.standard_normal((1, n))
        y = np.cumsum(rng.standard_normal((3, n)), axis=1) * 1e-3
        p = folder / f"short{j}.npz"
        write_record(p, Record(u=u, y=y, dt=1e-3, input_units="lbf", output_units="in",
                               input_channels=("f",), output_channels=("a", "b", "c")),
                     layout="io")
        paths.append(str(p))
    return paths


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_era_names_its_lags_and_what_it_needs():
    # OKID's lags: ceil(max_order / k) = ceil(40 / 3) = 14 on 3 outputs; 16 samples at least
    rec = Record(u=np.ones((1, 10)), y=np.ones((3, 10)), dt=1e-3, input_units="lbf",
                 output_units="in")
    with pytest.raises(RecordTooShortError, match=r"10 samples is too short for OKID's 14 "
                                                  r"lags \(need at least 16\)") as info:
        ERA(inputs="measured").fit([rec, rec])
    assert (info.value.samples, info.value.needed) == (10, 16)


@pytest.mark.parametrize("command", ["fit", "predict"])
def test_fit_and_predict_name_the_short_file(tmp_path, capsys, command):
    *train, target = _records(tmp_path, 10, count=4)
    argv = [command, "--method", "ERA", "--train", *train, "--out", str(tmp_path / "out")]
    if command == "predict":
        argv += ["--target", target]
    assert main(argv) != 0
    err = _one_line_error(capsys)
    assert re.search(r"short\d\.npz: ERA: a record of 10 samples is too short for OKID's "
                     r"\d+ lags \(need at least \d+\)", err), err
    assert not (tmp_path / "out").exists()


def test_a_scenario_on_short_record_files_stops_with_the_files(tmp_path):
    folder = tmp_path / "mine"
    (folder / "data").mkdir(parents=True)
    files = _records(folder / "data", 10, count=4)
    cases = "".join(f'[cases.r{j}]\nfile = "data/short{j}.npz"\n' for j in range(4))
    (folder / "mine.toml").write_text(
        '[scenario]\nname = "mine"\ntitle = "t"\nstructures = ["measured"]\nn_samples = 10\n'
        f'dt = 1e-3\ntargets = ["r3"]\n\n{cases}\n[[methods]]\nlabel = "ERA"\n'
        'method = "ERA"\ntrain = ["r0", "r1", "r2"]\noptions = { inputs = "measured" }\n',
        encoding="utf-8")
    assert len(files) == 4
    with pytest.raises(ScenarioFileError, match=r"mine\.toml: method `ERA`: its training "
                       r"files \(data/short0\.npz, data/short1\.npz, data/short2\.npz\) too "
                       r"short: .*10 samples .*need at least"):
        api.run(folder, out=tmp_path / "out", jobs=1, cache=None, figures=False)


def test_fit_and_predict_share_their_fit_arguments():
    sub = next(a for a in _parser()._actions if a.dest == "command").choices
    fit = {a.dest: a for a in sub["fit"]._actions}
    pred = {a.dest: a for a in sub["predict"]._actions}
    shared = ("method", "train", "solver", "n_modes", "units", "input_units", "output_units",
              "debug")
    for d in shared:
        assert fit[d].help == pred[d].help and fit[d].default == pred[d].default, d
    assert fit["method"].required and not pred["method"].required  # predict: or --model


@pytest.mark.parametrize("command", ["fit", "predict"])
def test_training_files_of_different_lengths_are_named(tmp_path, capsys, command):
    # MDS stacks its records' snapshots: every training file needs the first one's shape,
    # and the error names the file that differs and the one it differs from
    rng = np.random.default_rng(0)
    paths = []
    for j, n in enumerate((400, 300, 400)):
        p = tmp_path / f"free{j}.npz"
        np.savez(p, W=np.cumsum(rng.standard_normal((3, n)), axis=1) * 1e-3,
                 F=rng.standard_normal((3, n)), dt=1e-3)
        paths.append(str(p))
    argv = [command, "--method", "MDS", "--train", paths[0], paths[1],
            "--out", str(tmp_path / "out")]
    if command == "predict":
        argv += ["--target", paths[2]]
    assert main(argv) != 0
    err = _one_line_error(capsys)
    said = r"\S*free1\.npz: field `W`: shape \(3, 300\) differs from free0\.npz's `W` \(3, 400\)"
    assert re.search(said, err), err
    assert "records[" not in err
    assert not (tmp_path / "out").exists()
