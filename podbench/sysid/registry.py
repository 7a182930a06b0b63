"""The one registry of method names: a name → a method class and the parameters it fixes.

Scenario files (``method = "ML"``), ``podbench predict --method``, ``podbench methods``, the
studies with their own runner and the docs' parameter tables all read names here. An entry
is a class (``"ML"`` → :class:`~podbench.sysid.methods.MultipleLoad`) or a *configuration*:
a registered name with parameters (``"ML-TC"``: ML on measured inputs with the TC prior).
A configuration may leave parameters to its caller (``supplied``: what the caller computes
from its own data, e.g. base_excited's ``ML-k``, ``k`` the number of its training records).

Lookup (:func:`lookup`) is the exact name first, then the one name equal to it but for
letter case; an unknown name is one line with the closest name ("did you mean"). A method
of your own is named ``"module:Class"`` or ``"file.py:Class"`` (:func:`resolve`) and is
checked the same way: a class with ``fit`` and ``predict``, else one line naming the file
and the missing piece.

Adding a method is one class in one file (a :class:`~podbench.sysid.methods.PODMethod`
subclass) and one line in :data:`ENTRIES`.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from podbench.core.hints import did_you_mean
from podbench.core.userimport import import_object
from podbench.errors import InputError, UnknownNameError
from podbench.sysid.methods import (
    ERA,
    MDS,
    POVR,
    DMDc,
    FIRLeastSquares,
    Mdof,
    MixedResponse,
    MultipleLoad,
    OpInf,
    SingleLoad,
    Superposition,
)
from podbench.sysid.methods.peers import ERA_BLOCKS
from podbench.sysid.methods.periodic import BestLinearApproximation, LevelInterpolatedML

__all__ = ["Entry", "ENTRIES", "REGISTRY", "BUILTIN_METHODS", "lookup", "resolve", "names",
           "is_user_method"]


@dataclass(frozen=True)
class Entry:
    """A registered method: its ``name``, class, the parameters it fixes (``params``: a
    configuration), those its caller must give (``supplied``) and a one-line ``summary``."""

    name: str
    cls: type
    params: Mapping[str, Any] = field(default_factory=dict)
    supplied: tuple[str, ...] = ()
    summary: str = ""

    @property
    def configuration(self) -> bool:
        """Whether the entry fixes or leaves parameters (not the class as it is)."""
        return bool(self.params or self.supplied)

    def build(self, **params):
        """An unfitted estimator: the class with the entry's parameters and ``params``."""
        missing = [p for p in self.supplied if p not in params]
        if missing:
            raise InputError(f"method {self.name!r}: give {', '.join(missing)} (the "
                             "configuration leaves it to its caller)")
        return self.cls(**{**self.params, **params})


_MEASURED_LAGS = {"inputs": "measured", "n_lags": "auto", "solver": "ls"}
_WHOLE = {"inputs": "measured", "n_lags": None, "solver": "ls"}

