"""Structure files in SI (``units = "m, N, second"``) besides the dissertation's inch–lbf:
the same beam written in both systems has the same natural frequencies and the same
dimensionless errors, and its displacements in metres are those in inches times 0.0254."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from podbench import api
from podbench.core.units import INCH, LBF
from podbench.errors import StructureFileError
from podbench.structures.beam import density_from_lbm_per_ft3
from podbench.structures.files import build_structure, structure_length_unit

RHO_IN = density_from_lbm_per_ft3(500.0)  # lbf·s²/in⁴
MASS = LBF / INCH  # kg per lbf·s²/in
SENSORS_IN = [0.0, 3.0, 6.0, 9.0, 12.0]


def _beam(si: bool) -> dict:
    L = INCH if si else 1.0  # metres per file length unit
    return {"name": "b_si" if si else "b_in", "kind": "cantilever_beam",
            "units": "m, N, second" if si else "inch, lbf, second", "description": "test",
            "beam": {"length": 12.0 * L, "width": 1.0 * L, "depth": 0.75 * L,
                     "E": 29.0e6 * (LBF / INCH**2 if si else 1.0),
                     "density": RHO_IN * (MASS / INCH**3 if si else 1.0),
                     "n_elements": 12, "sensors": [x * L for x in SENSORS_IN]},
            "damping": {"modal_ratio": 0.02}}


def test_the_si_beam_has_the_same_frequencies_and_its_matrices_convert():
    b_in, b_si = build_structure(_beam(False)), build_structure(_beam(True))
    assert b_in.metadata["unit_system"] == "inch-lbf" and b_si.metadata["unit_system"] == "SI"
    assert b_si.metadata["units"] == "m, N, second"
    assert structure_length_unit(b_in) == "in" and structure_length_unit(b_si) == "m"
    # round-off only: the eigenproblem's conditioning (K's span of 1e8) times 1e-16
    np.testing.assert_allclose(b_si.natural_frequencies(6), b_in.natural_frequencies(6),
                               rtol=1e-9)
    dense = [k.toarray() if hasattr(k, "toarray") else np.asarray(k) for k in (b_si.K, b_in.K)]
    np.testing.assert_allclose(dense[0], dense[1] * (LBF / INCH) * np.kron(
        np.ones((12, 12)), [[1.0, INCH], [INCH, INCH**2]]), rtol=1e-12)
    np.testing.assert_allclose(b_si.sensor_positions, INCH * np.asarray(SENSORS_IN),
                               rtol=1e-15)


def test_an_inch_lbf_field_in_an_si_file_is_refused():
    spec = _beam(True)
    spec["beam"].pop("density")
    spec["beam"]["density_lbm_per_ft3"] = 500.0
    with pytest.raises(StructureFileError, match=r"field `beam\.density_lbm_per_ft3`: an "
                       r"inch–lbf field in a file whose units are \"m, N, second\""):
        build_structure(spec, source="b_si.toml")


def test_the_si_displacements_are_the_inch_ones_times_0_0254():
    from podbench.dynamics.simulate import simulate

    b_in, b_si = build_structure(_beam(False)), build_structure(_beam(True))
    F_in = np.zeros((len(SENSORS_IN), 300))
    F_in[-1, 1:6] = 100.0  # lbf at the 12-in tip, 0.5 ms
    r_in = simulate(b_in, 300, 1e-4, force=F_in)
    r_si = simulate(b_si, 300, 1e-4, force=LBF * F_in)
    assert np.max(np.abs(r_in.W)) > 1e-4  # in: a real response
    np.testing.assert_allclose(r_si.W, INCH * r_in.W, rtol=0,
                               atol=1e-9 * INCH * np.max(np.abs(r_in.W)))


def _toml(d: dict, prefix: str = "") -> str:
    top = [f"{k} = {_value(v)}" for k, v in d.items() if not isinstance(v, dict)]
    subs = [f"\n[{prefix}{k}]\n" + _toml(v, f"{prefix}{k}.") for k, v in d.items()
            if isinstance(v, dict)]
    return "\n".join(top) + "\n" + "".join(subs)


def _value(v) -> str:
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return repr(v)


def _scenario(si: bool) -> str:
    L, F = (INCH, LBF) if si else (1.0, 1.0)
    name = "s_si" if si else "s_in"
    cases = "".join(
        f"[cases.load{i}]\nforce = {{ kind = \"pulse\", location = {x * L!r}, "
        f"amplitude = {100.0 * F!r}, duration = 5.0e-4 }}\n"
        for i, x in enumerate((3.0, 6.0, 9.0, 12.0), start=1))
    beam = "b_si" if si else "b_in"
    return (f'[scenario]\nname = "{name}"\ntitle = "t"\nstructures = ["{beam}"]\n'
            f'n_samples = 300\ndt = 1.0e-4\ntargets = ["load4"]\n\n{cases}\n'
            '[[methods]]\nlabel = "ML"\nmethod = "ML"\ntrain = ["load1", "load2", "load3"]\n'
            'options = { solver = "block" }\n')


@pytest.mark.heavy
def test_si_and_inch_lbf_runs_give_the_same_errors_and_scaled_displacements(tmp_path):
    for si in (False, True):
        folder = tmp_path / ("si" if si else "in")
        (folder / "structures").mkdir(parents=True)
        spec = _beam(si)
        (folder / "structures" / f"{spec['name']}.toml").write_text(_toml(spec),
                                                                    encoding="utf-8")
        (folder / f"{'s_si' if si else 's_in'}.toml").write_text(_scenario(si),
                                                                 encoding="utf-8")
    got = {}
    for tag in ("in", "si"):
        res = api.run(tmp_path / tag, out=tmp_path / f"out_{tag}", jobs=1, cache=None,
                      figures=tag == "si", quiet=True)
        got[tag] = res
    s_in, s_si = (pd.read_csv(tmp_path / f"out_{t}" / "summary.csv") for t in ("in", "si"))
    errors = [c for c in s_in.columns if c.endswith("error") and
              pd.api.types.is_numeric_dtype(s_in[c])]
    assert "total_error" in errors
    for c in errors:
        np.testing.assert_allclose(s_si[c].to_numpy(float), s_in[c].to_numpy(float),
                                   rtol=1e-6, atol=1e-12, err_msg=c)
    ser_in, ser_si = got["in"]._units[0].series["load4"], got["si"]._units[0].series["load4"]
    assert ser_si["unit"] == "m"
    np.testing.assert_allclose(ser_si["truth"], INCH * ser_in["truth"], rtol=1e-9,
                               atol=1e-12 * INCH * np.max(ser_in["truth"]))
    report = (tmp_path / "out_si" / "report.html").read_text(encoding="utf-8")
    assert "Units: displacements in m" in report and "100-lbf" not in report
