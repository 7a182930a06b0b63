"""The Painter Street Overpass study file: ``scenarios/painter_street/painter_street.toml``.

A study with its own runner (:mod:`podbench.study.own_runner`): its ``[painter_street]``
table names the folder of measured records (``data``, relative to the file: one ``.npz``
per earthquake and ``events.csv``), which :mod:`podbench.harness.painter_street` runs
leave-one-event-out and :mod:`podbench.report.painter_street` writes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from podbench.study.own_runner import data_folder, read_runner_table

__all__ = ["PainterStreetPlan", "load_painter_street", "TABLE"]

TABLE = "painter_street"


@dataclass(frozen=True)
class PainterStreetPlan:
    """``name`` (the study folder's name), the study file ``path`` and the records folder
    ``data`` (``*.npz`` events and ``events.csv``)."""

    name: str
    path: Path
    data: Path


def load_painter_street(path) -> PainterStreetPlan:
    """Read and check the ``[painter_street]`` table of a study file.

    Raises
    ------
    ScenarioFileError
        One line naming the file and the field: the table or ``data`` missing, ``data`` not a
        folder holding ``.npz`` records and ``events.csv``.
    """
    path = Path(path)
    data = read_runner_table(path, TABLE, lambda t, p: data_folder(t, p, ("events.csv",)))
    return PainterStreetPlan(name=path.resolve().parent.name, path=path, data=data)
