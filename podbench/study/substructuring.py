"""The substructuring study file (Chapter 6): ``scenarios/substructuring/substructuring.toml``.

A study with its own runner (``[study] runner = "substructuring"``,
:mod:`podbench.study.own_runner`), not a scenario folder of methods and targets:
:func:`load_substructuring` reads its ``[substructuring]`` table into a
:class:`SubstructuringPlan` (pure data), which :mod:`podbench.harness.substructuring` runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from podbench.core.tomlfile import load_toml, typed_field
from podbench.errors import ScenarioFileError

__all__ = ["SubstructuringPlan", "ComponentEntry", "load_substructuring", "TABLE"]

TABLE = "substructuring"


@dataclass(frozen=True)
class ComponentEntry:
    """A component: a structure file (scaled), attached by its DOF ``component_dof`` to the
    parent's interface DOF, or the time-varying tip mass of a structure (``tip_mass``)."""

    name: str
    structure: str
    scale: float = 1.0
    component_dof: int = 0
    tip_mass: bool = False


@dataclass(frozen=True)
class SubstructuringPlan:
    name: str
    path: Path
    parent: str
    interface_dof: int
    dt: float
    n_samples: int
    load: dict
    noise: tuple
    seeds: tuple
    horizon: int
    divergence: float
    components: tuple
    identification: dict = field(default_factory=dict)


def _read(path: Path) -> dict:
    return load_toml(path, str(path), ScenarioFileError)[1]


def _get(d: dict, key: str, kind, path: Path, *default):
    return typed_field(d, key, kind, f"{path}: [{TABLE}]", ScenarioFileError, *default)


def load_substructuring(path) -> SubstructuringPlan:
    """Read and check a substructuring study file."""
    path = Path(path)
    raw = _read(path).get(TABLE)
    if not isinstance(raw, dict):
        raise ScenarioFileError(f"{path}: no [{TABLE}] table")
    comps = []
    for i, c in enumerate(raw.get("components", [])):
        if not isinstance(c, dict) or "name" not in c or "structure" not in c:
            raise ScenarioFileError(f"{path}: {TABLE}.components[{i}] needs a name and a "
                                    "structure")
        comps.append(ComponentEntry(name=str(c["name"]), structure=str(c["structure"]),
                                    scale=float(c.get("scale", 1.0)),
                                    component_dof=int(c.get("component_dof", 0)),
                                    tip_mass=bool(c.get("tip_mass", False))))
    if not comps:
        raise ScenarioFileError(f"{path}: {TABLE}.components is empty")
    noise = tuple(float(x) for x in _get(raw, "noise", list, path))
    if any(x < 0 for x in noise):
        raise ScenarioFileError(f"{path}: {TABLE}.noise levels must be >= 0")
    return SubstructuringPlan(
        name=path.parent.name, path=path,
        parent=_get(raw, "parent", str, path), interface_dof=_get(raw, "interface_dof", int, path),
        dt=_get(raw, "dt", float, path), n_samples=_get(raw, "n_samples", int, path),
        load=_get(raw, "load", dict, path), noise=noise,
        seeds=tuple(int(s) for s in _get(raw, "seeds", list, path)),
        horizon=_get(raw, "horizon", int, path, 1),
        divergence=_get(raw, "divergence", float, path, 10.0),
        components=tuple(comps), identification=dict(raw.get("identification", {})))
