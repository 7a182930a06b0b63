"""Scenario files: which structures, excitations, training sets, targets and methods a study runs.

A scenario is a TOML file (``scenarios/chapter4/*.toml``); every field is checked and an error
names the file and the dotted field::

    scenarios/chapter4/beam_forced.toml: field `methods[1].train[2]`: unknown case "load9"; ...

Format (units inch, lbf, second)::

    [scenario]
    name = "beam_forced"                 # must equal the file's stem
    title = "Beams, forced response"     # one line, used in tables and figures
    source = "Allison (2007) §4.1.2"     # where the study comes from (free text)
    description = "..."                  # free text
    structures = ["lti_beam", "nl_beam"] # names (structures/ folders) or paths to .toml files
    n_samples = 500                      # samples per record, t_j = j·dt, j = 0 … n−1 (<= 10⁷)
    dt = 1.0e-4                          # s
    engine = "newmark"                   # optional: "newmark" (default) or "exudyn"
    targets = ["load5"]                  # cases every reported method predicts

    [cases.load1]                        # a named excitation; any of the three entries
    description = "..."                  # optional
    force = [{ kind = "pulse", location = 2.0, amplitude = 500.0, duration = 5.0e-4 }]
    # initial_displacement = { kind = "static_displacement", loads = [[24, 100]],
    #                          reference = "lti_beam" }
    # initial_velocity = { kind = "impulse_velocity", impulses = [[19, 1000]],
    #                      duration = 1.0e-4, reference = "lti_beam" }
    # file = "data/load1.npz"            # instead: a measured record (.npz, .mat, .csv, .uff;
    #                                    # relative to this file; podbench.measured)

A case with a ``file`` is read, not simulated; its ``W`` must have the scenario's
``n_samples`` columns and its ``dt`` the scenario's ``dt``. ``structures = ["measured"]``
means no structure at all (every case then needs a ``file``); a structure name with file
cases checks the sensor count (and positions, if the file has them) against the structure.
Either way a unit with a measured case has no linear twin: its linearization columns are NaN.

    [[methods]]
    label = "SL"                         # name in the tables (unique)
    method = "SL"                        # POVR, MDS, SL, ML, MR, superposition or module:Class
    n_modes = 4                          # optional (method default otherwise)
    train = ["load1"]                    # training cases, in order (the first gives the POMs)
    options = { solver = "ls" }          # optional constructor keywords of the method
    twin = "ML"                          # optional: label of the coupled twin
    report = true                        # optional: false = used only as another's twin

    [sweep]                              # optional: axes of `podbench sweep` (ignored by run)
    noise = [0.0, 0.01, 0.05]            # relative noise levels (default [0.0])
    n_modes = [3, 4]                     # k for every method (default: each method's own)
    seeds = [0, 1, 2]                    # noise seeds (default [0])
    solvers = ["ls", "tls"]              # deconvolution solvers (default: each method's own);
                                         # or tables {solver = "tls", options = {rcond = 1e-2},
                                         #            label = "tls-1e-2"}
    noise_on = ["W", "F"]                # training quantities that get noise (W, F, w0, v0)
    noise_model = "per_channel"          # or "per_entry_rms" (the former model; podbench.noise)
    # snr_db = [40, 26]                  # instead of `noise`: sensor SNR in dB (40 dB = 1 %)
    force_offset = 0.0                   # measured-force offset, relative to the channel peak
    force_drift = 0.0                    # measured-force linear drift at the record's end, same
    coupled_train = "first"              # MDS/ML with k modes: "first" k training cases or "all"

    [conditioning]                       # optional: signal conditioning of every training
    detrend = "linear"                   # record (podbench.conditioning): "mean" / "linear"
    force_window = { pre = 1e-4, post = 2e-3 }     # s around each detected impact
    exponential_window = { tau = 0.05 }  # s; the prediction is corrected (un-windowed)
    # threshold = 0.05, noise_factor = 5.0, min_pretrigger = 8   (impact detection)

The excitation tables are those of :func:`podbench.excitations.excitation_from_dict`;
``force`` is one table or an array of tables (summed). A ``reference`` names a structure of
the scenario's ``structures`` list or any other loadable structure (the beams' profiles are
computed on ``lti_beam``, §4.1.1).

The ``[sweep]`` table is read by ``podbench sweep`` (:mod:`podbench.harness.sweep`, which
defines the noise model and the meaning of each axis); :func:`apply_overrides` derives the
scenario of one sweep point.

A ``claims.toml`` file in a scenario folder is not a scenario: it holds the dissertation's
claims that ``podbench run`` checks against the measured table (see
:mod:`podbench.study.claims`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from podbench.core.hints import noise_level_hint
from podbench.core.resources import display_path as _display
from podbench.core.resources import unique_paths
from podbench.core.tomlfile import load_toml
from podbench.errors import InputError, ScenarioFileError, StructureFileError
from podbench.structures.spec import MISSING, Table
from podbench.study.estimators import (
    build_estimator,
    check_method_entry,
    method_entry,
    option_names,
    solver_hint,
    solver_options_hint,
)
from podbench.study.own_runner import read_requires
from podbench.sysid import registry
from podbench.sysid.conditioning import DETREND_KINDS, Conditioning
from podbench.sysid.deconvolution import current_name, make_solver
from podbench.sysid.noise import NOISE_MODELS, level_from_snr_db

__all__ = [
    "Scenario",
    "Case",
    "MethodSpec",
    "Sweep",
    "SolverChoice",
    "Variant",
    "load_scenario",
    "apply_overrides",
    "method_solver",
    "find_scenarios",
    "BUILTIN_METHODS",
    "CLAIMS_FILE",
]

BUILTIN_METHODS = tuple(registry.names())
"""Method names a scenario may use without a ``module:Class`` path
(:mod:`podbench.sysid.registry`)."""

CLAIMS_FILE = "claims.toml"
EXPERIMENT_FILE = "experiment.toml"
"""A study folder's virtual-experiment file (:mod:`podbench.experiments`), not a scenario."""
NOT_SCENARIOS = (CLAIMS_FILE, EXPERIMENT_FILE)
MAX_SAMPLES = 10_000_000
"""Largest ``scenario.n_samples`` (a record of 10⁷ samples on 48 sensors is 3.8 GB per
matrix): a larger value is a typo, refused before anything is allocated."""
_EXCITATION_KEYS = ("initial_displacement", "initial_velocity", "force")
_EXCITATION_KINDS = {"initial_displacement": ("static_displacement",),
                     "initial_velocity": ("impulse_velocity",),
                     "force": ("pulse", "force_history", "combined")}
