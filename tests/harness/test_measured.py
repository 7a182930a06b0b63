"""Measured data in (podbench.measured): a scenario case read from a file in each format,
round trips, one-line errors naming the file and the variable, the shipped example."""
# ruff: noqa: E501  (TOML scenario text)

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from podbench.core.recordfiles import read_record, write_record
from podbench.core.resources import bundled_scenarios
from podbench.errors import InputError, ScenarioFileError
from podbench.harness.runner import read_case, run_unit
from podbench.study.resolve import MeasuredStructure, resolve_structure
from podbench.study.scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = bundled_scenarios() / "examples" / "measured" / "measured_chain.toml"
N, DT = 120, 0.004

SCENARIO = """
[scenario]
name = "{name}"
title = "measured records"
structures = [{structures}]
n_samples = 120
dt = 0.004
targets = ["f6"]
{cases}
[[methods]]
label = "ML"
method = "ML"
train = ["f1", "f2", "f3", "f4", "f5"]
"""


def _record(seed=0, loaded=2):
    rng = np.random.default_rng(seed)
    W = rng.standard_normal((5, N)) * np.logspace(-4, -1, 5)[:, None]
    F = np.zeros((5, N))
    F[loaded, 1:6] = 1.0 + rng.random(5)
    return SimpleNamespace(W=W, F=F, dt=DT, w0=W[:, 0].copy(), v0=rng.standard_normal(5))


def _scenario(tmp_path, files: dict, name="meas", structures='"measured"', extra=""):
    cases = "".join(f'[cases.{c}]\nfile = "{f}"\n' for c, f in files.items())
    p = tmp_path / f"{name}.toml"
    p.write_text(SCENARIO.format(name=name, structures=structures, cases=cases) + extra,
                 encoding="utf-8")
    return load_scenario(p)


@pytest.mark.parametrize("fmt", ["npz", "mat", "csv", "uff"])
def test_each_format_round_trips_through_the_scenario_path(tmp_path, fmt):
    (tmp_path / "data").mkdir()
    r = _record(3)
    write_record(tmp_path / "data" / f"x.{fmt}", r, sensors=["a", "b", "c", "d", "e"])
    sc = _scenario(tmp_path, {f"f{i}": f"data/x.{fmt}" for i in range(1, 7)})
    got = read_case(sc, "f1", MeasuredStructure())
    np.testing.assert_allclose(got.W, r.W, rtol=1e-12, atol=0)
    np.testing.assert_allclose(got.F, r.F, rtol=1e-12, atol=0)
    assert got.dt == DT and got.t[-1] == pytest.approx((N - 1) * DT)
    if fmt in ("npz", "mat"):  # these layouts carry the initial state
        np.testing.assert_allclose(got.v0, r.v0, rtol=1e-12, atol=0)
    else:  # CSV and UFF: from rest at the first sample
        np.testing.assert_array_equal(got.w0, r.W[:, 0])
        assert not got.v0.any()
    assert read_record(tmp_path / "data" / f"x.{fmt}").sensors == ("a", "b", "c", "d", "e")


def test_a_scenario_of_measured_cases_runs_and_has_no_linearization(tmp_path):
    """Five simulated chain tests written to files in four formats, noise-free: ML (k = m)
    identifies the chain exactly from the files, as from the simulation (test_forced...)."""
    from podbench.dynamics import simulate
    from podbench.dynamics.excitations import Pulse
    from podbench.structures import load_structure

    s = load_structure("chain_coupled")
    (tmp_path / "data").mkdir()
    files = {}
    fmts = ["npz", "mat", "csv", "uff", "npz", "csv"]
    for i, dof in enumerate([4, 3, 2, 1, 0, 2]):
        shape = "half_sine" if i == 5 else "rectangular"
        f = Pulse(dof, 1.0, 0.02 if i < 5 else 0.06, shape=shape, by="dof").sample(s, N, DT)
        r = simulate(s, n_samples=N, dt=DT, force=f)
        name = f"f{i + 1}"
        write_record(tmp_path / "data" / f"{name}.{fmts[i]}", r)
        files[name] = f"data/{name}.{fmts[i]}"
    for structures in ('"measured"', '"chain_coupled"'):
        sc = _scenario(tmp_path, files, name="meas", structures=structures)
        res = run_unit(sc.path, structures.strip('"'), keep_series=False)
        (row,) = res.rows
        assert row["status"] == "ok" and res.simulated == 0
        assert row["total_error"] < 1e-9
        assert np.isnan(row["linearization_error"]) and np.isnan(row["residual_error"])


def test_the_shipped_example_runs():
    """scenarios/examples/measured: 1 % noise per channel on every record, the target
    included; ML's error is that of the target's own noise (measured 0.0101)."""
    assert sum(f.stat().st_size for f in EXAMPLE.parent.rglob("*")) < 200_000
    res = run_unit(EXAMPLE, "measured", keep_series=False)
    err = {r["method"]: r["total_error"] for r in res.rows}
    assert 0.005 < err["ML"] < 0.02 and err["SL"] > err["ML"]


