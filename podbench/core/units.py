"""The quantities and units a record's channels carry, and their unit systems.

A record (:class:`~podbench.core.records.Record`) states the quantity and the unit of its
inputs and of its outputs. :data:`UNITS` lists the units podbench knows for each quantity
with their factor to SI; a record is in one unit system, ``"SI"`` or ``"inch-lbf"`` (strain
is dimensionless and fits both), and is converted once, where the data come in.
"""

from __future__ import annotations

from podbench.errors import InputError

__all__ = ["QUANTITIES", "UNITS", "LBF", "INCH", "normalize_unit", "unit_system",
           "system_unit", "unit_factor"]

QUANTITIES = ("force", "displacement", "velocity", "acceleration", "strain", "voltage")
"""The quantities an input or output channel can measure (``voltage``: a signal such as a
shaker generator's reference, in V, a unit of both systems)."""

LBF = 4.4482216152605
"""One pound-force in newtons (exact by definition of the lbf and the standard gravity)."""
INCH = 0.0254
"""One inch in metres (exact)."""

UNITS: dict[str, dict[str, tuple[str, float]]] = {
    "force": {"N": ("SI", 1.0), "lbf": ("inch-lbf", LBF)},
    "displacement": {"m": ("SI", 1.0), "in": ("inch-lbf", INCH)},
    "velocity": {"m/s": ("SI", 1.0), "in/s": ("inch-lbf", INCH)},
    "acceleration": {"m/s^2": ("SI", 1.0), "in/s^2": ("inch-lbf", INCH)},
    "strain": {"strain": ("any", 1.0)},
    "voltage": {"V": ("any", 1.0)},
}
"""Quantity → unit → (unit system, factor to SI). ``"any"``: fits both (strain, volts)."""

_ALIASES = {"m/s2": "m/s^2", "m/s²": "m/s^2", "m s^-2": "m/s^2", "in/s2": "in/s^2",
            "in/s²": "in/s^2", "inch": "in", "inches": "in", "newton": "N", "lb": "lbf",
            "in/in": "strain", "m/m": "strain", "-": "strain", "1": "strain"}

_SYSTEM_UNIT = {(q, system): u for q, table in UNITS.items() for u, (own, _) in table.items()
                for system in (("SI", "inch-lbf") if own == "any" else (own,))}
"""(quantity, unit system) → the unit podbench converts to."""


def normalize_unit(unit, where: str = "unit") -> tuple[str, str]:
    """``(quantity, unit)`` of a unit string (aliases such as ``m/s2`` accepted).

    Raises
    ------
    InputError
        Missing or unknown unit, naming ``where``.
    """
    if unit is None or (isinstance(unit, str) and not unit.strip()):
        raise InputError(f"{where}: missing (give the unit, e.g. 'm/s^2' or 'in/s^2')")
    u = str(unit).strip()
    u = _ALIASES.get(u, _ALIASES.get(u.lower(), u))
    for quantity, table in UNITS.items():
        if u in table:
            return quantity, u
    known = ", ".join(u for t in UNITS.values() for u in t)
    raise InputError(f"{where}: unknown unit {unit!r} (known: {known})")


def unit_system(*units: str) -> str:
    """The unit system of units (``"SI"``, ``"inch-lbf"`` or ``"any"`` for strain only).

    Raises InputError for a mix of systems."""
    systems = {UNITS[normalize_unit(u)[0]][normalize_unit(u)[1]][0] for u in units} - {"any"}
    if len(systems) > 1:
        raise InputError(f"units {', '.join(units)} mix unit systems "
                         f"({', '.join(sorted(systems))}); convert where the data come in")
    return systems.pop() if systems else "any"


def system_unit(quantity: str, system: str) -> str:
    """The unit of ``quantity`` in the unit system ``system`` (``"SI"`` or ``"inch-lbf"``)."""
    return _SYSTEM_UNIT[(quantity, system)]


def unit_factor(quantity: str, unit: str, new: str) -> float:
    """The factor that converts values of ``quantity`` from ``unit`` to ``new``."""
    return UNITS[quantity][unit][1] / UNITS[quantity][new][1]
