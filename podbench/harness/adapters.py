"""Adapters between the harness (which holds :class:`~podbench.data.Response` objects) and the
identification methods (which see only arrays).

Each adapter has ``fit(train, basis=None)`` with the training responses in the scenario's order
and ``predict(target) -> (m, n)`` for a target response, and exposes the basis it used as
``modes_`` (m × k, orthonormal). What each built-in method takes from a response:

========  ==========================================  ==========================================
method    fit                                         predict
========  ==========================================  ==========================================
POVR      ``W, x0`` of the first training response     ``x0`` of the target
MDS       ``[W…], [x0…]`` of all training responses    ``x0`` of the target
SL        ``W, F`` of the first training response      ``F`` of the target
ML        ``[W…], [F…]``                               ``F`` of the target
MR        ``[W…], w0=[…], v0=[…], F=[…]``              ``w0, v0, F`` of the target
========  ==========================================  ==========================================

``x0`` is the initial displacement ``w0`` (``options.excitation = "displacement"``, the
default) or velocity ``v0`` (``"velocity"``) at the sensors. ``superposition`` sums the
predictions of other methods, each fed its own part of the target (free-displacement methods
get ``w0``, free-velocity methods ``v0``, forced methods ``F``): for a linear structure that
is exact, so MDS(w0) + MDS(v0) + ML(F) in MR's basis is MR's coupled twin.

A method of your own is named ``"module:Class"`` (an importable module) or
``"file.py:Class"`` (a path relative to the scenario file). The class is constructed with
``n_modes=`` (if the scenario gives it) and the scenario's ``options``, and must provide::

    fit_responses(train: list[Response], *, basis=None) -> self
    predict_response(target: Response) -> ndarray (m, n)
    modes_  # optional (m, k) orthonormal basis; without it projection errors are NaN
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

import numpy as np

from ..errors import InputError, ScenarioFileError
from ..methods import MDS, POVR, MixedResponse, MultipleLoad, SingleLoad

__all__ = ["make_adapter", "Adapter", "SuperpositionAdapter", "UserAdapter", "KIND"]

_CLASSES = {"POVR": POVR, "MDS": MDS, "SL": SingleLoad, "ML": MultipleLoad,
            "MR": MixedResponse}

KIND = {"POVR": "free", "MDS": "free", "SL": "forced", "ML": "forced", "MR": "mixed"}
"""Which excitation each built-in method identifies."""


class Adapter:
    """A built-in method driven from responses."""

    def __init__(self, method: str, n_modes: int | None, options: dict):
        self.method = method
        opts = dict(options)
        if n_modes is not None:
            opts["n_modes"] = n_modes
        self.excitation = opts.get("excitation", "displacement")
        try:
            self.estimator = _CLASSES[method](**opts)
        except TypeError as exc:
            raise InputError(f"method {method}: bad option ({exc})") from None

    @property
    def kind(self) -> str:
        return KIND[self.method]

    def _x0(self, r):
        return r.v0 if self.excitation == "velocity" else r.w0

    def fit(self, train, basis=None):
        e, m = self.estimator, self.method
        if m == "POVR":
            e.fit(train[0].W, self._x0(train[0]), basis=basis)
        elif m == "MDS":
            e.fit([r.W for r in train], [self._x0(r) for r in train], basis=basis)
        elif m == "SL":
            e.fit(train[0].W, train[0].F, dt=train[0].dt, basis=basis)
        elif m == "ML":
            e.fit([r.W for r in train], [r.F for r in train], dt=train[0].dt, basis=basis)
        else:  # MR
            e.fit([r.W for r in train], w0=[r.w0 for r in train], v0=[r.v0 for r in train],
                  F=[r.F for r in train], dt=train[0].dt, basis=basis)
        return self

    def predict(self, target) -> np.ndarray:
        e = self.estimator
        if self.kind == "free":
            return e.predict(self._x0(target))
        if self.kind == "forced":
            return e.predict(target.F)
        return e.predict(w0=target.w0, v0=target.v0, F=target.F)

    @property
    def modes_(self):
        return self.estimator.modes_


class SuperpositionAdapter:
    """Sum of other methods' predictions (each fitted in the same basis)."""

    kind = "mixed"

    def __init__(self, parts: list):
        self.parts = parts
        self._basis = None

    def fit(self, trains, basis=None):
        for a, train in zip(self.parts, trains, strict=True):
            a.fit(train, basis=basis)
        self._basis = self.parts[0].modes_ if basis is None else basis
        return self

    def predict(self, target) -> np.ndarray:
        return sum(a.predict(target) for a in self.parts)

    @property
    def modes_(self):
        return self._basis


