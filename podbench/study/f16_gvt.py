"""The F-16 ground vibration test study file: ``scenarios/f16_gvt/f16_gvt.toml``.

A study with its own runner (:mod:`podbench.study.own_runner`; data: Noël & Schoukens,
"F-16 aircraft benchmark based on ground vibration test data", Workshop on Nonlinear
System Identification Benchmarks, 2017). Its ``[f16_gvt]`` table names the folder of level
records (``data``: one ``.npz`` per force level, ``*level<N>_*.npz``), the multisine's
``period`` (samples) and ``transient_periods``, the ``input`` (the measured ``force``, or
the generator's ``voltage`` only when asked), the bands' ``coverage``, the ``sets``
(training levels → validation levels) and the ``methods``. This module reads and checks it
and builds the estimators from the method entries (:func:`build_estimator`, the one place
that names the method classes); :mod:`podbench.harness.f16_gvt` runs it and
:mod:`podbench.report.f16_gvt` writes it.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field
from pathlib import Path

from podbench.errors import InputError
from podbench.structures.spec import Table
from podbench.study.own_runner import data_folder, read_runner_table
from podbench.sysid import registry
from podbench.sysid.methods import DMDc, Mdof, OpInf
from podbench.sysid.methods.inputs import LAG_GRID

__all__ = ["F16Plan", "TrainingSet", "MethodEntry", "load_f16_gvt", "build_estimator",
           "EXTRAS", "TABLE", "INPUTS", "ROLES"]

TABLE = "f16_gvt"

INPUTS = ("force", "voltage")
"""What a level's input is: the shaker ``force`` measured by the impedance head (N), or,
only when asked, the signal generator's reference ``voltage`` (V; not the force on the
structure)."""


EXTRAS: dict[type, str] = {DMDc: "pydmd", OpInf: "opinf", Mdof: "mdof"}
"""The Python package a method class needs beyond podbench (the peers' extras)."""


ROLES = ("benchmark", "extension")
"""A set's role: one of the benchmark's pairs and joint sets (the targets are judged on
them), or an extension of the study (reported beside them)."""


@dataclass(frozen=True)
class TrainingSet:
    """Training force levels, the validation levels they predict (level numbers), the
    labels of the methods run on them (None: every method) and the set's role
    (:data:`ROLES`)."""

    train: tuple[int, ...]
    targets: tuple[int, ...]
    methods: tuple[str, ...] | None = None
    role: str = "benchmark"


@dataclass(frozen=True)
class MethodEntry:
    """One row label of the tables: the ``method`` (a name of the method registry,
    :mod:`podbench.sysid.registry`), its ``options`` (constructor keywords), whether its
    predictions get ``bands`` and a ``note``."""

    label: str
    method: str
    options: dict = field(default_factory=dict)
    bands: bool = False
    note: str = ""


@dataclass(frozen=True)
class F16Plan:
    """The checked ``[f16_gvt]`` table (see the module docstring)."""

    name: str
    path: Path
    data: Path
    period: int
    transient_periods: int
    input: str
    coverage: float
    sets: tuple[TrainingSet, ...]
    methods: tuple[MethodEntry, ...]
    figure: tuple[str, tuple[int, ...], int]


def _sets(t: Table, labels) -> tuple[TrainingSet, ...]:
    out = []
    for s in t.tables("sets"):
        train = tuple(s.integers("train", minimum=1))
        targets = tuple(s.integers("targets", minimum=1))
        if len(set(train)) != len(train):
            s.fail("train", f"a level given twice: {list(train)}")
        both = sorted(set(train) & set(targets))
        if both:
            s.fail("targets", f"level {both[0]} is also a training level")
        role = s.string("role", "benchmark", choices=ROLES)
        only = s.strings("methods", None)
        for i, label in enumerate(only or ()):
            if label not in labels:
                s.fail(f"methods[{i}]", f"no method labelled {label!r} (labels: "
                       f"{', '.join(labels)})")
        s.close()
        out.append(TrainingSet(train, targets, None if only is None else tuple(only), role))
    if not out:
        t.fail("sets", "expected at least one set")
    return tuple(out)


def _methods(t: Table, period: int, transient: int) -> tuple[MethodEntry, ...]:
    out = []
    for m in t.tables("methods"):
        label = m.string("label")
        name = m.string("method")
        try:
            registry.lookup(name)
        except InputError as exc:
            m.fail("method", str(exc).splitlines()[0])
        options = m.raw("options", {})
        if not isinstance(options, dict):
            m.fail("options", f"expected a table of keyword arguments, got {options!r}")
        entry = MethodEntry(label, name, dict(options), m.boolean("bands", False),
                            m.string("note", ""))
        try:
            build_estimator(entry, period=period, transient_periods=transient, n_train=2,
                            dt=1.0)
        except (TypeError, InputError) as exc:
            m.fail("options", str(exc).splitlines()[0])
        m.close()
        if any(e.label == label for e in out):
            m.fail("label", f"{label!r} is given twice")
        out.append(entry)
    if not out:
        t.fail("methods", "expected at least one method")
    return tuple(out)


def _figure(t: Table, methods, sets) -> tuple[str, tuple[int, ...], int]:
    f = t.table("figure", required=True)
    label = f.string("method", choices=tuple(e.label for e in methods))
    train = tuple(f.integers("train", minimum=1))
    target = f.integer("target", minimum=1)
    if not any(s.train == train and target in s.targets for s in sets):
        f.fail("train", f"no set trains on {list(train)} and predicts level {target}")
    f.close()
    return label, train, target


def _plan(t: Table, path: Path) -> F16Plan:
    """The plan of the ``[f16_gvt]`` table ``t`` of the study file ``path``."""
    data = data_folder(t, path)
    period = t.integer("period", minimum=2)
    transient = t.integer("transient_periods", 1, minimum=0)
    inp = t.string("input", "force", choices=INPUTS)
    coverage = t.number("coverage", 0.9, above=0.0, below=1.0)
    methods = _methods(t, period, transient)
    sets = _sets(t, [m.label for m in methods])
    figure = _figure(t, methods, sets)
    return F16Plan(name=path.resolve().parent.name, path=path, data=data, period=period,
                   transient_periods=transient, input=inp, coverage=coverage, sets=sets,
                   methods=methods, figure=figure)


def load_f16_gvt(path) -> F16Plan:
    """Read and check the ``[f16_gvt]`` table of a study file.

    Raises
    ------
    ScenarioFileError
        One line naming the file and the field: the table or a field missing or of the
        wrong type, ``data`` not a folder of ``.npz`` records, a method name unknown or
        its options not the class's keywords, a set training on a level it predicts.
    """
    path = Path(path)
    return read_runner_table(path, TABLE, _plan)


def missing_extra(entry: MethodEntry) -> str | None:
    """The Python package a method entry needs and that is not installed, or None."""
    extra = EXTRAS.get(registry.lookup(entry.method).cls)
    if extra is not None and importlib.util.find_spec(extra) is None:
        return extra
    return None


def build_estimator(entry: MethodEntry, *, period: int, transient_periods: int,
                    n_train: int, dt: float):
    """The unfitted estimator of a method entry for a training set of ``n_train`` records
    sampled at ``dt`` (s): the registry's entry built with the entry's options.

    Periodic methods (``inputs="periodic"``) get the table's ``period`` and
    ``transient_periods``. A truncated kernel whose length is chosen by leave-one-record-out
    (``n_lags="auto"``) cannot choose from one training record: it then takes the longest
    of its ``lag_grid`` (:data:`~podbench.sysid.methods.inputs.LAG_GRID`, 2 s), fixed in
    advance — a long memory is what a lightly damped structure needs. Raises TypeError (an
    unknown option) or InputError (a bad value) before any data are read.
    """
    reg = registry.lookup(entry.method)
    options = dict(entry.options)
    if "period" in reg.supplied:
        options.setdefault("period", period)
    est = reg.build(**options)
    params = est.get_params(deep=False)
    if getattr(est, "inputs", None) == "periodic":
        est.set_params(period=period, transient_periods=transient_periods)
    est._validate_params()
    if n_train < 2 and params.get("n_lags", None) == "auto":
        grid = params.get("lag_grid", LAG_GRID)
        est.set_params(n_lags=max(1, int(round(max(grid) / dt))))
    return est
