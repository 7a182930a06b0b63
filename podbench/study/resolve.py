"""A scenario's structure entries resolved to structures: a structure file by name (the
scenario's folder, its ``structures/``, ``PODBENCH_STRUCTURES``, the bundled ones), a
``[variants.<name>]`` of one, or ``"measured"`` for a study of record files."""

from __future__ import annotations

import os
from pathlib import Path

from podbench.core.hints import did_you_mean
from podbench.core.resources import display_path
from podbench.errors import ScenarioFileError, StructureFileError, UnknownNameError
from podbench.structures import list_structures, load_structure
from podbench.study.scenarios import Scenario

MEASURED = "measured"
"""The structure entry of a study of record files (no structure is simulated)."""


def _structure_search(scenario: Scenario) -> list[Path]:
    return [scenario.folder, scenario.folder / "structures", Path.cwd() / "structures"]


class MeasuredStructure:
    """What ``structures = ["measured"]`` resolves to: no model, nothing to simulate, no
    linear twin (the sensors are those of the files)."""

    name = MEASURED
    is_linear = True
    n_sensors = None
    sensor_positions = None
    events = ()


def resolve_structure(entry: str, scenario: Scenario, field: str = "scenario.structures"):
    """Load a structure named in a scenario (a name, or a path relative to the file;
    ``"measured"``: :class:`MeasuredStructure`).

    ``field`` is the scenario field that names it (shown in the error message).
    """
    if entry == MEASURED:
        return MeasuredStructure()
    variant = scenario.variants.get(entry)
    if variant is not None:  # a structure file with some fields replaced, renamed
        base_entry = variant.structure
        if base_entry.endswith(".toml") and not os.path.isabs(base_entry):
            base_entry = str(scenario.folder / base_entry)
        shown = display_path(scenario.path)
        try:
            return load_structure(base_entry, search_path=_structure_search(scenario),
                                  overrides=variant.set, name=entry)
        except UnknownNameError as exc:
            hint = did_you_mean(variant.structure, list_structures(_structure_search(scenario)))
            raise ScenarioFileError(f"{shown}: field `variants.{entry}.structure`: {exc}{hint}") \
                from None
        except StructureFileError as exc:
            raise ScenarioFileError(f"{shown}: field `variants.{entry}.set`: {exc}") from None
    if entry.endswith(".toml") and not os.path.isabs(entry):
        entry = str(scenario.folder / entry)
    if entry.endswith(".toml") and not os.path.isfile(entry):
        raise ScenarioFileError(f"{display_path(scenario.path)}: field `{field}`: {entry}: no such "
                                "structure file")
    search = _structure_search(scenario)
    try:
        return load_structure(entry, search_path=search)
    except UnknownNameError as exc:
        hint = did_you_mean(entry, [*list_structures(search), *scenario.variants])
        raise ScenarioFileError(f"{display_path(scenario.path)}: field `{field}`: {exc}{hint}") \
            from None