ENGINES = ("newmark", "exudyn")
NOISE_QUANTITIES = ("W", "F", "w0", "v0")
"""Training quantities a sweep may add noise to (displacements, forces, initial profiles)."""
COUPLED_TRAIN = ("first", "all")


@dataclass(frozen=True)
class Case:
    """A named excitation: initial displacement, initial velocity and/or force (dicts)."""

    name: str
    initial_displacement: dict | None = None
    initial_velocity: dict | None = None
    force: tuple[dict, ...] = ()
    description: str = ""
    force_fields: tuple[str, ...] = ()
    """Field of each force inside the case's table: ``force`` (one table) or ``force[i]``."""
    file: str | None = None
    """A measured record (path relative to the scenario file, :mod:`podbench.measured`)
    instead of excitations: the case is read, not simulated."""

    def excitation_fields(self) -> list[tuple[str, dict]]:
        """``(field, table)`` of every excitation, the field relative to ``cases.<name>``."""
        out = [(k, getattr(self, k)) for k in ("initial_displacement", "initial_velocity")
               if getattr(self, k) is not None]
        names = self.force_fields or tuple(f"force[{i}]" for i in range(len(self.force)))
        return out + list(zip(names, self.force, strict=True))

    def spec(self) -> dict:
        """A JSON-able description (used in cache keys)."""
        out: dict[str, object] = {
            "initial_displacement": self.initial_displacement,
            "initial_velocity": self.initial_velocity,
            "force": list(self.force),
        }
        if self.file is not None:
            out["file"] = self.file
        return out


@dataclass(frozen=True)
class MethodSpec:
    """One ``[[methods]]`` entry."""

    label: str
    method: str
    train: tuple[str, ...]
    n_modes: int | None = None
    options: dict = field(default_factory=dict)
    twin: str | None = None
    report: bool = True
    parts: tuple[str, ...] = ()
    composite: bool = False
    """Whether the method is a sum of other entries (``parts``; the registry's trait)."""
    base_label: str = ""
    """The label in the scenario file when a sweep renamed this entry (else "")."""
    solver_label: str = ""
    """The sweep's solver label this entry was expanded for (else "")."""


