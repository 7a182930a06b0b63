"""Every public name of before the one-record, one-class-per-method layout still imports:
through the one alias table (podbench._compat), a retired name warning once with the new
name, and building what it built (a configuration of the new class where its defaults
differed)."""

import importlib
import warnings

import numpy as np
import pytest

import podbench._compat as compat
from podbench.core.records import Record
from podbench.sysid.methods import ERA, DMDc, Mdof, MultipleLoad, OpInf, SingleLoad

# the __all__ of every module whose names moved, as they were
OLD = {
    "podbench.methods": ["PODMethod", "POVR", "MDS", "SingleLoad", "MultipleLoad",
                         "MixedResponse", "Superposition", "ERA", "DMDc", "OpInf",
                         "BUILTIN_METHODS", "MultipleLoadIO", "SingleLoadIO", "ERAIO",
                         "DMDcIO", "OpInfIO", "MdofIO"],
    "podbench.methods.inputs": ["MultipleLoadIO", "SingleLoadIO", "FIRLeastSquares",
                                "mixed_response_io", "LAG_GRID", "TC_GRID", "io_records"],
    "podbench.methods.peers_io": ["ERAIO", "DMDcIO", "OpInfIO", "ERA_BLOCKS"],
    "podbench.sysid.methods.peers_io": ["ERAIO", "DMDcIO", "OpInfIO", "ERA_BLOCKS"],
    "podbench.methods.mdof_peer": ["MdofIO", "okid_fixed", "EXTRA_HINT"],
    "podbench.core.iorecords": ["IORecord", "UNITS", "QUANTITIES", "normalize_unit",
                                "unit_system", "convert", "from_record", "read_io_record",
                                "write_io_record", "check_compatible", "check_records"],
    "podbench.sysid.measured": ["MeasuredRecord", "read_record", "write_record", "FORMATS",
                                "format_of"],
    "podbench.measured": ["MeasuredRecord", "read_record", "write_record", "FORMATS",
                          "format_of"],
    "podbench.records": ["Record", "as_record", "is_record"],
    "podbench.data": ["Record", "Response", "as_record", "displacement_norm", "is_record",
                      "norm_percent_error"],
    "podbench": ["run", "StudyResult", "Record", "Response", "Structure", "deconvolution",
                 "displacement_norm", "errors", "excitations", "list_structures",
                 "load_structure", "methods", "norm_percent_error", "pod", "simulate"],
    "podbench.study.hints": ["did_you_mean"],
}


@pytest.mark.parametrize("module", sorted(OLD))
def test_every_public_name_of_before_imports(module):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        mod = importlib.import_module(module)
        missing = [name for name in OLD[module] if not hasattr(mod, name)]
    assert not missing, f"{module}: {missing}"


def test_a_retired_name_warns_once_naming_the_new_name():
    compat._WARNED.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        methods = importlib.import_module("podbench.methods")
        a = methods.MultipleLoadIO
        b = methods.MultipleLoadIO
    texts = [str(w.message) for w in caught if issubclass(w.category, FutureWarning)]
    assert texts == ["MultipleLoadIO is retired: use podbench.sysid.methods.MultipleLoad with "
                     "inputs='measured', n_lags='auto', solver='ls'"]
    assert a(n_modes=2).get_params() == b(n_modes=2).get_params()


def test_the_retired_classes_build_their_old_configurations():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        methods = importlib.import_module("podbench.methods")
        ml = methods.MultipleLoadIO(prior="tc")
        era = methods.ERAIO(max_order=10, feedthrough="auto")
        assert isinstance(methods.SingleLoadIO(), SingleLoad)
        assert isinstance(methods.DMDcIO(), DMDc) and isinstance(methods.OpInfIO(), OpInf)
        assert isinstance(methods.MdofIO(method="srim"), Mdof)
        old = importlib.import_module("podbench.measured")
        rec = old.MeasuredRecord(np.ones((2, 3)), np.zeros((2, 3)), 0.5, sensors=("a", "b"))
    assert isinstance(ml, MultipleLoad) and (ml.inputs, ml.n_lags, ml.solver, ml.prior) == (
        "measured", "auto", "ls", "tc")
    assert isinstance(era, ERA) and (era.inputs, era.blocks, era.max_order) == (
        "measured", 1.0, 10)
    assert isinstance(rec, Record) and rec.dt == 0.5 and rec.sensors == ("a", "b")
    assert rec.collocated