# ----------------------------------------------------------------------- bad files
def _bad(tmp_path, name, arrays, **kw):
    (tmp_path / "data").mkdir(exist_ok=True)
    np.savez(tmp_path / "data" / name, **arrays, **kw)
    files = {f"f{i}": f"data/{name}" for i in range(1, 7)}
    return _scenario(tmp_path, files)


@pytest.mark.parametrize("arrays,var,words", [
    ({"F": np.zeros((5, N)), "dt": DT}, "W", "missing (the file has: F, dt)"),
    ({"W": np.zeros((5, N, 1)), "F": np.zeros((5, N)), "dt": DT}, "W", "expected a 2-D array"),
    ({"W": np.zeros((5, N)), "F": np.zeros((4, N)), "dt": DT}, "F", "shape (4, 120) differs"),
    ({"W": np.zeros((5, 100)), "F": np.zeros((5, 100)), "dt": DT}, "W", "100 samples"),
    ({"W": np.zeros((5, N)), "F": np.zeros((5, N)), "dt": 0.001}, "dt", "differs from the scenario's dt"),
    ({"W": np.full((5, N), np.nan), "F": np.zeros((5, N)), "dt": DT}, "W", "NaN or Inf at index (0, 0)"),
])
def test_a_bad_file_gets_one_line_naming_the_file_and_the_variable(tmp_path, arrays, var, words):
    sc = _bad(tmp_path, "x.npz", arrays)
    with pytest.raises(ScenarioFileError) as err:
        read_case(sc, "f1", MeasuredStructure())
    msg = str(err.value)
    assert "\n" not in msg and "cases.f1.file" in msg and "data/x.npz" in msg
    assert f"variable `{var}`" in msg and words in msg


def test_sensor_count_checked_against_a_named_structure(tmp_path):
    sc = _bad(tmp_path, "x.npz", {"W": np.zeros((4, N)), "F": np.zeros((4, N)), "dt": DT})
    s = resolve_structure("chain_coupled", sc)
    with pytest.raises(ScenarioFileError, match="variable `W`: 4 sensors .* has 5"):
        read_case(sc, "f1", s)


def test_pickles_and_matlab_v73_are_refused_clearly(tmp_path):
    p = tmp_path / "obj.npz"
    np.savez(p, W=np.array([{"a": 1}], dtype=object), F=np.zeros((1, 2)), dt=DT)
    with pytest.raises(InputError, match="no pickles"):
        read_record(p)
    # a v7.3 (HDF5) MAT header: version 0x0200 at byte 124
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: x HDF5 schema 1.00 .".ljust(116)
    v73 = tmp_path / "v73.mat"
    v73.write_bytes(head + b"\x00" * 8 + b"\x00\x02IM" + b"\x00" * 512)
    with pytest.raises(InputError, match=r"v7\.3 \(HDF5\).*-v7"):
        read_record(v73)


def test_csv_layout_errors_name_the_column(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("t,w:a,f:b\n0,1,2\n0.1,1,2\n", encoding="utf-8")
    with pytest.raises(InputError, match="variable `f:b`: a force at a sensor without"):
        read_record(p)
    p.write_text("time,w:a\n0,1\n0.1,1\n", encoding="utf-8")
    with pytest.raises(InputError, match="variable `t`: the first column"):
        read_record(p)
    p.write_text("t,w:a\n0,1\n0.1,1\n0.25,1\n", encoding="utf-8")
    with pytest.raises(InputError, match="variable `t`: expected uniform"):
        read_record(p)


def test_missing_pyuff_names_the_extra(tmp_path, monkeypatch):
    p = tmp_path / "x.uff"
    p.write_text("", encoding="utf-8")
    monkeypatch.setitem(sys.modules, "pyuff", None)
    with pytest.raises(InputError, match=r"pip install 'podbench\[measured\]'"):
        read_record(p)


def test_a_case_is_a_file_or_excitations_not_both(tmp_path):
    p = tmp_path / "both.toml"
    p.write_text(SCENARIO.format(name="both", structures='"measured"', cases="""
[cases.f1]
file = "a.npz"
force = { kind = "pulse", location = 1, amplitude = 1.0, duration = 0.02, by = "dof" }
"""), encoding="utf-8")
    with pytest.raises(ScenarioFileError, match="cases.f1.file.*not both"):
        load_scenario(p)


def test_the_conditioning_table_is_read():
    from podbench.sysid.conditioning import Conditioning

    sc = load_scenario(EXAMPLE)
    assert sc.conditioning == Conditioning(detrend="linear", force_window=(0.004, 0.02))
    # run_unit(conditioning=None) switches it off; the example's noise is then kept
    on = run_unit(EXAMPLE, "measured", keep_series=False).rows
    off = run_unit(EXAMPLE, "measured", keep_series=False, conditioning=None).rows
    assert [r["total_error"] for r in on] != [r["total_error"] for r in off]
