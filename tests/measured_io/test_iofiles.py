"""CSV and UFF 58 input/output records: round trips, pyuff's own writer, bad files."""

import csv
import importlib.util

import numpy as np
import pytest

from podbench.cli import main
from podbench.core.iofiles import is_io_layout
from podbench.core.recordfiles import read_record, write_record
from podbench.core.records import Record
from podbench.errors import InputError

HAVE_PYUFF = importlib.util.find_spec("pyuff") is not None
needs_pyuff = pytest.mark.skipif(not HAVE_PYUFF, reason="pyuff not installed")


def _ds58(**kw):
    """A dataset 58 from pyuff's own prepare_58, every required key given."""
    import pyuff

    base = dict(id2="", id3="", id4="", id5="", load_case_id=0, ver_num=0,
                rsp_ent_name="pt", ref_ent_name="none", abscissa_axis_units_lab="s",
                orddenom_spec_data_type=0, orddenom_axis_units_lab="", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="", z_axis_value=0.0, abscissa_len_unit_exp=0,
                abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0, ordinate_len_unit_exp=1,
                ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0, orddenom_len_unit_exp=0,
                orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0, z_axis_len_unit_exp=0,
                z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0)
    base.update(kw)
    return pyuff.prepare_58(**base)


def _rec(n=64, y=True, **kw):
    rng = np.random.default_rng(3)
    args = dict(u=rng.normal(size=(2, n)) * 1e-3, y=rng.normal(size=(3, n)) * 7e4 if y else None,
                dt=0.005, input_units="in/s^2", output_units="strain",
                input_channels=("ground x", "abut,2"), output_channels=("s1", "s2", "mid [c]"),
                name="r")
    args.update(kw)
    return Record(**args)


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat",
                                    pytest.param(".uff", marks=needs_pyuff),
                                    pytest.param(".unv", marks=needs_pyuff)])
def test_every_format_round_trips_values_units_and_channels_exactly(tmp_path, suffix):
    r = _rec()
    p = tmp_path / f"rec{suffix}"
    write_record(p, r, layout="io")
    s = read_record(p)
    np.testing.assert_array_equal(s.u, r.u)  # exact: 17 digits in CSV, doubles in UFF 58b
    np.testing.assert_array_equal(s.y, r.y)
    assert s.dt == r.dt and s.n_samples == 64
    assert s.input_channels == r.input_channels and s.output_channels == r.output_channels
    assert (s.input_units, s.output_units) == ("in/s^2", "strain")
    assert (s.input_quantity, s.output_quantity) == ("acceleration", "strain")
    assert s.units == "inch-lbf"
    if suffix in (".csv", ".uff", ".unv"):
        assert is_io_layout(p)


@pytest.mark.parametrize("suffix", [".csv", pytest.param(".uff", marks=needs_pyuff)])
def test_a_target_without_outputs_takes_the_declared_output_unit(tmp_path, suffix):
    r = _rec(y=False, input_units="m/s^2", output_units="m")
    p = tmp_path / f"t{suffix}"
    write_record(p, r, layout="io")
    with pytest.raises(InputError, match=f"t{suffix}: variable `outputs`: missing"):
        read_record(p)
    s = read_record(p, require_outputs=False, default_output_units="m")
    assert s.y is None and s.output_units == "m" and s.output_quantity == "displacement"
    np.testing.assert_array_equal(s.u, r.u)


@needs_pyuff
def test_ascii_uff_written_by_pyuff_itself_is_read(tmp_path):
    """An independent writer: pyuff's ASCII dataset 58 (11 significant digits), unnamed
    channels told apart by their data types (13 force → input, 12 acceleration → output)."""
    import pyuff

    t = np.arange(200) * 0.01
    f = np.sin(2 * np.pi * t)
    a = np.cos(3 * t) * 9.81
    sets = []
    for node, kind, unit, data in ((5, 13, "N", f), (7, 12, "m/s^2", a)):
        sets.append(_ds58(
            binary=0, id1="Record 1", func_type=1, rsp_node=node, rsp_dir=3, ref_node=0,
            ref_dir=0, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=0.01,
            num_pts=200, ordinate_spec_data_type=kind, ordinate_axis_units_lab=unit,
            abscissa_spec_data_type=17, ord_data_type=4,
            data=data, x=t))
    p = tmp_path / "shaker.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    r = read_record(p)
    assert r.input_channels == ("5:3",) and r.output_channels == ("7:3",)
    assert (r.input_quantity, r.output_quantity) == ("force", "acceleration")
    assert r.dt == 0.01
    np.testing.assert_allclose(r.u[0], f, rtol=1e-10, atol=1e-11)
    np.testing.assert_allclose(r.y[0], a, rtol=1e-10)