@dataclass(frozen=True)
class Variant:
    """A ``[variants.<name>]`` table: the structure ``structure`` with the dotted fields of
    ``set`` replaced (e.g. ``{"tip_mass.mean": 0.1}``), named ``name`` in the tables."""

    name: str
    structure: str
    set: dict = field(default_factory=dict)
    description: str = ""


@dataclass(frozen=True)
class SolverChoice:
    """One entry of ``sweep.solvers``: a solver name, its options and the label shown."""

    label: str
    solver: str
    options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Sweep:
    """The ``[sweep]`` table: axes of ``podbench sweep`` (see :mod:`podbench.harness.sweep`).

    ``n_modes`` and ``solvers`` are None when the table leaves the methods' own values.
    """

    noise: tuple[float, ...] = (0.0,)
    n_modes: tuple[int, ...] | None = None
    seeds: tuple[int, ...] = (0,)
    solvers: tuple[SolverChoice, ...] | None = None
    noise_on: tuple[str, ...] = ("W", "F")
    coupled_train: str = "first"
    noise_model: str = "per_channel"
    force_offset: float = 0.0
    force_drift: float = 0.0


@dataclass(frozen=True)
class Scenario:
    """A validated scenario file."""

    name: str
    title: str
    source: str
    description: str
    structures: tuple[str, ...]
    n_samples: int
    dt: float
    engine: str
    targets: tuple[str, ...]
    cases: dict
    methods: tuple[MethodSpec, ...]
    path: Path
    digest: str
    sweep: Sweep | None = None
    variants: dict = field(default_factory=dict)
    """``name -> Variant``: structures of this scenario built from a structure file with some
    of its fields replaced (``[variants.<name>]``)."""
    base: Path | None = None
    """The scenario file this one inherits from (``scenario.base``), or None."""
    conditioning: object = None
    """The ``[conditioning]`` table (:class:`podbench.conditioning.Conditioning`) or None."""
    training_noise: float = 0.0
    """``scenario.training_noise``: per-channel measurement noise (relative std, 0.01 = 1 %
    of each channel's RMS, seed 0, on W and F; :class:`podbench.noise.NoiseSpec`) added to
    every training record of ``podbench run`` (targets stay noise-free)."""
    requires: tuple[str, ...] = ()
    """``scenario.requires``: the extras of podbench its committed tables need (checked
    installed when run, :func:`podbench.study.own_runner.check_requires`)."""

    @property
    def folder(self) -> Path:
        return self.path.parent

    def method(self, label: str) -> MethodSpec:
        for m in self.methods:
            if m.label == label:
                return m
        raise KeyError(label)

    def reported_methods(self) -> tuple[MethodSpec, ...]:
        return tuple(m for m in self.methods if m.report)


def read_excitation(t: Table, key: str, *, many: bool):
    value = t.raw(key, None)
    if value is None:
        return () if many else None
    items = value if (many and isinstance(value, list)) else [value]
    if many and isinstance(value, list) and not value:
        t.fail(key, "expected a force table or a non-empty array of force tables")
    out = []
    for i, item in enumerate(items):
        where = f"{key}[{i}]" if (many and isinstance(value, list)) else key
        if not isinstance(item, dict):
            t.fail(where, f"expected an excitation table with a `kind`, got {item!r}")
        if "kind" not in item or not isinstance(item["kind"], str):
            t.fail(where, "the excitation table needs a `kind` string (static_displacement, "
                          "impulse_velocity, pulse, force_history, combined)")
        kinds = _EXCITATION_KINDS[key]
        if item["kind"] not in kinds:
            t.fail(f"{where}.kind", f'expected {" or ".join(map(repr, kinds))} for `{key}`, '
                                    f'got "{item["kind"]}"')
        out.append(dict(item))
    return tuple(out) if many else out[0]


def load_scenario(path, *, _stack: tuple = ()) -> Scenario:
    """Read and validate one scenario file (and the file it inherits from, ``base``).

    Raises
    ------
    ScenarioFileError
        Missing file, TOML syntax error, a missing/misspelt/ill-typed field, an unknown case
        or method label, a twin that does not exist. The message names the file and field.
    """
    path = Path(path)
    shown = _display(path)
    raw, doc = read_study_file(path, shown, "scenario")
    try:
        return _parse(doc, path, shown, hashlib.sha256(raw).hexdigest(), _stack)
    except StructureFileError as exc:  # Table raises StructureFileError; re-badge it
        raise ScenarioFileError(str(exc)) from None


