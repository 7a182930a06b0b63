"""The note of a cross-validated estimate whose target's load lies beyond every training
load by more than the folds could measure (podbench.sysid.methods.bands.load_note), in
Python and through ``podbench predict``: on the coupled 5-mass chain, ML trained on four
unit pulses (one size: every fold's load equals the others'), the target a pulse at the
fifth mass three times as large."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from podbench.methods import MultipleLoad

from podbench import Record
from podbench.cli import main
from podbench.core.recordfiles import write_record
from podbench.sysid.methods import bands

from ._cases import forced_case
from ._truth import newmark


@pytest.fixture(scope="module")
def chain():
    """``(training records, target of 3× the unit pulse, target of 1×, the pulse F)``."""
    case = forced_case("coupled")
    recs = [Record(W=W, F=F, dt=case.dt) for W, F in zip(case.W[:4], case.F[:4], strict=True)]
    F = case.F[4]
    W = newmark(case.M, case.C, case.K, case.dt, case.n, F=3.0 * F)[0]
    return recs, Record(W=W, F=3.0 * F, dt=case.dt), Record(W=case.W[4], F=F, dt=case.dt), F


def test_load_levels_by_hand(chain):
    recs, big, _, F = chain
    lv = bands.load_levels(big)
    assert lv["peak"] == 3.0 * float(np.max(np.abs(F)))
    assert math.isclose(lv["impulse"], 3.0 * float(np.sum(np.abs(F))) * big.dt, rel_tol=1e-12)
    w0 = np.array([0.0, -2.0, 1.0])
    free = bands.load_levels(Record(W=np.zeros((3, 4)), w0=w0))
    assert free == {"peak": 2.0, "norm": math.sqrt(5.0)}


def test_a_load_beyond_every_training_load_gets_a_note_and_keeps_its_estimate(chain):
    recs, big, same, _ = chain
    model = MultipleLoad(solver="block").fit(recs)
    p = model.predict(big, coverage=0.9)
    # every training pulse has the same size: no fold lay beyond the others (1×), the
    # target 3× beyond the largest by both measures
    assert "peak 3× the largest training record's, a fold's at most 1× the other folds'" in p.note
    assert "impulse 3×" in p.note and "may be low" in p.note
    assert np.isfinite(p.error_estimate) and p.error_estimate > 0
    # the estimate does not read the note: a linear model's relative error is the same at
    # any size of one load, and so is its estimate (the terms are scale-free)
    q = model.predict(same, coverage=0.9)
    assert q.note == ""
    assert math.isclose(p.error_estimate, q.error_estimate, rel_tol=1e-9)


def test_predict_writes_the_note_beside_the_estimate(chain, tmp_path, capsys):
    recs, big, same, _ = chain
    train = []
    for j, r in enumerate(recs):
        train.append(str(write_record(tmp_path / f"r{j}.npz", r)))
    targets = [str(write_record(tmp_path / "big.npz", big)),
               str(write_record(tmp_path / "same.npz", same))]
    out = tmp_path / "out"
    assert main(["predict", "--method", "ML", "--train", *train, "--target", *targets,
                 "--solver", "block", "--coverage", "0.9", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    rows = {r["target"]: r for r in csv.DictReader(open(out / "errors.csv"))}
    assert rows["big"]["error_estimate"] and "peak 3×" in rows["big"]["note"]
    assert rows["same"]["error_estimate"] and rows["same"]["note"] == ""
    assert rows["big"]["error_estimate"] == rows["same"]["error_estimate"]
    big_line = next(line for line in printed.splitlines() if line.startswith("big:"))
    assert "(note: the target's load lies beyond every training load by more" in big_line
    same_line = next(line for line in printed.splitlines() if line.startswith("same:"))
    assert "note" not in same_line
