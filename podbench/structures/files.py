"""Declarative structure files: ``structures/<name>.toml`` → :class:`Structure`.

A structure file is a TOML document with four common top-level fields and the tables of its
``kind``::

    # Units: inch, lbf, second (mass lbf·s²/in, stiffness lbf/in)
    name = "lti_beam"                # must equal the file's stem
    kind = "cantilever_beam"         # which builder (see KINDS)
    units = "inch, lbf, second"      # or "m, N, second" (SI); every number in that system
    description = "..."              # the model, its source section, every choice made

    [beam]
    ...

Kinds (see ``docs/structures.md`` for every field):

``cantilever_beam``  §4.1 and §5 beams: ``[beam]`` (optional ``sensors``), optional
                     ``[tip_mass]``, ``[tip_spring]``, ``[tip_dashpot]``, ``[tip_band]`` (the
                     §5.2 rubber band), ``[damping]``
                     (:func:`podbench.fem.beam.cantilever_beam`)
``satellite_truss``  §4.2 truss: ``[truss]`` with ``[truss.longeron|batten|diagonal]``,
                     optional ``[fracture]`` (:func:`podbench.fem.truss.satellite_truss`)
``chain``            spring–mass chain: ``[chain]``, optional ``[damping]``
                     (:func:`podbench.fem.chain.chain`)
``matrices``         a user's own M, K (C) from .npz/.mat/.mtx/.npy files: ``[matrices]``
``python``           ``builder = "module:function"`` (optional ``path = "file.py"`` relative
                     to the structure file; :mod:`podbench.core.userimport`) called with
                     ``[parameters]`` as keyword arguments

This module reads fields and calls builders; the physics (section stiffness, tip stiffness,
beam mass, tip-mass laws, the cubic spring matched to the tip stiffness, spring counts)
lives in the builder modules ``beam.py``, ``truss.py``, ``chain.py`` and ``laws.py``.

Every malformed file raises one :class:`~podbench.errors.StructureFileError` naming the file
and the field; unknown fields are rejected. Nothing is unpickled.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

from podbench.core.hints import did_you_mean
from podbench.core.resources import bundled_structures, unique_paths
from podbench.core.tomlfile import load_toml
from podbench.core.userimport import UserImportError, import_module_or_file
from podbench.errors import InputError, StructureFileError, UnknownNameError
from podbench.structures.beam import (
    MODAL_DAMPING_MAX_DOFS,
    cantilever_beam,
    density_from_lbm_per_ft3,
    k3_matching_linear,
    sensor_nodes,
    tip_mass_law,
    tip_stiffness,
)
from podbench.structures.chain import chain, spring_count
from podbench.structures.matrices import (
    check_definite,
    check_matrix,
    from_matrices,
    read_arrays,
    read_matrix,
)
from podbench.structures.spec import Table, fail
from podbench.structures.structure import Structure
from podbench.structures.truss import TubeSection, satellite_truss

__all__ = [
    "UNITS",
    "KINDS",
    "SpecContext",
    "register_kind",
    "structure_dirs",
    "list_structures",
    "find_structure",
    "load_structure",
    "build_structure",
    "check_structure_matrices",
    "structure_length_unit",
]

#: The dissertation's unit system, the bundled structures' (``units = "inch, lbf, second"``).
UNITS = "inch, lbf, second"
#: SI (``units = "m, N, second"``): lengths m, forces N, masses kg, E Pa, density kg/m³.
UNITS_SI = "m, N, second"

_UNIT_SYSTEMS = {"inch lbf second": (UNITS, "inch-lbf"), "in lbf s": (UNITS, "inch-lbf"),
                 "in lbf second": (UNITS, "inch-lbf"), "inch lbf s": (UNITS, "inch-lbf"),
                 "m n second": (UNITS_SI, "SI"), "m n s": (UNITS_SI, "SI"),
                 "meter newton second": (UNITS_SI, "SI"), "metre newton second": (UNITS_SI, "SI"),
                 "si": (UNITS_SI, "SI")}
"""A structure file's ``units`` (lower case, commas as spaces) → (the canonical string, the
unit system of :mod:`podbench.core.units`). Every builder is the same physics in any
coherent system, so the numbers are used as written; the only field tied to inch–lbf,
``density_lbm_per_ft3``, is refused in an SI file."""

_ENV = "PODBENCH_STRUCTURES"


@dataclass(frozen=True)
class SpecContext:
    """What a kind's parser knows besides its tables.

    ``file`` is the name shown in messages, ``base_dir`` the folder relative paths in the file
    refer to, ``name``/``description``/``source`` the common top-level fields.
    """

    file: str
    base_dir: Path
    name: str
    description: str
    source: str
    unit_system: str = "inch-lbf"
    """``"inch-lbf"`` or ``"SI"`` (the file's ``units``): the system of every number."""


_Parser = Callable[[Table, SpecContext], Structure]
_KINDS: dict[str, _Parser] = {}
#: Read-only view of the registered kinds (kind name → parser).
KINDS: Mapping[str, _Parser] = MappingProxyType(_KINDS)


def register_kind(kind: str, parser: _Parser | None = None, *, replace_existing=False):
    """Register ``parser(top: Table, ctx: SpecContext) -> Structure`` for ``kind``.

    Usable as a decorator. The parser reads its own tables from ``top`` (the top-level
    :class:`~podbench.structures.spec.Table`; ``name``, ``kind``, ``units`` and ``description`` are
    already read) and must read every field it accepts: the loader rejects the rest.
    """

    def deco(func):
        if kind in _KINDS and not replace_existing:
            raise InputError(f"Parameter `kind`: {kind!r} is already registered")
        _KINDS[kind] = func
        return func

    return deco(parser) if parser is not None else deco


# ---------------------------------------------------------------------------- locating files
def structure_dirs(search_path=None) -> list[Path]:
    """Folders searched for structure names, in order.

    ``search_path`` (a folder or a list of folders), then the folders of the environment
    variable ``PODBENCH_STRUCTURES`` (``os.pathsep``-separated), then the structures
    bundled with podbench (``structures``).
    """
    dirs: list[Path] = []
    if search_path is not None:
        if isinstance(search_path, (str, os.PathLike)):
            search_path = [search_path]
        dirs += [Path(p) for p in search_path]
    env = os.environ.get(_ENV, "")
    dirs += [Path(p) for p in env.split(os.pathsep) if p]
    bundled = bundled_structures()
    if bundled.is_dir():
        dirs.append(bundled)
    return unique_paths(dirs)


def list_structures(search_path=None) -> list[str]:
    """Names of the structure files found (``sub/name`` for files in sub-folders), sorted."""
    names = set()
    for d in structure_dirs(search_path):
        if d.is_dir():
            for p in d.rglob("*.toml"):
                names.add(p.relative_to(d).with_suffix("").as_posix())
    return sorted(names)


def _is_path(name_or_path) -> bool:
    if isinstance(name_or_path, os.PathLike):
        return True
    s = str(name_or_path)
    return s.endswith(".toml") or os.path.isfile(s)


def find_structure(name_or_path, *, search_path=None) -> Path:
    """The file of a structure name (or the given path, checked to exist)."""
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise InputError(
            f"Parameter `name_or_path`: expected a structure name or a path, got {name_or_path!r}"
        )
    if _is_path(name_or_path):
        p = Path(name_or_path)
        if not p.is_file():
            raise StructureFileError(f"{p}: no such structure file")
        return p
    name = str(name_or_path)
    for d in structure_dirs(search_path):
        p = d / f"{name}.toml"
        if p.is_file():
            return p
    available = list_structures(search_path)
    where = ", ".join(str(d) for d in structure_dirs(search_path)) or "no folder"
    raise UnknownNameError(
        f"Unknown structure {name!r}{did_you_mean(name, available)} (searched {where}); "
        f"available: {', '.join(available) if available else 'none'}"
    )


def _display(path: Path) -> str:
    try:
        rel = os.path.relpath(path)
    except ValueError:  # pragma: no cover - different drive on Windows
        return str(path)
    return str(path) if rel.startswith("..") else rel


def load_structure(name_or_path, *, search_path=None, overrides=None,
                   name: str | None = None) -> Structure:
    """Build the structure of a file, given its name (``"lti_beam"``) or its path.

    Parameters
    ----------
    name_or_path : str or path-like
        A bare name (looked up as ``<dir>/<name>.toml`` in :func:`structure_dirs`; names of
        files in sub-folders read ``"examples/my_builder"``) or the path of a ``.toml`` file.
    search_path : path or list of paths, optional
        Folders searched before ``PODBENCH_STRUCTURES`` and the bundled structures.
    overrides : dict, optional
        ``{"tip_mass.mean": 0.1, …}``: dotted fields of the file replaced before the
        structure is built (a variant; every field must exist in the file).
    name : str, optional
        The name of the built structure (default the file's ``name``); a variant's name.

    Raises
    ------
    UnknownNameError
        No file of that name (the message lists the available names).
    StructureFileError
        A malformed file (the message names the file and the field).
    """
    path = find_structure(name_or_path, search_path=search_path)
    shown = _display(path)
    _, spec = load_toml(path, shown, StructureFileError)
    if not overrides:
        structure = build_structure(spec, source=str(path))
    else:
        structure = build_structure(_with_overrides(spec, overrides, shown), source=str(path))
        shown_set = ", ".join(f"{k} = {v!r}" for k, v in overrides.items())
        structure = replace(structure, description=f"{structure.description}\n"
                                                   f"Variant: {shown_set}.")
    if name is not None and name != structure.name:
        structure = replace(structure, name=name)
    return structure


def _with_overrides(spec: dict, overrides: dict, shown: str) -> dict:
    """A copy of ``spec`` with the dotted fields of ``overrides`` replaced; each field must
    exist already (a misspelt field would otherwise be a silent no-op) and keep its type
    family (number for number, string for string, …)."""
    import copy

    out = copy.deepcopy(spec)
    for dotted, value in overrides.items():
        keys = str(dotted).split(".")
        node: Any = out  # a table, until a key leads to a value or to nothing
        for k in keys[:-1]:
            node = node.get(k) if isinstance(node, dict) else None
            if not isinstance(node, dict):
                break
        if not isinstance(node, dict) or keys[-1] not in node:
            raise StructureFileError(f"{shown}: a variant sets `{dotted}`, which this file "
                                     "does not have (only existing fields can be replaced)")
        old = node[keys[-1]]
        number = (int, float)
        same = (isinstance(old, number) and isinstance(value, number)
                and not isinstance(old, bool) and not isinstance(value, bool)) \
            or type(old) is type(value)
        if not same:
            raise StructureFileError(f"{shown}: a variant sets `{dotted}` to {value!r}, but the "
                                     f"file's value {old!r} is of another type")
        node[keys[-1]] = value
    return out


def build_structure(spec: dict, *, source: str = "") -> Structure:
    """Build a :class:`Structure` from an already-parsed structure-file dictionary.

    Parameters
    ----------
    spec : dict
        The parsed TOML document.
    source : str
        Path of the file it came from: names the file in messages, anchors relative paths
        (``matrices`` files, ``python`` builders) and must have the stem ``spec["name"]``.
        ``""`` for a spec built in code (relative paths then refer to the working folder).
    """
    if source:
        src = Path(source)
        shown, base_dir = _display(src), src.resolve().parent
    else:
        shown, base_dir = "<structure spec>", Path.cwd()
    top = Table(spec, file=shown)
    name = top.string("name")
    if source and name != Path(source).stem:
        top.fail("name", f'"{name}" does not match the file name "{Path(source).name}"')
    kind = top.string("kind")
    if kind not in _KINDS:
        top.fail("kind", f'unknown kind "{kind}"; known kinds: {", ".join(sorted(_KINDS))}')
    units, system = _unit_system(top)
    description = top.string("description")
    ctx = SpecContext(file=shown, base_dir=base_dir, name=name, description=description.strip(),
                      source=str(source), unit_system=system)
    try:
        structure = _KINDS[kind](top, ctx)
        if kind not in ("matrices", "python"):  # those check each matrix where it is read
            check_structure_matrices(structure, f"the {kind} built from this file has")
    except StructureFileError:
        raise
    except InputError as exc:
        raise StructureFileError(f"{shown}: {exc}") from exc
    top.close()
    meta = dict(structure.metadata)
    meta["units"], meta["unit_system"] = units, system
    meta.setdefault("kind", kind)
    return replace(structure, name=name, description=ctx.description, source=ctx.source,
                   metadata=meta)


def check_structure_matrices(structure: Structure, label: str) -> None:
    """Check that ``M`` is symmetric positive definite and ``K`` (initially and after every
    stiffness event), ``C`` symmetric positive semi-definite (see
    :func:`podbench.fem.matrices.check_definite`); ``label`` starts the message
    (e.g. ``"the chain built from this file has"``).

    Raises
    ------
    InputError
        ``"<label> K: not positive semi-definite (smallest eigenvalue ...)"``.
    """

    check_definite(structure.M, f"{label} M", semi=False)
    check_definite(structure.K, f"{label} K", semi=True)
    if structure.events:
        check_definite(structure.stiffness(float("inf")), f"{label} K after its stiffness "
                       "events", semi=True)
    if structure.C is not None:
        check_definite(structure.C, f"{label} C", semi=True)


def structure_length_unit(structure) -> str:
    """The displacement unit of a structure's responses: ``"m"`` for a structure file in SI,
    ``"in"`` otherwise (the dissertation's inch–lbf, and structures built in Python)."""
    meta = getattr(structure, "metadata", None) or {}
    return "m" if meta.get("unit_system") == "SI" else "in"


# ---------------------------------------------------------------------------- shared readers
def _unit_system(top: Table) -> tuple[str, str]:
    """The file's ``units``: (canonical string, ``"inch-lbf"`` or ``"SI"``)."""
    units = top.string("units")
    got = _UNIT_SYSTEMS.get(" ".join(units.lower().replace(",", " ").split()))
    if got is None:
        top.fail("units", f'expected "{UNITS}" (the dissertation\'s) or "{UNITS_SI}" (SI: m, '
                          f'N, kg, Pa), got "{units}"')
    return got


def _density(t: Table, ctx: SpecContext) -> float:
    """``density`` (lbf·s²/in⁴, or kg/m³ in an SI file) or ``density_lbm_per_ft3`` (inch–lbf
    files only; converted with g0 = 386.0886)."""
    key = t.exclusive("density", "density_lbm_per_ft3")
    if key == "density":
        return t.number("density", positive=True)
    if ctx.unit_system == "SI":
        t.fail("density_lbm_per_ft3", "an inch–lbf field in a file whose units are "
                                      f'"{UNITS_SI}": give `density` in kg/m³')
    return density_from_lbm_per_ft3(t.number("density_lbm_per_ft3", positive=True))


# ---------------------------------------------------------------------------- cantilever_beam
@register_kind("cantilever_beam")
def _cantilever_beam(top: Table, ctx: SpecContext) -> Structure:
    """``[beam]`` and the optional ``[damping]``, ``[tip_mass]``, ``[tip_spring]``,
    ``[tip_dashpot]``, ``[tip_band]`` → :func:`~podbench.structures.beam.cantilever_beam`."""
    kw = _beam_fields(top.table("beam", required=True), ctx)
    beam = {k: kw[k] for k in ("length", "width", "depth")}
    dm = top.table("damping")
    if dm is not None:
        kw["modal_damping"] = _modal_damping_field(dm, 2 * kw["n_elements"])
    tm = top.table("tip_mass")
    if tm is not None:
        kw["tip_mass"] = _tip_mass_field(tm, beam, kw["density"])
    ts = top.table("tip_spring")
    if ts is not None:
        kw["tip_k3"] = _tip_spring_field(ts, beam, kw["E"])
    td = top.table("tip_dashpot")
    if td is not None:
        kw["tip_dashpot"] = td.number("c", nonnegative=True)
        td.close()
    tb = top.table("tip_band")
    if tb is not None:
        kw["tip_band"] = _tip_band_field(tb)
    return cantilever_beam(name=ctx.name, **kw)


def _beam_fields(b: Table, ctx: SpecContext) -> dict[str, Any]:
    """``[beam]``: geometry (in), E (psi), density, element count and the sensor positions."""
    length = b.number("length", positive=True)
    kw: dict[str, Any] = dict(
        length=length,
        width=b.number("width", positive=True),
        depth=b.number("depth", positive=True),
        E=b.number("E", positive=True),
        density=_density(b, ctx),
        n_elements=b.integer("n_elements", positive=True),
    )
    sensors = b.numbers("sensors", None, nonnegative=True)
    if sensors is not None:
        try:
            sensor_nodes(sensors, length, kw["n_elements"])
        except InputError as exc:
            b.fail("sensors", str(exc).removeprefix("Parameter `sensors`: "))
        kw["sensors"] = sensors
    b.close()
    return kw


def _modal_damping_field(dm: Table, n_dofs: int) -> list[float] | float:
    """``[damping] modal_ratio``: one ratio, or one per mode, each in [0, 1)."""
    z = dm.numbers("modal_ratio", nonnegative=True, scalar_ok=True)
    for i, zi in enumerate([z] if isinstance(z, float) else z):
        if not zi < 1.0:
            dm.fail("modal_ratio" if isinstance(z, float) else f"modal_ratio[{i}]",
                    f"expected a damping ratio in [0, 1), got {zi!r}")
    if isinstance(z, list) and len(z) > n_dofs:
        dm.fail("modal_ratio", f"{len(z)} ratios for a model of {n_dofs} modes")
    if n_dofs > MODAL_DAMPING_MAX_DOFS:
        dm.fail("modal_ratio", f"modal damping builds a dense {n_dofs} x {n_dofs} matrix; "
                               f"at most {MODAL_DAMPING_MAX_DOFS} DOFs are supported")
    dm.string("source", "", nonempty=False)
    dm.close()
    return z


def _tip_mass_field(tm: Table, beam: dict[str, float], density: float):
    """``[tip_mass]``: the law ``m(t)`` (constant, sine or linear; absolute or beam masses)."""
    law = tm.string("law", choices=("constant", "sine", "linear"))
    scale = tm.string("scale", "absolute", choices=("absolute", "beam_mass"))
    params: dict[str, float]
    if law == "constant":
        params = {"value": tm.number("value", nonnegative=True)}
    elif law == "sine":
        mean = tm.number("mean", nonnegative=True)
        amp = tm.number("amplitude")
        if abs(amp) > mean:
            tm.fail("amplitude", f"|amplitude| = {abs(amp)!r} exceeds mean = {mean!r}: "
                                 "the mass would become negative")
        params = {"mean": mean, "amplitude": amp,
                  "period": tm.number("period", positive=True),
                  "phase": tm.number("phase", 0.0)}
    else:
        params = {"initial": tm.number("initial", nonnegative=True),
                  "final": tm.number("final", nonnegative=True),
                  "duration": tm.number("duration", positive=True)}
    tm.close()
    return tip_mass_law(law, scale=scale, density=density, **beam, **params)


def _tip_spring_field(ts: Table, beam: dict[str, float], E: float) -> float:
    """``[tip_spring]``: ``k3`` (lbf/in³), or the k3 matching the tip stiffness at a deflection."""
    key = ts.exclusive("k3", "k3_match_linear_at")
    if key == "k3":
        k3 = ts.number("k3", nonnegative=True)
    else:
        w_ref = ts.number("k3_match_linear_at", positive=True)
        k3 = k3_matching_linear(tip_stiffness(E=E, **beam), w_ref)
    ts.close()
    return k3


def _tip_band_field(tb: Table) -> dict[str, Any]:
    """``[tip_band]``: the §5.2 rubber band (stiffness, side, slack or prestretch, twin)."""
    band = {"k": tb.number("k", nonnegative=True),
            "side": tb.string("side", choices=("positive", "negative")),
            "slack": tb.number("slack", 0.0, nonnegative=True),
            "prestretch": tb.number("prestretch", 0.0, nonnegative=True),
            "twin": tb.string("twin", "tangent", choices=("tangent", "free", "two_sided"))}
    if band["slack"] > 0 and band["prestretch"] > 0:
        tb.fail("prestretch", f"both `slack` ({band['slack']!r} in) and `prestretch` "
                              f"({band['prestretch']!r} in) are non-zero; at most one may be")
    tb.close()
    return band


# ---------------------------------------------------------------------------- satellite_truss
def _tube(t: Table, key: str):

    sub = t.table(key, required=True)
    D = sub.number("outer_diameter", positive=True)
    th = sub.number("thickness", positive=True)
    if 2 * th > D:
        sub.fail("thickness", f"{th!r} in exceeds half the outer diameter {D!r} in")
    sub.close()
    return TubeSection(D, th)


@register_kind("satellite_truss")
def _satellite_truss(top: Table, ctx: SpecContext) -> Structure:

    t = top.table("truss", required=True)
    kw: dict[str, Any] = dict(
        n_elements=t.integer("n_elements", positive=True),
        bay_length=t.number("bay_length", positive=True),
        side=t.number("side", positive=True),
        E=t.number("E", positive=True),
        density=_density(t, ctx),
        diagonal_pattern=t.string("diagonal_pattern", "mirrored",
                                  choices=("mirrored", "parallel")),
        supports=t.string("supports", "pinned", choices=("pinned", "free")),
        longeron=_tube(t, "longeron"),
        batten=_tube(t, "batten"),
        diagonal=_tube(t, "diagonal"),
    )
    t.close()
    fr = top.table("fracture")
    kw["fracture_element"] = None
    if fr is not None:
        kw["fracture_element"] = fr.integer("element", positive=True,
                                            maximum=kw["n_elements"])
        kw["fracture_time"] = fr.number("time", nonnegative=True)
        kw["fracture_model"] = fr.string("model", "element",
                                         choices=("element", "stiffness_only"))
        fr.close()
    return satellite_truss(name=ctx.name, **kw)


# ---------------------------------------------------------------------------- chain
@register_kind("chain")
def _chain(top: Table, ctx: SpecContext) -> Structure:

    c = top.table("chain", required=True)
    n = c.integer("n", positive=True)
    boundary = c.string("boundary", "fixed-free", choices=("fixed-free", "fixed-fixed"))
    masses = c.numbers("masses", positive=True, scalar_ok=True)
    if isinstance(masses, list) and len(masses) != n:
        c.fail("masses", f"expected {n} values (one per mass, n = {n}), got {len(masses)}")
    springs = c.numbers("springs", positive=True, scalar_ok=True)
    n_springs = spring_count(n, boundary)
    if isinstance(springs, list) and len(springs) != n_springs:
        c.fail("springs", f"expected {n_springs} values (a {boundary} chain of n = {n} "
                          f"masses), got {len(springs)}")
    mu = c.number("mass_coupling", 0.0)
    if not abs(mu) < 0.5:
        c.fail("mass_coupling", f"expected |μ| < 0.5 (keeps M positive definite), got {mu!r}")
    c.close()
    kw = dict(masses=masses, springs=springs, mass_coupling=mu, boundary=boundary)

    d = top.table("damping")
    if d is not None:
        kind = d.string("type", choices=("none", "rayleigh", "dashpots"))
        if kind == "rayleigh":
            kw["rayleigh"] = (d.number("alpha", nonnegative=True),
                              d.number("beta", nonnegative=True))
        elif kind == "dashpots":
            pots = []
            for t in d.tables("dashpots"):
                dofs = t.integers("dofs", minimum=0)
                if len(dofs) not in (1, 2) or (len(dofs) == 2 and dofs[0] == dofs[1]):
                    t.fail("dofs", f"expected [i] (grounded) or [i, j] (i != j), got {dofs}")
                if max(dofs) >= n:
                    t.fail("dofs", f"DOF {max(dofs)} outside [0, {n - 1}] (n = {n})")
                pots.append((*dofs, t.number("c", nonnegative=True)))
                t.close()
            if not pots:
                d.fail("dashpots", "expected at least one dashpot")
            kw["dashpots"] = pots
        d.close()
    return chain(n, name=ctx.name, **kw)


# ---------------------------------------------------------------------------- matrices
#: A matrix read from a file: (where, for messages; the file as written; the matrix).
_ReadMatrix = tuple[str, str, Any]


@register_kind("matrices")
def _matrices(top: Table, ctx: SpecContext) -> Structure:
    """``[matrices]``: M, K (and C) from one .npz/.mat ``file`` or one file per matrix, the
    sensors, then the checks (symmetric, M positive definite, K and C semi-definite)."""
    t = top.table("matrices", required=True)
    form = t.exclusive("file", "M")
    rtol = t.number("symmetry_rtol", 1e-10, positive=True)
    mats = _matrix_archive(t, ctx) if form == "file" else _matrix_files(t, ctx)
    sd = t.raw("sensor_dofs")
    if isinstance(sd, str):
        if sd != "all":
            t.fail("sensor_dofs", f'expected "all" or an array of DOF indices, got "{sd}"')
    else:
        sd = t.integers("sensor_dofs", minimum=-1)
    labels = t.strings("dof_labels", ())
    positions = t.numbers("sensor_positions", None)
    t.close()

    checked = _checked_matrices(mats, rtol, ctx)
    _check_sensor_fields(t, checked["M"].shape[0], sd, labels, positions)
    files = {k: mats[k][1] for k in mats}
    return from_matrices(name=ctx.name, M=checked["M"], K=checked["K"], C=checked.get("C"),
                         sensor_dofs=sd, dof_labels=labels, sensor_positions=positions,
                         symmetry_rtol=rtol, metadata={"matrix_sources": files})


def _matrix_path(t: Table, ctx: SpecContext, key: str) -> tuple[str, Path]:
    """The file named by field ``key`` (relative to the structure file), checked to exist."""
    rel = t.string(key)
    path = (ctx.base_dir / rel).resolve()
    if not path.is_file():
        t.fail(key, f'no such file "{path}"')
    return rel, path


def _matrix_archive(t: Table, ctx: SpecContext) -> dict[str, _ReadMatrix]:
    """``file = "x.npz"`` (or .mat): one archive holding M, K and optionally C."""
    rel, path = _matrix_path(t, ctx, "file")
    if path.suffix.lower() not in (".npz", ".mat"):
        t.fail("file", f'expected a .npz or .mat file holding M, K (and C), got "{rel}"')
    try:
        arrays = read_arrays(path)
    except InputError as exc:
        t.fail("file", str(exc))
    for key in arrays:
        if key not in ("M", "K", "C"):
            t.fail("file", f'"{rel}" holds an unexpected array "{key}" (expected M, K '
                           "and optionally C)")
    for key in ("M", "K"):
        if key not in arrays:
            t.fail("file", f'"{rel}" holds no matrix "{key}" (it holds {sorted(arrays)})')
    return {k: (f"field `{t.field('file')}`: matrix {k} in \"{rel}\"", rel, arrays[k])
            for k in arrays}


def _matrix_files(t: Table, ctx: SpecContext) -> dict[str, _ReadMatrix]:
    """``M = "m.mtx"``, ``K = ...`` (and ``C``): one file per matrix."""
    mats: dict[str, _ReadMatrix] = {}
    for key in ("M", "K", "C"):
        if key == "C" and not t.has("C"):
            continue
        rel, path = _matrix_path(t, ctx, key)
        try:
            mats[key] = (f"field `{t.field(key)}` (\"{rel}\")", rel, read_matrix(path))
        except InputError as exc:
            t.fail(key, str(exc))
    return mats


def _checked_matrices(mats: dict[str, _ReadMatrix], rtol: float, ctx: SpecContext) -> dict:
    """M (symmetric positive definite), then K and C (positive semi-definite, M's size)."""
    checked: dict[str, Any] = {}
    for key in ("M", "K", "C"):
        if key in mats:
            where, _, A = mats[key]
            n = checked["M"].shape[0] if key != "M" else None
            try:
                checked[key] = check_matrix(A, where, n=n, symmetry_rtol=rtol,
                                            positive_definite=(key == "M"),
                                            positive_semidefinite=(key != "M"))
            except InputError as exc:
                fail(ctx.file, None, str(exc))
    return checked


def _check_sensor_fields(t: Table, n: int, sd: str | list[int], labels: list[str],
                         positions: list[float] | float | None) -> None:
    """``sensor_dofs``, ``dof_labels`` and ``sensor_positions`` against the n DOFs of M."""
    if not isinstance(sd, str) and max(sd) >= n:
        t.fail("sensor_dofs", f"DOF {max(sd)} outside [-1, {n - 1}] (M is {n} x {n})")
    if labels and len(labels) != n:
        t.fail("dof_labels", f"expected {n} labels (M is {n} x {n}), got {len(labels)}")
    n_sensors = n if isinstance(sd, str) else len(sd)
    if isinstance(positions, list) and len(positions) != n_sensors:
        t.fail("sensor_positions", f"expected {n_sensors} values (one per sensor), got "
                                   f"{len(positions)}")


# ---------------------------------------------------------------------------- python
_RESULT_KEYS = ("M", "K", "C", "sensor_dofs", "sensor_positions", "sensor_labels",
                "dof_labels", "metadata")


@register_kind("python")
def _python(top: Table, ctx: SpecContext) -> Structure:
    """``builder = "module:function"`` called with ``[parameters]``; it returns a Structure
    or a dict of matrices (:func:`~podbench.structures.matrices.from_matrices`)."""
    target = top.string("builder")
    if target.count(":") != 1 or not all(target.split(":")):
        top.fail("builder", f'expected "module:function", got "{target}"')
    module_name, func_name = target.split(":")
    rel = top.string("path", None)
    params = top.table("parameters")
    kwargs = dict(params.data) if params is not None else {}
    if params is not None:
        params.accept_all()  # the builder's signature checks them below

    func = _builder_function(top, ctx, module_name, func_name, rel)
    _check_builder_parameters(top, params, target, func, kwargs)
    try:
        result = func(**kwargs)
    except InputError:
        raise
    except Exception as exc:
        top.fail("builder", f"{target} raised {type(exc).__name__}: {exc}")
    return _builder_structure(top, ctx, target, result)


def _builder_function(top: Table, ctx: SpecContext, module_name: str, func_name: str,
                      rel: str | None) -> Callable[..., Any]:
    """The builder function: from the file ``path`` if given, else the module (importable or
    next to the structure file, :func:`~podbench.core.userimport.import_module_or_file`)."""
    if rel is not None:
        if not rel.endswith(".py"):
            top.fail("path", f'expected a Python file "name.py", got "{rel}"')
        try:
            module = import_module_or_file(rel, ctx.base_dir)
        except UserImportError as exc:
            top.fail("path", str(exc))
    else:
        try:
            module = import_module_or_file(module_name, ctx.base_dir)
        except UserImportError as exc:
            top.fail("builder", f"{exc}; or give `path` to load a file next to the "
                                "structure file")
    func = getattr(module, func_name, None)
    if not callable(func):
        top.fail("builder", f'module "{module_name}" has no function "{func_name}"')
    return func


def _check_builder_parameters(top: Table, params: Table | None, target: str,
                              func: Callable[..., Any], kwargs: dict[str, Any]) -> None:
    """Every ``[parameters]`` entry must be a parameter of the builder, and bind to it."""
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return
    accepted = [p.name for p in sig.parameters.values()
                if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if params is not None and not any(p.kind == p.VAR_KEYWORD
                                      for p in sig.parameters.values()):
        for key in kwargs:
            if key not in accepted:
                params.fail(key, f"not a parameter of {target} (its parameters: "
                                 f"{', '.join(accepted) or 'none'})")
    try:
        sig.bind(**kwargs)
    except TypeError as exc:
        top.fail("parameters", f"do not match {target}: {exc}")


def _builder_structure(top: Table, ctx: SpecContext, target: str, result) -> Structure:
    """The builder's result: a checked Structure, or a dict of M, K (C, sensors, ...)."""
    if isinstance(result, Structure):
        try:
            check_structure_matrices(result, f"{target} returned a Structure with")
        except InputError as exc:
            top.fail("builder", str(exc))
        return result
    if not isinstance(result, Mapping):
        top.fail("builder", f"{target} must return a Structure or a dict with M, K (and "
                            f"optionally C, sensor_dofs, ...), got {type(result).__name__}")
    unknown = [k for k in result if k not in _RESULT_KEYS]
    if unknown:
        top.fail("builder", f"{target} returned unknown key {unknown[0]!r} (allowed: "
                            f"{', '.join(_RESULT_KEYS)})")
    for k in ("M", "K"):
        if k not in result:
            top.fail("builder", f"{target} returned no {k!r}")

    kw = {k: result[k] for k in _RESULT_KEYS if k in result}
    kw.setdefault("sensor_dofs", "all")
    kw["where"] = f"{target} returned"
    return from_matrices(name=ctx.name, **kw)