def read_study_file(path: Path, shown: str, what: str) -> tuple[bytes, dict]:
    """The bytes of a study's TOML file (a scenario, an experiment) and its parsed table.

    Raises
    ------
    ScenarioFileError
        ``<shown>: no such <what> file``, a TOML syntax error, text that is not UTF-8, a file
        that cannot be read.
    """
    if not path.is_file():
        raise ScenarioFileError(f"{shown}: no such {what} file")
    return load_toml(path, shown, ScenarioFileError)


def _load_base(sc: Table, path: Path, rel: str, stack: tuple) -> Scenario:
    """The scenario ``rel`` (relative to ``path``) that ``path`` inherits from."""
    base_path = (path.parent / rel).resolve()
    if base_path in stack or base_path == path.resolve():
        sc.fail("base", f'"{rel}" inherits back from this file (a cycle)')
    if not base_path.is_file():
        sc.fail("base", f'no such scenario file "{rel}" (relative to this file)')
    try:
        return load_scenario(base_path, _stack=stack + (path.resolve(),))
    except ScenarioFileError as exc:
        sc.fail("base", f"the inherited scenario is not usable: {exc}")


def _parse(doc: dict, path: Path, shown: str, digest: str, stack: tuple = ()) -> Scenario:
    top = Table(doc, file=shown)
    sc = top.table("scenario", required=True)
    name = sc.string("name")
    if name != path.stem:
        sc.fail("name", f'"{name}" does not match the file name "{path.name}"')
    base_rel = sc.string("base", None)
    base = None if base_rel is None else _load_base(sc, path, base_rel, stack)
    head = _parse_header(sc, base)
    variants = {**(base.variants if base is not None else {}),
                **_parse_variants(top, head["structures"])}
    if base is not None:
        digest = hashlib.sha256((digest + base.digest).encode("ascii")).hexdigest()
    cases = _parse_cases(top, base)
    for i, tname in enumerate(head["targets"]):
        _check_case(sc, f"targets[{i}]", tname, cases)
    methods = _parse_methods(top, base, cases)
    _check_method_labels(top, methods)
    _check_method_options(top, methods, path.parent)
    sweep_t = top.table("sweep")
    sweep = (base.sweep if base is not None else None) if sweep_t is None \
        else _parse_sweep(sweep_t, path.parent)
    cond_t = top.table("conditioning")
    conditioning = (base.conditioning if base is not None else None) if cond_t is None \
        else _parse_conditioning(cond_t)
    top.close()
    return Scenario(
        name=name, **head, cases=cases, methods=tuple(methods), path=path.resolve(),
        digest=digest, sweep=sweep, variants=variants,
        base=None if base is None else base.path, conditioning=conditioning,
    )


def _parse_header(sc: Table, base: Scenario | None) -> dict[str, Any]:
    """The fields of the ``[scenario]`` table after ``name`` and ``base`` (a field left out
    is inherited from ``base``), checked; closes the table."""

    def inherited(attr):
        return MISSING if base is None else getattr(base, attr)

    title = sc.string("title", inherited("title"))
    source = sc.string("source", "" if base is None else base.source)
    description = sc.string("description", "" if base is None else base.description,
                            nonempty=False)
    structures = sc.strings("structures", MISSING if base is None else list(base.structures))
    if not structures:
        sc.fail("structures", "expected at least one structure")
    if len(set(structures)) != len(structures):
        sc.fail("structures", f"a structure is listed twice: {structures}")
    n_samples = sc.integer("n_samples", inherited("n_samples"), minimum=2, maximum=MAX_SAMPLES)
    dt = sc.number("dt", inherited("dt"), positive=True)
    if not math.isfinite(n_samples * dt * 1e6):  # room for products like ω²·t² downstream
        sc.fail("dt", f"{dt!r} s times n_samples = {n_samples} is not a finite record length")
    engine = sc.string("engine", "newmark" if base is None else base.engine, choices=ENGINES)
    targets = sc.strings("targets", MISSING if base is None else list(base.targets))
    if not targets:
        sc.fail("targets", "expected at least one target case")
    training_noise = sc.number("training_noise", 0.0 if base is None else base.training_noise,
                               nonnegative=True)
    if training_noise > 1:  # std = level × the channel's RMS: 5 is 500 %
        sc.fail("training_noise", f"expected a level in [0, 1] (std = level × each channel's "
                f"RMS), got {training_noise:g}{noise_level_hint(training_noise)}")
    requires = read_requires(sc, () if base is None else base.requires)
    sc.close()
    return {"title": title, "source": source, "description": description.strip(),
            "structures": tuple(structures), "n_samples": n_samples, "dt": dt,
            "engine": engine, "targets": tuple(targets), "training_noise": training_noise,
            "requires": requires}


