"""The base-excited study: motions, SI records, the study file's errors, a small run."""

import csv

import numpy as np
import pytest

from podbench.core.records import INCH, convert
from podbench.errors import InputError
from podbench.harness.base_excited import (
    StructureSpec,
    base_motion,
    load_study,
    make_records,
    run_study,
)
from podbench.report.base_excited import write_study
from podbench.sysid.methods import MultipleLoad


def measured_ml(**kw):
    """ML on measured inputs with the lag rule (the former ``MultipleLoadIO``'s defaults)."""
    return MultipleLoad(**{"inputs": "measured", "n_lags": "auto", "solver": "ls", **kw})


SMALL = """
[base_excitation]
name = "small"
title = "small"
train = ["rect_T", "half_sine_3T"]
targets = ["burst"]
outputs = ["absolute_acceleration", "strain"]
[base_excitation.structures.lti_beam]
dt = 1.0e-4
n_samples = 120
resultant = 500.0
pulse = 5.0e-4
strain_points = [1.0, 12.0]
fibre_distance = 0.375
"""


def test_base_motions_start_at_rest_and_peak_at_the_amplitude():
    dt, T, A = 1e-3, 5e-3, 2.5
    r = base_motion("rect_2T", dt, 100, T, A)
    assert r[0] == 0.0 and np.count_nonzero(r) == 10 and r.max() == A
    h = base_motion("half_sine_3T", dt, 100, T, A)
    assert h[0] == 0.0 and np.count_nonzero(h) == 14 and h.max() == pytest.approx(A, rel=0.02)
    d = base_motion("double_T", dt, 100, T, A)
    assert d.sum() == 0.0 and d.min() == -A
    b = base_motion("burst", dt, 100, T, A)
    assert b[0] == 0.0 and np.abs(b).max() == pytest.approx(A, rel=1e-15)
    with pytest.raises(InputError, match="base motion 'sawtooth'"):
        base_motion("sawtooth", dt, 100, T, A)


def test_records_are_si_and_ml_gives_the_same_prediction_in_either_system():
    """Conversion once where the records are made: m/s² = 0.0254 · in/s²; ML fitted on the
    inch–lbf records predicts the SI prediction converted (the identification does not
    depend on the units)."""
    spec = StructureSpec("lti_beam", "lti_beam", 1e-4, 150, 500.0, 5e-4,
                         strain={"strain_points": [3.0], "fibre_distance": 0.375})
    si = make_records(spec, ["rect_T", "half_sine_3T", "burst"], "absolute_acceleration")
    assert si[0].input_units == "m/s^2" and si[0].output_units == "m/s^2"
    r = si[0].u.max() / INCH  # the peak in in/s²: resultant / (rᵀ M r)
    assert r == pytest.approx(500.0 / 0.013136686322101321, rel=1e-9)
    ips = [convert(x, "inch-lbf") for x in si]
    a = measured_ml(n_lags=None, solver="ls").fit(si[:2]).predict(si[2])
    b = measured_ml(n_lags=None, solver="ls").fit(ips[:2]).predict(ips[2])
    np.testing.assert_allclose(b * INCH, a, rtol=1e-9, atol=1e-12 * np.abs(a).max())
    assert np.linalg.norm(a - si[2].y) / np.linalg.norm(si[2].y) < 1e-9


@pytest.mark.parametrize("text, words", [
    ("[other]\n", "study.toml: table `[base_excitation]`: missing"),
    ("[base_excitation]\ntrain = ['rect_T']\ntargets = ['burst']\n",
     "study.toml: field `structures`: missing"),
    (SMALL.replace('"burst"', '"zigzag"'), "base motion 'zigzag'"),
    (SMALL.replace('n_samples = 120', 'n_samples = "many"'),
     "[base_excitation.structures.lti_beam]: field `n_samples`: expected int"),
    (SMALL.replace('"strain"]', '"stress"]'), "field `outputs`: unknown 'stress'"),
])
def test_a_bad_study_file_is_one_line(tmp_path, text, words):
    p = tmp_path / "study.toml"
    p.write_text(text)
    with pytest.raises(InputError) as exc:
        load_study(p)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_a_small_study_runs_and_writes_its_tables(tmp_path):
    p = tmp_path / "study.toml"
    p.write_text(SMALL)
    res = run_study(p)
    write_study(res, tmp_path / "out", figures=False)
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    by = {(r["output"], r["method"]): r for r in rows}
    assert by[("absolute_acceleration", "ML")]["total_error"] == "<1e-08"
    assert by[("strain", "ML")]["total_error"] == "<1e-08"
    assert by[("absolute_acceleration", "ML")]["unit"] == "m/s^2"
    assert by[("strain", "SL")]["status"] == "refused"
    assert "not forces at the output channels" in by[("strain", "SL")]["note"]
    assert float(by[("absolute_acceleration", "FIR-LS-half")]["total_error"]) > 0.1
    assert "## Strain" in (tmp_path / "out" / "FINDINGS.md").read_text()
