"""The base-excited study file: ``scenarios/base_excited/base_excited.toml``.

A study with its own runner (:mod:`podbench.study.own_runner`): its ``[base_excitation]``
table names the structures (each with ``dt`` s, ``n_samples``, the resultant ``resultant``
lbf of the Chapter 4 pulse, the pulse length ``pulse`` s, and the strain channels), the
training and target base motions and the outputs, which :mod:`podbench.harness.base_excited`
runs and :mod:`podbench.report.base_excited` writes.

Base motions (names ``rect_<a>T``, ``half_sine_<a>T``, ``double_T``, ``burst``; ``T`` the
structure's ``pulse``): peak ``A``, first sample 0 (podbench's convention, pulses start one
sample after t = 0). ``burst``: normal noise (seed 0) smoothed by a moving average over
``T``, times ``exp(−t/τ)`` with τ an eighth of the record, scaled to peak ``A``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from podbench.core.resources import bundled_scenarios
from podbench.core.tomlfile import load_toml, typed_field
from podbench.errors import InputError

__all__ = ["STUDY", "TABLE", "OUTPUT_UNITS", "StructureSpec", "BaseStudy", "study_file",
           "load_study", "base_motion"]

STUDY = "base_excited"
"""The study's name and its folder under ``scenarios/``."""
TABLE = "base_excitation"
"""The TOML table of a base-excited study file."""
OUTPUT_UNITS = {"absolute_acceleration": ("in/s^2", "acceleration"),
                "strain": ("strain", "strain")}
"""Output name → (the structure's unit, the quantity)."""


@dataclass(frozen=True)
class StructureSpec:
    label: str
    structure: str
    dt: float
    n_samples: int
    resultant: float
    pulse: float
    fracture: bool = True
    strain: dict = field(default_factory=dict)


@dataclass(frozen=True)
class BaseStudy:
    name: str
    title: str
    description: str
    structures: tuple
    train: tuple
    targets: tuple
    outputs: tuple
    path: str = ""


def study_file() -> Path:
    """The bundled study file."""
    return bundled_scenarios() / STUDY / f"{STUDY}.toml"


def _need(where: str, table: dict, key: str, kind):
    return typed_field(table, key, kind, where, InputError)


def _structure_spec(where: str, label: str, t: dict) -> StructureSpec:
    w = f"{where}: [{TABLE}.structures.{label}]"
    strain = {}
    if "strain_points" in t:
        strain = {"strain_points": [float(x) for x in t["strain_points"]],
                  "fibre_distance": _need(w, t, "fibre_distance", float)}
    elif "strain_member_labels" in t:
        strain = {"member_labels": [str(x) for x in t["strain_member_labels"]]}
    spec = StructureSpec(label=label, structure=str(t.get("structure", label)),
                         dt=_need(w, t, "dt", float), n_samples=_need(w, t, "n_samples", int),
                         resultant=_need(w, t, "resultant", float),
                         pulse=_need(w, t, "pulse", float),
                         fracture=bool(t.get("fracture", True)), strain=strain)
    if spec.dt <= 0 or spec.n_samples < 10 or spec.pulse <= 0:
        raise InputError(f"{w}: fields `dt`, `n_samples`, `pulse`: expected dt > 0, "
                         "n_samples ≥ 10, pulse > 0")
    return spec


def load_study(path=None) -> BaseStudy:
    """Read a base-excited study file (default: the bundled one); one line per error."""
    path = Path(path) if path is not None else study_file()
    _, spec = load_toml(path, str(path), InputError)
    where = path.name
    if TABLE not in spec:
        raise InputError(f"{where}: table `[{TABLE}]`: missing")
    t = spec[TABLE]
    structures = tuple(_structure_spec(where, k, v)
                       for k, v in _need(where, t, "structures", dict).items())
    names = list(t.get("train", [])) + list(t.get("targets", []))
    for m in names:
        base_motion(m, 1e-3, 64, 1e-2, 1.0)  # a misspelt motion: refused before any work
    outputs = tuple(t.get("outputs", ["absolute_acceleration"]))
    for o in outputs:
        if o not in OUTPUT_UNITS:
            raise InputError(f"{where}: field `outputs`: unknown {o!r} (expected some of "
                             f"{', '.join(OUTPUT_UNITS)})")
    return BaseStudy(name=str(t.get("name", STUDY)), title=str(t.get("title", "")),
                     description=str(t.get("description", "")), structures=structures,
                     train=tuple(_need(where, t, "train", list)),
                     targets=tuple(_need(where, t, "targets", list)), outputs=outputs,
                     path=str(path))


def _multiple(text: str, name: str) -> float:
    try:
        return float(text[:-1]) if text != "T" else 1.0
    except ValueError:
        raise InputError(f"base motion {name!r}: expected <kind>_<a>T, e.g. rect_2T") from None


def base_motion(name: str, dt: float, n: int, T: float, A: float) -> np.ndarray:
    """The base acceleration ``name`` (module docstring), ``n`` samples at ``dt``, peak ``A``."""
    t = np.arange(n) * dt
    on = t > dt / 2

    def rect(d):
        return A * (on & (t < dt + d - dt / 2))

    if name == "burst":
        w = max(1, int(round(T / dt)))
        noise = np.random.default_rng(0).normal(size=n)
        x = np.convolve(noise, np.ones(w) / w)[:n] * np.exp(-t / (n * dt / 8)) * on
        return A * x / np.max(np.abs(x))
    if name == "double_T":
        return rect(T) - np.roll(rect(T), int(round(2 * T / dt)))
    kind, _, mult = name.rpartition("_")
    if kind == "rect" and mult.endswith("T"):
        return rect(_multiple(mult, name) * T)
    if kind == "half_sine" and mult.endswith("T"):
        d = _multiple(mult, name) * T
        return A * np.where(on & (t < dt + d - dt / 2), np.sin(np.pi * (t - dt) / d), 0.0)
    raise InputError(f"base motion {name!r}: expected rect_<a>T, half_sine_<a>T, double_T or "
                     "burst")