def _parse_cases(top: Table, base: Scenario | None) -> dict[str, Case]:
    """The ``[cases.<name>]`` tables, added to (or replacing) those of ``base``."""
    cases_t = top.table("cases", required=base is None)
    cases = {} if base is None else dict(base.cases)
    if cases_t is not None:
        for cname in list(cases_t.data):
            cases[cname] = _parse_case(cases_t.table(cname, required=True), cname)
        cases_t.close()
    return cases


def _parse_case(ct: Table, cname: str) -> Case:
    force = read_excitation(ct, "force", many=True)
    case = Case(
        name=cname,
        initial_displacement=read_excitation(ct, "initial_displacement", many=False),
        initial_velocity=read_excitation(ct, "initial_velocity", many=False),
        force=force,
        description=ct.string("description", "", nonempty=False),
        force_fields=tuple(f"force[{i}]" if isinstance(ct.data["force"], list) else "force"
                           for i in range(len(force))),
        file=ct.string("file", None),
    )
    excited = not (case.initial_displacement is None and case.initial_velocity is None
                   and not case.force)
    if case.file is not None and excited:
        ct.fail("file", "a case is either a measured record (`file`) or excitations "
                        "(" + ", ".join(_EXCITATION_KEYS) + "), not both")
    if case.file is None and not excited:
        ct.fail(None, "a case needs at least one of " + ", ".join(_EXCITATION_KEYS)
                + " (or a measured record: `file`)")
    ct.close()
    return case


def _check_case(t: Table, key: str, cname: str, cases: dict) -> None:
    if cname not in cases:
        t.fail(key, f'unknown case "{cname}"; the file defines: {", ".join(cases)}')


def _parse_methods(top: Table, base: Scenario | None, cases: dict) -> list[MethodSpec]:
    """The ``[[methods]]`` entries, or those of ``base`` (their cases checked against ours)."""
    methods: list[MethodSpec] = []
    mtables = top.tables("methods", [] if base is not None else MISSING)
    if not mtables and base is None:
        top.fail("methods", "expected at least one [[methods]] entry")
    if not mtables and base is not None:  # inherited, their cases checked against ours
        methods = list(base.methods)
        for i, m in enumerate(methods):
            for j, c in enumerate(m.train):
                _check_case(top, f"methods[{i}].train[{j}] (inherited)", c, cases)
    for mt in mtables:
        methods.append(_parse_method(mt, cases))
    return methods


def _parse_method(mt: Table, cases: dict) -> MethodSpec:
    label = mt.string("label")
    method = mt.string("method")
    composite, per_mode = False, False
    if not registry.is_user_method(method):
        try:
            entry = registry.lookup(method)
        except InputError as exc:
            mt.fail("method", str(exc))
        method, composite = entry.name, bool(entry.cls.composite)
        per_mode = bool(getattr(entry.cls, "records_per_mode", False))
    parts: tuple[str, ...] = ()
    if composite:
        parts = tuple(mt.strings("parts"))
        train: tuple[str, ...] = ()
    else:
        train = tuple(mt.strings("train"))
        if not train:
            mt.fail("train", "expected at least one training case")
        for j, c in enumerate(train):
            _check_case(mt, f"train[{j}]", c, cases)
    n_modes = mt.integer("n_modes", None, minimum=1)
    if per_mode and n_modes is not None and n_modes > len(train):  # known before any fit
        mt.fail("n_modes", f"{n_modes} modes from {len(train)} training cases: {method} "
                "identifies a k × k matrix from its training cases (Eqs. 3.26, 3.48), so "
                f"k ≤ {len(train)}")
    options = mt.raw("options", {})
    if not isinstance(options, dict):
        mt.fail("options", f"expected a table of keyword arguments, got {options!r}")
    options = dict(options)
    if isinstance(options.get("solver"), str):  # a former solver name: its new one (warns)
        options["solver"] = current_name(options["solver"])
    twin = mt.string("twin", None)
    report = mt.boolean("report", True)
    mt.close()
    return MethodSpec(label=label, method=method, train=train, n_modes=n_modes,
                      options=dict(options), twin=twin, report=report, parts=parts,
                      composite=composite)