class UserAdapter:
    """A user's class following the harness protocol (see the module docstring)."""

    kind = "user"

    def __init__(self, cls, n_modes: int | None, options: dict, name: str):
        opts = dict(options)
        if n_modes is not None:
            opts["n_modes"] = n_modes
        try:
            self.estimator = cls(**opts)
        except TypeError as exc:
            raise InputError(f"method {name}: bad option ({exc})") from None
        for attr in ("fit_responses", "predict_response"):
            if not callable(getattr(self.estimator, attr, None)):
                raise InputError(f"method {name}: the class has no `{attr}` method (see "
                                 "podbench.harness.adapters for the protocol)")

    def fit(self, train, basis=None):
        self.estimator.fit_responses(list(train), basis=basis)
        return self

    def predict(self, target) -> np.ndarray:
        return np.asarray(self.estimator.predict_response(target), dtype=float)

    @property
    def modes_(self):
        return getattr(self.estimator, "modes_", None)


def load_class(spec: str, base_dir: Path, where: str):
    """Import ``module:Class`` or ``file.py:Class`` (relative to ``base_dir``)."""
    mod_name, _, cls_name = spec.rpartition(":")
    if not mod_name or not cls_name:
        raise ScenarioFileError(f"{where}: expected \"module:Class\", got \"{spec}\"")
    try:
        if mod_name.endswith(".py"):
            path = (base_dir / mod_name).resolve()
            if not path.is_file():
                raise ScenarioFileError(f"{where}: no such file {path}")
            key = f"podbench_user_method_{path.stem}_{abs(hash(str(path))) % 10**8}"
            module = sys.modules.get(key)
            if module is None:
                s = importlib.util.spec_from_file_location(key, path)
                module = importlib.util.module_from_spec(s)
                sys.modules[key] = module
                s.loader.exec_module(module)
        else:
            module = importlib.import_module(mod_name)
    except ScenarioFileError:
        raise
    except Exception as exc:  # a user's module failing to import is a bad input, not a crash
        raise ScenarioFileError(f"{where}: cannot import \"{mod_name}\": "
                                f"{type(exc).__name__}: {exc}") from None
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise ScenarioFileError(f"{where}: \"{mod_name}\" has no \"{cls_name}\"")
    return cls


def make_adapter(spec, scenario, *, _stack=()):
    """The adapter of a :class:`~podbench.scenarios.MethodSpec` of ``scenario``."""
    where = f"{scenario.path}: method \"{spec.label}\""
    if spec.method in _CLASSES:
        return Adapter(spec.method, spec.n_modes, spec.options)
    if spec.method == "superposition":
        if spec.label in _stack:
            raise ScenarioFileError(f"{where}: superposition parts refer back to themselves")
        parts = [make_adapter(scenario.method(p), scenario, _stack=_stack + (spec.label,))
                 for p in spec.parts]
        return SuperpositionAdapter(parts)
    cls = load_class(spec.method, scenario.folder, where)
    return UserAdapter(cls, spec.n_modes, spec.options, spec.method)


def training_sets(spec, scenario):
    """The training case names of a method (a list per part for a superposition)."""
    if spec.method == "superposition":
        return [training_sets(scenario.method(p), scenario) for p in spec.parts]
    return list(spec.train)


def all_cases(spec, scenario) -> set[str]:
    """Every case a method (or a superposition's parts) trains on."""
    if spec.method == "superposition":
        return set().union(*(all_cases(scenario.method(p), scenario) for p in spec.parts))
    return set(spec.train)
