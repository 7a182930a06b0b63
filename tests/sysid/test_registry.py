"""The one registry of method names: lookup, configurations, a user's class, and no method
name compared as a string anywhere else in the package."""

import re
from pathlib import Path

import numpy as np
import pytest

from podbench.errors import InputError, UnknownNameError
from podbench.sysid import registry
from podbench.sysid.methods import FIRLeastSquares, MultipleLoad, PODMethod

PACKAGE = Path(__file__).resolve().parents[2] / "podbench"


def test_every_entry_builds_an_estimator_of_its_class():
    assert len(set(registry.names())) == len(registry.ENTRIES)
    for e in registry.ENTRIES:
        est = e.build(**{p: 4 for p in e.supplied})
        assert isinstance(est, e.cls) and isinstance(est, PODMethod)
        for key, value in e.params.items():
            assert est.get_params(deep=False)[key] == value
    assert registry.BUILTIN_METHODS["FIR-LS"] is FIRLeastSquares
    assert all(not e.configuration for e in registry.ENTRIES
               if e.name in registry.BUILTIN_METHODS)


def test_lookup_is_exact_then_letter_case_then_a_did_you_mean():
    assert registry.lookup("ML").cls is MultipleLoad
    assert registry.lookup("ml-tc").name == "ML-TC"  # letter case aside
    with pytest.raises(UnknownNameError, match=r"unknown method \"MSD\"; did you mean 'MDS'\?"):
        registry.lookup("MSD")


def test_a_configuration_leaves_what_its_caller_must_give():
    with pytest.raises(InputError, match="method 'ML-k': give n_modes"):
        registry.lookup("ML-k").build()
    est = registry.lookup("ML-k").build(n_modes=3)
    assert (est.n_modes, est.inputs, est.n_lags, est.solver) == (3, "measured", None, "ls")


def test_a_users_class_registers_the_same_way_and_a_bad_one_gets_one_line(tmp_path):
    (tmp_path / "mine.py").write_text(
        "from podbench.methods import PODMethod\n"
        "class Good(PODMethod):\n"
        "    def _fit(self, records, basis):\n        self.modes_ = None\n"
        "class NoPredict:\n    def fit(self, records):\n        return self\n")
    assert registry.resolve("mine.py:Good", tmp_path).cls.__name__ == "Good"
    with pytest.raises(InputError) as err:
        registry.resolve("mine.py:NoPredict", tmp_path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("mine.py: NoPredict has no `predict(record)`")


_COMPARISON = re.compile(
    r"(==|!=|\bin\b|\bnot in\b)\s*[(\[{]?\s*['\"](" +
    "|".join(re.escape(n) for n in registry.names()) + r")['\"]")


def test_no_method_name_is_compared_as_a_string_outside_the_registry():
    """A method's behaviour is declared by its class (traits, ``refusal``,
    ``command_line_params``), never decided elsewhere by comparing its name; at most 2
    comparisons in the package (measured: 0 outside the registry's own lookup)."""
    found = []
    for path in PACKAGE.rglob("*.py"):
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            code = line.split("#", 1)[0]
            if _COMPARISON.search(code):
                found.append(f"{path.relative_to(PACKAGE)}:{i}: {line.strip()}")
    assert len(found) <= 2, "\n".join(found)


def test_configurations_give_the_classes_results():
    rng = np.random.default_rng(0)
    from podbench.core.records import Record

    recs = [Record(u=rng.normal(size=(1, 120)), y=rng.normal(size=(2, 120)), dt=0.01,
                   input_units="m/s^2", output_units="m/s^2", name=f"r{j}") for j in range(3)]
    a = registry.lookup("ML-lags").build().fit(recs).predict(recs[0])
    b = MultipleLoad(inputs="measured", n_lags="auto", solver="ls").fit(recs).predict(recs[0])
    np.testing.assert_array_equal(a, b)