def _check_method_labels(top: Table, methods: list[MethodSpec]) -> None:
    """Labels unique; every twin and part an existing label (a part not a superposition);
    at least one reported method."""
    labels = [m.label for m in methods]
    for i, m in enumerate(methods):
        if m.label in labels[:i]:
            top.fail(f"methods[{i}].label", f'label "{m.label}" is used twice')
    for i, m in enumerate(methods):
        where = f"methods[{i}]"
        if m.twin is not None and m.twin not in labels:
            top.fail(f"{where}.twin",
                     f'unknown method label "{m.twin}"; labels: {", ".join(labels)}')
        if m.twin == m.label:
            top.fail(f"{where}.twin", "a method cannot be its own twin (leave `twin` out)")
        for j, p in enumerate(m.parts):
            if p not in labels or p == m.label:
                top.fail(f"{where}.parts[{j}]", f'unknown method label "{p}"; labels: '
                                                f'{", ".join(x for x in labels if x != m.label)}')
            if methods[labels.index(p)].composite:
                top.fail(f"{where}.parts[{j}]", f'"{p}" is itself a superposition; list its '
                                                "parts instead")
    if not any(m.report for m in methods):
        top.fail("methods", "every method has report = false: nothing would be tabulated")


def _parse_variants(top: Table, structures) -> dict:
    """The ``[variants.<name>]`` tables: ``structure`` (a name or path), ``set`` (dotted
    field → value; every field must exist in that file, checked when it is loaded),
    ``description``. A variant's name may be listed in ``scenario.structures``."""
    vt = top.table("variants")
    out: dict[str, Variant] = {}
    if vt is None:
        return out
    for vname in list(vt.data):
        t = vt.table(vname, required=True)
        structure = t.string("structure")
        values = t.raw("set")
        if not isinstance(values, dict) or not values:
            t.fail("set", f"expected a table of dotted fields and values, got {values!r}")
        for key, value in values.items():
            if isinstance(value, dict):
                t.fail(f"set.{key}", 'write nested fields as one dotted key in quotes, e.g. '
                                     '"tip_mass.mean" = 0.1')
        description = t.string("description", "", nonempty=False)
        t.close()
        out[vname] = Variant(name=vname, structure=structure, set=dict(values),
                             description=description)
    vt.close()
    return out


def _check_method_options(top: Table, methods, folder: Path) -> None:
    """Bind every entry's ``options`` (and ``n_modes``) to its class's constructor and
    validate the values, before any simulation: the class is imported, an unknown option,
    a bad value or a missing user file fails naming ``methods[i].<field>``."""

    by_label = {m.label: m for m in methods}
    for i, m in enumerate(methods):
        problem = check_method_entry(m, by_label.__getitem__, folder)
        if problem is not None:
            field, message = problem
            if m.composite:
                field = "parts"
            top.fail(f"methods[{i}].{field}", message)


def _method_entry(spec: MethodSpec, scenario: Scenario):
    """The registry entry of an entry's method (a user's class too)."""
    return method_entry(spec.method, scenario.folder)


def _unique(t: Table, key: str, values) -> None:
    seen = []
    for v in values:
        if v in seen:
            t.fail(key, f"{v!r} is listed twice")
        seen.append(v)


def _parse_sweep(t: Table, folder: Path) -> Sweep:

    noise = _sweep_noise(t)
    _unique(t, "noise", noise)
    noise_model = t.string("noise_model", "per_channel", choices=NOISE_MODELS)
    force_offset = t.number("force_offset", 0.0)
    force_drift = t.number("force_drift", 0.0)
    modes = t.integers("n_modes", None, minimum=1)
    if modes is not None:
        _unique(t, "n_modes", modes)
    n_modes = None if modes is None else tuple(modes)
    seeds = tuple(t.integers("seeds", [0], minimum=0))
    _unique(t, "seeds", seeds)
    noise_on = t.strings("noise_on", ["W", "F"])
    if not noise_on:
        t.fail("noise_on", f"expected a non-empty array of {', '.join(NOISE_QUANTITIES)}")
    for i, q in enumerate(noise_on):
        if q not in NOISE_QUANTITIES:
            t.fail(f"noise_on[{i}]", f'unknown quantity "{q}"; expected one of '
                                     f'{", ".join(NOISE_QUANTITIES)}')
    _unique(t, "noise_on", noise_on)
    coupled_train = t.string("coupled_train", "first", choices=COUPLED_TRAIN)
    solvers = _sweep_solvers(t, folder)
    t.close()
    return Sweep(noise=noise, n_modes=n_modes, seeds=seeds, solvers=solvers,
                 noise_on=tuple(noise_on), coupled_train=coupled_train,
                 noise_model=noise_model, force_offset=force_offset, force_drift=force_drift)


