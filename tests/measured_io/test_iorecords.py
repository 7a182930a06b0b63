"""Input/output records: units, conversion at the door, validation naming file and field."""

import numpy as np
import pytest

from podbench.core.recordfiles import read_record, write_record
from podbench.core.records import INCH, LBF, Record, check_records, convert
from podbench.errors import InputError


def _rec(n=50, name="a.npz", **kw):
    rng = np.random.default_rng(0)
    args = dict(u=rng.normal(size=(2, n)), y=rng.normal(size=(3, n)), dt=0.01,
                input_units="m/s^2", output_units="m/s^2", input_channels=("g1", "g2"),
                output_channels=("d1", "d2", "d3"), name=name)
    args.update(kw)
    return Record(**args)


def test_conversion_factors_are_exact_and_round_trip():
    r = _rec()
    i = convert(r, "inch-lbf")
    assert i.input_units == "in/s^2" and i.output_units == "in/s^2" and i.units == "inch-lbf"
    np.testing.assert_allclose(i.u, r.u / INCH, rtol=1e-15)
    back = convert(i, "SI")
    np.testing.assert_allclose(back.y, r.y, rtol=1e-15)
    f = Record(u=np.ones((1, 3)), y=np.ones((1, 3)), dt=1.0, input_units="N",
                 output_units="m")
    g = convert(f, "inch-lbf")
    assert g.u[0, 0] == pytest.approx(1 / LBF, rel=1e-15)  # 1 N = 0.2248 lbf
    assert g.y[0, 0] == pytest.approx(39.37007874015748, rel=1e-15)


def test_strain_fits_both_systems_and_mixing_is_refused():
    r = Record(u=np.ones((1, 3)), y=np.ones((1, 3)), dt=1.0, input_units="in/s^2",
                 output_units="strain")
    assert r.units == "inch-lbf" and convert(r, "SI").output_units == "strain"
    with pytest.raises(InputError, match="mix unit systems"):
        Record(u=np.ones((1, 3)), y=np.ones((1, 3)), dt=1.0, input_units="in/s^2",
                 output_units="m/s^2", name="x.npz")


@pytest.mark.parametrize("kw, match", [
    (dict(input_units=None), "x.npz: field `input_units`: missing"),
    (dict(output_units="furlong"), "x.npz: field `output_units`: unknown unit 'furlong'"),
    (dict(output_quantity="strain"), "does not match the unit 'm/s\\^2'"),
    (dict(dt=0.0), "x.npz: field `dt`"),
])
def test_bad_fields_are_one_line_naming_file_and_field(kw, match):
    with pytest.raises(InputError, match=match):
        _rec(name="x.npz", **kw)


def test_nan_is_named_with_its_index():
    u = np.zeros((2, 50))
    u[1, 7] = np.nan
    with pytest.raises(InputError, match=r"x.npz: field `inputs`: NaN or Inf at index \(1, 7\)"):
        _rec(name="x.npz", u=u)


def test_compatibility_checks_before_fitting():
    a = _rec(name="a.npz")
    with pytest.raises(InputError, match="b.npz: field `dt`: 0.02 s differs"):
        check_records([a, _rec(name="b.npz", dt=0.02)])
    with pytest.raises(InputError, match="b.npz: field `input_channels`: channel\\(s\\) g2 "
                                         "absent"):
        check_records([a, _rec(name="b.npz", u=np.ones((1, 50)), input_channels=("g1",))])
    with pytest.raises(InputError, match="b.npz: field `input_units`: 'in/s\\^2' differs"):
        check_records([a], [convert(_rec(name="b.npz"), "inch-lbf")])
    with pytest.raises(InputError, match="b.npz: field `inputs`: 5 samples, the model needs "
                                         "at least 26"):
        check_records([a], [_rec(name="b.npz", n=5)], min_samples=26)


def test_file_round_trip_and_declared_units(tmp_path):
    r = _rec()
    write_record(tmp_path / "r.npz", r, layout="io")
    s = read_record(tmp_path / "r.npz")
    np.testing.assert_array_equal(s.u, r.u)
    assert s.output_channels == r.output_channels and s.output_quantity == "acceleration"
    np.savez(tmp_path / "bare.npz", inputs=r.u, outputs=r.y, dt=0.01)
    with pytest.raises(InputError, match="bare.npz: variable `input_units`: missing"):
        read_record(tmp_path / "bare.npz")
    t = read_record(tmp_path / "bare.npz", input_units="m/s2", output_units="m/s^2",
                       system="inch-lbf")
    np.testing.assert_allclose(t.y, r.y / INCH, rtol=1e-15)
    with pytest.raises(InputError, match="r.npz: variable `input_units`: 'm/s\\^2' in the "
                                         "file, 'in/s\\^2' declared"):
        read_record(tmp_path / "r.npz", input_units="in/s^2")


def test_todays_record_is_the_collocated_special_case():
    W = np.arange(6.0).reshape(2, 3)
    r = Record(W=W, F=2 * W, dt=0.1)
    assert r.collocated and r.input_units == "lbf" and r.output_quantity == "displacement"
    np.testing.assert_array_equal(r.W, W)
    np.testing.assert_array_equal(r.F, 2 * W)


def test_one_record_class_reads_both_layouts_and_free_responses(tmp_path):
    """A displacement/force file, an input/output file and a free response (W, dt, w0, no F)
    come back as one class; the free response needs no F."""
    W = np.arange(12.0).reshape(3, 4)
    np.savez(tmp_path / "free.npz", W=W, dt=0.5, w0=W[:, 0])
    free = read_record(tmp_path / "free.npz")
    assert isinstance(free, Record) and free.free and free.F is None and free.u is None
    np.testing.assert_array_equal(free.W, W)
    assert free.output_units == "in" and free.dt == 0.5 and free.name == "free.npz"
    wf = Record(W=W, F=2 * W, dt=0.1)
    write_record(tmp_path / "wf.csv", wf)
    back = read_record(tmp_path / "wf.csv")
    assert back.collocated and back.input_units == "lbf"
    np.testing.assert_array_equal(back.F, 2 * W)
    io = _rec()
    write_record(tmp_path / "io.csv", io)  # not the dissertation's record: input/output layout
    assert read_record(tmp_path / "io.csv").input_channels == ("g1", "g2")


def test_the_retired_record_names_import_and_warn_once_naming_the_new_name():
    import importlib
    import warnings

    import podbench._compat as compat

    compat._WARNED.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = importlib.import_module("podbench.core.iorecords")
        assert old.IORecord is Record and old.IORecord is Record
        measured = importlib.import_module("podbench.measured")
        r = measured.MeasuredRecord(W=np.ones((2, 3)), F=np.zeros((2, 3)), dt=1.0,
                                    sensors=("a", "b"), path="x.npz")
    assert isinstance(r, Record) and r.sensors == ("a", "b") and r.name == "x.npz"
    texts = [str(w.message) for w in caught if issubclass(w.category, FutureWarning)]
    assert texts == ["IORecord is retired: use podbench.core.records.Record",
                     "MeasuredRecord is retired: use podbench.core.records.Record"]