@pytest.mark.parametrize("text, words", [
    ("time,u:a [m/s^2]\n0,1\n0.1,2\n", "bad.csv: field `t`: the first column must be time"),
    ("t,u:a [m/s^2],x:b\n0,1,2\n0.1,2,3\n", "bad.csv: field `x:b`: expected a column named"),
    ("t,u:a [m/s^2],y:b [m/s^2]\n0,1,2\n0.1,oops,3\n",
     "bad.csv: field `u:a [m/s^2]`: row 3: 'oops' is not a number"),
    ("t,u:a [m/s^2],y:b [m/s^2]\n0,1,2\n0.1,nan,3\n",
     "bad.csv: field `u:a [m/s^2]`: NaN or Inf in row 3"),
    ("t,u:a [m/s^2],u:b [in/s^2],y:c [m]\n0,1,2,3\n0.1,2,3,4\n",
     "bad.csv: field `u:b [in/s^2]`: unit 'in/s^2' differs from 'u:a [m/s^2]'"),
    ("t,u:a [m/s^2],y:c [m]\n0,1,2\n0.1,2,3\n0.3,2,3\n",
     "bad.csv: field `t`: expected uniform times"),
    ("t,u:a [m/s^2],y:c [m]\n0,1,2\n0.1,2\n", "bad.csv: field `row 3`: 2 values"),
    ("t,u:a [m/s^2],y:c [furlong]\n0,1,2\n0.1,2,3\n",
     "bad.csv: field `output_units`: unknown unit 'furlong'"),
    ("t,u:a,y:c [m]\n0,1,2\n0.1,2,3\n", "bad.csv: the input columns carry no unit; write "
     "it in the header (`u:<channel> [m/s^2]`) or declare it (e.g. --input-units m/s^2)"),
    ("t,u:a [N],y:c\n0,1,2\n0.1,2,3\n", "bad.csv: the output columns carry no unit"),
    ("t,y:c [m]\n0,1\n0.1,2\n", "bad.csv: field `inputs`: no input column"),
])
def test_a_bad_csv_is_one_line_naming_the_file_and_the_field(tmp_path, text, words):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(InputError) as exc:
        read_record(p)
    assert words in str(exc.value) and "\n" not in str(exc.value)


@needs_pyuff
def test_a_bad_uff_is_one_line_naming_the_file_and_the_field(tmp_path):
    import pyuff

    def ds(id1, inc, n=50, kind=12, unit="m/s^2", func_type=1):
        return _ds58(
            binary=0, id1=id1, func_type=func_type, rsp_node=1, rsp_dir=1, ref_node=0,
            ref_dir=0, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=inc, num_pts=n,
            ordinate_spec_data_type=kind, ordinate_axis_units_lab=unit,
            abscissa_spec_data_type=17, ord_data_type=4, data=np.ones(n),
            x=np.arange(n) * inc)
    cases = [([ds("u:g", 0.01), ds("y:d", 0.02)], "field `dt`: the datasets have different"),
             ([ds("u:g", 0.01), ds("y:d", 0.01, n=40)], "field `inputs`: the datasets have "
                                                        "different lengths"),
             ([ds("u:g", 0.01), ds("y:d", 0.01, func_type=4)], "field `dataset 2`: function "
                                                               "type 4"),
             ([ds("u:g", 0.01), ds("u:g", 0.01)], "field `u:g`: channel listed twice"),
             ([ds("u:g", 0.01), ds("y:d", 0.01, kind=12, unit="m")],
              "field `output_quantity`: 'acceleration' does not match the unit 'm'"),
             ([ds("u:g", 0.01, unit="NONE"), ds("y:d", 0.01)],
              "variable `input_units`: missing")]
    for k, (sets, words) in enumerate(cases):
        p = tmp_path / f"bad{k}.uff"
        pyuff.UFF(str(p)).write_sets(sets, mode="add")
        with pytest.raises(InputError, match=f"bad{k}.uff: .*{words}") as exc:
            read_record(p)
        assert "\n" not in str(exc.value)


@needs_pyuff
def test_uff_refuses_a_dt_it_cannot_store():
    with pytest.raises(InputError, match="x.uff: field `dt`: .* 6 significant digits"):
        write_record("x.uff", _rec(dt=1 / 3000), layout="io")


def test_predict_reads_csv_records_as_it_reads_npz(tmp_path):
    """The same records as CSV and .npz give the same prediction (CSV round trip exact)."""
    h = 0.02 * np.exp(-np.arange(20) / 4.0)
    rng = np.random.default_rng(1)
    paths = {".csv": [], ".npz": []}
    for j, n in enumerate((300, 260, 280, 240)):
        u = rng.normal(size=(1, n))
        y = np.convolve(u[0], h)[:n][None]
        rec = Record(u=u, y=None if j == 3 else y, dt=0.01, input_units="m/s^2",
                       output_units="m/s^2", input_channels=("g",), output_channels=("d",))
        for suffix in paths:
            p = tmp_path / f"r{j}{suffix}"
            write_record(p, rec, layout="io")
            paths[suffix].append(str(p))
    preds = {}
    for suffix, ps in paths.items():
        out = tmp_path / f"out{suffix[1:]}"
        assert main(["predict", "--method", "ML", "--train", *ps[:2], "--target", *ps[2:],
                     "--out", str(out), "--solver", "ls"]) == 0
        rows = list(csv.DictReader(open(out / "errors.csv")))
        assert float(rows[0]["total_error"]) < 1e-10 and rows[1]["total_error"] == ""
        with np.load(out / "r3.npz") as z:
            preds[suffix] = z["y_hat"]
    np.testing.assert_array_equal(preds[".csv"], preds[".npz"])