def _sweep_noise(t: Table) -> tuple[float, ...]:
    """The noise levels of a ``[sweep]`` table: ``noise``, or ``snr_db`` converted."""
    if "snr_db" not in t.data:
        levels = tuple(t.numbers("noise", [0.0], nonnegative=True))
        for i, x in enumerate(levels):
            if x > 1:  # std = level × the channel's RMS: 5 is 500 %
                t.fail(f"noise[{i}]", f"expected a level in [0, 1] (std = level × each "
                       f"channel's RMS), got {x:g}{noise_level_hint(x)}")
        return levels
    if "noise" in t.data:
        t.fail("snr_db", "give the noise levels either as `noise` or as `snr_db`, not both")
    snr = t.numbers("snr_db", None)
    if not snr:
        t.fail("snr_db", "expected a non-empty array of SNRs in dB")
    _unique(t, "snr_db", snr)
    if any(not math.isfinite(x) for x in snr):
        t.fail("snr_db", f"expected finite numbers of dB, got {snr}")
    return tuple(level_from_snr_db(x) for x in snr)


def _sweep_solvers(t: Table, folder: Path) -> tuple[SolverChoice, ...] | None:
    """``sweep.solvers``: names or ``{solver, options, label}`` tables, each bound to its
    solver's constructor now, before any simulation; None when the table has none."""
    raw = t.raw("solvers", None)
    if raw is None:
        return None
    if not isinstance(raw, list) or not raw:
        t.fail("solvers", f"expected a non-empty array of solver names or tables, got {raw!r}")
    solvers = [_solver_choice(t, f"solvers[{i}]", item, folder) for i, item in enumerate(raw)]
    _unique(t, "solvers (labels)", [c.label for c in solvers])
    return tuple(solvers)


def _solver_choice(t: Table, where: str, item, folder: Path) -> SolverChoice:
    if isinstance(item, str):
        name = current_name(item)  # a former name: its new one (warns), shown as that
        options, label = {}, name
    elif isinstance(item, dict):
        st = Table(item, file=t.file, prefix=t.field(where))
        name = current_name(st.string("solver"))
        options = st.raw("options", {})
        if not isinstance(options, dict):
            st.fail("options", f"expected a table of solver keyword options, got "
                               f"{options!r}")
        label = st.string("label", name)
        st.close()
    else:
        t.fail(where, f"expected a solver name or a table with `solver`, got {item!r}")
    try:  # bound to the solver's constructor now, before any simulation
        make_solver(name, options, base_dir=folder)
    except InputError as exc:
        t.fail(where, " ".join(str(exc).split()) + solver_hint(name)
               + solver_options_hint(name, options))
    return SolverChoice(label=label, solver=name, options=dict(options))


def _parse_conditioning(t: Table):
    """The ``[conditioning]`` table (:mod:`podbench.conditioning`)."""

    kw = {}
    if t.has("detrend"):
        kw["detrend"] = t.string("detrend", choices=DETREND_KINDS)
    fw = t.table("force_window")
    if fw is not None:
        kw["force_window"] = (fw.number("pre", 0.0, nonnegative=True),
                              fw.number("post", nonnegative=True))
        fw.close()
    ew = t.table("exponential_window")
    if ew is not None:
        kw["exponential_window"] = ew.number("tau", positive=True)
        ew.close()
    kw["threshold"] = t.number("threshold", 0.05, positive=True)
    kw["noise_factor"] = t.number("noise_factor", 5.0, nonnegative=True)
    kw["min_pretrigger"] = t.integer("min_pretrigger", 8, minimum=1)
    t.close()
    return Conditioning(**kw)


def _takes_option(spec: MethodSpec, scenario: Scenario, name: str) -> bool:
    """True if the entry's class has a constructor option ``name``."""

    return name in option_names(_method_entry(spec, scenario).cls)[0]


def _uses_solver(spec: MethodSpec, scenario: Scenario) -> bool:
    """True for an entry that deconvolves (its class takes a ``solver`` option), or a
    superposition with such a part."""
    if spec.composite:
        return any(_uses_solver(scenario.method(p), scenario) for p in spec.parts)
    return _takes_option(spec, scenario, "solver")


