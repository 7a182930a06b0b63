"""Hyperparameters declared once (podbench.sysid.params): the declarations match the
constructors, the checks raise InvalidParameterError naming the parameter, and the tables
of docs/methods.md are the ones the declarations generate."""

import inspect
import pickle
from pathlib import Path

import pytest

from podbench.errors import InputError, InvalidParameterError
from podbench.sysid import paramdocs
from podbench.sysid.methods.forced import MultipleLoad, SingleLoad
from podbench.sysid.params import Interval, Options, check_param, validate_params

DOCS = Path(__file__).resolve().parents[2] / "docs" / "methods.md"
CLASSES = list(paramdocs.METHODS) + list(paramdocs.SOLVERS.values())


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_constructor_parameter_is_declared_and_its_default_admitted(cls):
    names = cls._get_param_names()
    assert list(cls._parameter_constraints) == names
    sig = inspect.signature(cls.__init__)
    for name in names:
        check_param(sig.parameters[name].default, name, cls._parameter_constraints[name])
    validate_params(cls())


def test_docs_parameter_tables_are_the_generated_ones():
    text = DOCS.read_text(encoding="utf-8")
    block = text[text.index(paramdocs.BEGIN):text.index(paramdocs.END) + len(paramdocs.END)]
    assert block == paramdocs.render(), "run: python -m podbench.sysid.paramdocs docs/methods.md"


@pytest.mark.parametrize("est, param, message", [
    (SingleLoad(n_modes=0), "n_modes", "Parameter `n_modes`: expected an integer >= 1, got 0"),
    (SingleLoad(n_modes="3"), "n_modes",
     "Parameter `n_modes`: expected None or an integer >= 1, got '3'"),
    (SingleLoad(energy=1.5), "energy", "Parameter `energy`: expected a number in (0, 1], got 1.5"),
    (SingleLoad(n_lags="all"), "n_lags",
     "Parameter `n_lags`: expected 'auto', got 'all'"),
    (MultipleLoad(max_cond=0.5), "max_cond",
     "Parameter `max_cond`: expected a number >= 1, got 0.5"),
    (MultipleLoad(solver_options=[1]), "solver_options",
     "Parameter `solver_options`: expected None or a dict of keyword options, got [1]"),
])
def test_a_bad_value_is_one_invalid_parameter_error_naming_it(est, param, message):
    with pytest.raises(InvalidParameterError) as info:
        est._validate_params()
    assert str(info.value) == message
    assert info.value.param == param and isinstance(info.value, InputError)
    again = pickle.loads(pickle.dumps(info.value))  # crosses process boundaries intact
    assert (str(again), again.param) == (message, param)


def test_unknown_solver_option_names_solver_options():
    with pytest.raises(InvalidParameterError) as info:
        SingleLoad(solver="cgls", solver_options={"regg": 1})._validate_params()
    assert info.value.param == "solver_options" and isinstance(info.value, TypeError)


def test_constraints_describe_their_range():
    assert Interval("number", 0, 1, closed="both").describe() == "a number in [0, 1]"
    assert Interval("integer", None, 3, closed="neither").describe() == "an integer < 3"
    assert Options("po", "pi").describe() == "one of 'po', 'pi'"
    assert check_param(3, "n", [None, Interval("integer", 1)]) == 3
    assert isinstance(check_param(2, "x", [Interval("number", 0)]), float)
    for bad in (True, float("nan"), float("inf")):
        with pytest.raises(InvalidParameterError):
            check_param(bad, "x", [Interval("number", 0)])


def test_a_class_without_declarations_is_not_checked_here():
    class Mine(SingleLoad):
        _parameter_constraints: dict = {}

        def __init__(self, *, n_modes=None, whatever=None):
            self.n_modes = n_modes
            self.whatever = whatever

    assert validate_params(Mine(n_modes=-3))["n_modes"] == -3