ENTRIES: tuple[Entry, ...] = (
    Entry("POVR", POVR, summary="POV recalculation: one free response (§3.2.1)"),
    Entry("MDS", MDS, summary="multiple data sets: k free responses (§3.2.3)"),
    Entry("SL", SingleLoad, summary="single load: one forced response (§3.3.1)"),
    Entry("ML", MultipleLoad, summary="multiple loads: k forced responses or measured inputs "
                                      "(§3.3.2)"),
    Entry("MR", MixedResponse, summary="mixed response: three mixed responses (§3.4)"),
    Entry("superposition", Superposition, summary="the sum of other methods (MR's coupled "
                                                  "twin)"),
    Entry("FIR-LS", FIRLeastSquares, summary="FIR least squares per output channel (no POD)"),
    Entry("ERA", ERA, summary="ERA/OKID (Juang & Pappa 1985)"),
    Entry("DMDc", DMDc, summary="DMD with control (PyDMD)"),
    Entry("OpInf", OpInf, summary="operator inference (opinf)"),
    Entry("mdof", Mdof, summary="mdof's SRIM or OKID-ERA (measured inputs)"),
    Entry("BLA", BestLinearApproximation,
          summary="best linear approximation on a periodic excitation (Pintelon & Schoukens)"),
    Entry("ML-interp", LevelInterpolatedML,
          summary="ML's periodic kernel per force level, interpolated in input RMS"),
    # configurations: a registered name with parameters
    Entry("ML-lags", MultipleLoad, _MEASURED_LAGS,
          summary="ML on measured inputs, lags by leave-one-record-out"),
    Entry("ML-TC", MultipleLoad, {**_MEASURED_LAGS, "prior": "tc"},
          summary="ML on measured inputs, lags and TC prior by leave-one-record-out"),
    Entry("ML-poles", MultipleLoad, {**_MEASURED_LAGS, "prior": "tc", "kernel": "poles"},
          summary="ML-TC's kernel in a basis of decaying modes with poles from the data"),
    Entry("ML-whole", MultipleLoad, _WHOLE,
          summary="ML on measured inputs, the kernel over the whole record"),
    Entry("ML-periodic", MultipleLoad, {"inputs": "periodic"}, supplied=("period",),
          summary="ML on a periodic excitation, the kernel over one period (its excited "
                  "lines)"),
    Entry("ML-k", MultipleLoad, _WHOLE, supplied=("n_modes",),
          summary="ML-whole in k POMs, k given by the study (its training records)"),
    Entry("FIR-LS-whole", FIRLeastSquares, {"n_lags": None},
          summary="FIR-LS with the kernel over the whole record"),
    Entry("FIR-LS-half", FIRLeastSquares, supplied=("n_lags",),
          summary="FIR-LS truncated to n_lags (the study's half record)"),
    Entry("ERA-measured", ERA, {"inputs": "measured", "blocks": ERA_BLOCKS},
          summary="ERA/OKID on measured inputs, Hankel of 1 s of Markov parameters"),
    Entry("mdof-SRIM", Mdof, {"method": "srim"}, summary="mdof's SRIM"),
    Entry("mdof-OKID-ERA", Mdof, {"method": "okid-era", "horizon": 0.3, "markov": 0.6},
          summary="mdof's OKID-ERA, 0.6 s of Markov parameters, Hankel 0.3 s"),
)
"""Every registered name, classes first (the docs' order), then the configurations."""

REGISTRY: dict[str, Entry] = {e.name: e for e in ENTRIES}
"""Name → entry."""

BUILTIN_METHODS: dict[str, type] = {e.name: e.cls for e in ENTRIES if not e.configuration}
"""The built-in method classes by the name a scenario file gives."""


def names() -> list[str]:
    """Every registered name, in :data:`ENTRIES`' order."""
    return [e.name for e in ENTRIES]


def is_user_method(name: str) -> bool:
    """True for a ``"module:Class"`` / ``"file.py:Class"`` name."""
    return ":" in name


def lookup(name: str) -> Entry:
    """The entry of ``name``: the exact name, else the one equal to it but for letter case.

    Raises
    ------
    UnknownNameError
        One line with the closest name and the built-in ones.
    """
    if name in REGISTRY:
        return REGISTRY[name]
    same = [e for e in ENTRIES if e.name.lower() == str(name).lower()]
    if len(same) == 1:
        return same[0]
    raise UnknownNameError(
        f'unknown method "{name}"{did_you_mean(name, names())} (built-in methods: '
        f'{", ".join(names())}, or "module:Class" / "file.py:Class" for a method of your own)')


def _missing_piece(cls) -> str | None:
    """What a user's method class lacks (one phrase), or None."""
    if not inspect.isclass(cls):
        return f"is a {type(cls).__name__}, not a class"
    for attr, what in (("fit", "fit(records, *, basis=None)"), ("predict", "predict(record)")):
        if not callable(getattr(cls, attr, None)):
            return f"has no `{what}` method"
    return None


def resolve(name: str, base_dir=None) -> Entry:
    """The entry of a registered name or of a user's ``"module:Class"`` /
    ``"file.py:Class"`` (relative to ``base_dir``), checked: a class with ``fit`` and
    ``predict`` (see :class:`podbench.methods.PODMethod` for the contract).

    Raises
    ------
    InputError
        Unknown name; a module or file that does not import, no such class; a class that
        lacks a piece of the contract (one line naming the file and the piece).
    """
    if not is_user_method(name):
        return lookup(name)
    cls = import_object(name, base_dir)
    missing = _missing_piece(cls)
    if missing is not None:
        where, _, obj = name.rpartition(":")
        raise InputError(f"{where}: {obj} {missing} (a method needs fit(records, *, "
                         "basis=None) and predict(record); see podbench.methods.PODMethod)")
    return Entry(name, cls)