def method_solver(spec: MethodSpec, scenario: Scenario) -> str:
    """The solver label a method runs with: the sweep's label if the entry was expanded for
    one, else its ``options.solver`` (or its class's default) for a class that takes a
    ``solver`` option (SL, ML, MR), "" for one that does not deconvolve (POVR, MDS; a
    superposition shows its parts')."""
    if spec.solver_label:
        return spec.solver_label
    if spec.composite:
        names = [method_solver(scenario.method(p), scenario) for p in spec.parts]
        names = list(dict.fromkeys(n for n in names if n))
        return "+".join(names)
    if _uses_solver(spec, scenario):
        solver = spec.options.get("solver")
        if solver is None:  # the configuration's, else the class's default
            entry = _method_entry(spec, scenario)
            solver = entry.params.get(
                "solver", inspect.signature(entry.cls).parameters["solver"].default)
        return str(getattr(solver, "name", solver))
    return ""


def apply_overrides(scenario: Scenario, *, n_modes: int | None = None, solvers=None,
                    coupled_train: str = "first") -> Scenario:
    """The scenario of one sweep point.

    ``n_modes`` (k) replaces every method's ``n_modes`` (a superposition's parts included;
    a user's class receives it as the ``n_modes=`` keyword). MDS and ML identify a k × k
    matrix from their training sets (Eqs. 3.26, 3.48), so k is tied to the number of sets:
    with ``coupled_train = "first"`` they train on their first k cases (the square system of
    the dissertation; fewer than k cases is refused before any work by
    :func:`podbench.harness.runner.check_modes`), with
    ``"all"`` on all of them (a least-squares fit when there are more cases than modes).

    ``solvers`` (a sequence of :class:`SolverChoice`) expands every method that deconvolves
    (SL, ML, MR, and a superposition with such a part) into one entry per solver, labelled
    ``"<label> [<solver label>]"`` with ``base_label`` and ``solver_label`` set; the
    ``solver`` option is replaced and ``solver_options`` replaced by the choice's options.
    Twins and parts follow their own solver. Other methods are kept once.
    """
    methods = list(scenario.methods)
    if n_modes is not None:
        out = []
        for m in methods:
            if m.composite:
                out.append(m)
                continue
            train = m.train
            per_mode = getattr(build_estimator(m, scenario.method, scenario.folder),
                               "records_per_mode", False)
            if per_mode and coupled_train == "first" and len(train) >= n_modes:
                train = train[:n_modes]
            out.append(dataclasses.replace(m, n_modes=n_modes, train=train))
        methods = out
    if solvers:
        current = dataclasses.replace(scenario, methods=tuple(methods))
        uses = {m.label: _uses_solver(m, current) for m in methods}

        def renamed(label: str, choice: SolverChoice) -> str:
            return f"{label} [{choice.label}]" if uses[label] else label

        out = []
        for m in methods:
            if not uses[m.label]:
                out.append(m)
                continue
            for c in solvers:
                opts = dict(m.options)
                if not m.composite:
                    opts["solver"] = c.solver
                    opts.pop("solver_options", None)
                    if c.options:
                        opts["solver_options"] = dict(c.options)
                out.append(dataclasses.replace(
                    m, label=renamed(m.label, c), options=opts,
                    twin=None if m.twin is None else renamed(m.twin, c),
                    parts=tuple(renamed(p, c) for p in m.parts),
                    base_label=m.base_label or m.label, solver_label=c.label))
        labels = [m.label for m in out]
        if len(set(labels)) != len(labels):
            raise ScenarioFileError(f"{_display(scenario.path)}: the solver labels make two "
                                    f"method labels equal: {labels}")
        methods = out
    return dataclasses.replace(scenario, methods=tuple(methods))


def find_scenarios(paths) -> list[Path]:
    """Scenario files of ``paths`` (files, or folders scanned for ``*.toml`` except
    ``claims.toml`` and ``experiment.toml``), sorted and without duplicates.

    Raises
    ------
    ScenarioFileError
        A path that does not exist, a folder without scenario files, a non-TOML file.
    """
    found: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            files = sorted(f for f in p.glob("*.toml") if f.name not in NOT_SCENARIOS)
            if not files:
                raise ScenarioFileError(f"{_display(p)}: no scenario files (*.toml) in this folder")
            found.extend(files)
        elif p.is_file():
            if p.suffix != ".toml":
                raise ScenarioFileError(f"{_display(p)}: a scenario file must end in .toml")
            found.append(p)
        else:
            raise ScenarioFileError(f"{_display(p)}: no such file or folder")
    return unique_paths(found)


def canonical_json(obj) -> str:
    """Deterministic JSON (sorted keys) used to build cache keys."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)
