"""Studies with their own runner: a study file whose ``[study]`` table names the runner.

Most studies are scenario files of methods and targets (:mod:`podbench.study.scenarios`),
run unit by unit by :mod:`podbench.harness.runner`. A study that is not — the Painter
Street Overpass' leave-one-event-out over measured earthquakes, Chapter 6's substructuring
— is one TOML file that names its runner::

    [study]
    runner = "substructuring"        # a name of podbench.api.RUNNERS
    title = "Chapter 6: ..."         # optional, shown by `podbench list`
    requires = ["mdof"]              # optional: the extras its committed tables need

    [substructuring]                 # the runner's own table, read by the runner
    ...

:func:`own_study_file` recognizes such a file among the files a run names and
:func:`load_own_study` reads and checks its ``[study]`` table (one line naming the file and
the field, with the closest runner name for a misspelt one). The runners themselves are
registered in :data:`podbench.api.RUNNERS`, the one place that joins a runner (harness) to
its rendering (report).
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from podbench.core.extras import known_extras, unmet_extras_message
from podbench.core.hints import did_you_mean
from podbench.core.resources import display_path
from podbench.errors import ScenarioFileError, StructureFileError
from podbench.structures.spec import Table

__all__ = ["OwnStudy", "STUDY_TABLE", "own_study_file", "load_own_study", "read_toml",
           "read_requires", "check_requires", "read_runner_table", "data_folder"]

STUDY_TABLE = "study"
"""The top-level table that names a study's own runner."""


@dataclass(frozen=True)
class OwnStudy:
    """A study file with its own runner: ``path``, the ``runner``'s name, the ``title``
    (empty if the file gives none) and ``name`` (the study's folder name, as
    ``podbench run`` names its output ``results/<name>``)."""

    path: Path
    runner: str
    title: str
    name: str
    requires: tuple[str, ...] = ()


def read_toml(path: Path) -> dict | None:
    """The parsed TOML of ``path``, or None if it cannot be read (the scenario reader then
    reports why, in one line)."""
    try:
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None


def read_runner_table(path, table: str, read):
    """``read(t, path)`` on the ``[table]`` of the study file ``path`` (``t``: its
    :class:`~podbench.structures.spec.Table`), then every field of it checked as read: the
    runner's own table of a study with its own runner, read the same way by each runner.

    Raises
    ------
    ScenarioFileError
        One line naming the file and the field: not TOML, the table missing, a field of it
        missing, of the wrong type or unknown (``read``'s own checks too).
    """
    path = Path(path)
    shown = display_path(path)
    doc = read_toml(path)
    if doc is None:
        raise ScenarioFileError(f"{shown}: cannot be read as TOML")
    try:
        top = Table(doc, file=shown)
        t = top.table(table, required=True)
        out = read(t, path)
        t.close()
        top.accept_all()
    except StructureFileError as exc:  # Table raises StructureFileError; re-badge it
        raise ScenarioFileError(str(exc)) from None
    return out


def data_folder(t: Table, path: Path, also: tuple[str, ...] = ()) -> Path:
    """The folder named by the ``data`` field of ``t`` (relative to the study file
    ``path``), which must hold ``.npz`` records and the files ``also``; a ``t.fail`` line
    otherwise."""
    rel = t.string("data")
    data = (Path(path).parent / rel).resolve()
    if not data.is_dir():
        t.fail("data", f'no such folder "{rel}" (relative to this file)')
    if not any(data.glob("*.npz")) or not all((data / f).is_file() for f in also):
        t.fail("data", f'"{rel}" holds no .npz records' + "".join(f" and {f}" for f in also))
    return data


def read_requires(t: Table, default=()) -> tuple[str, ...]:
    """The ``requires`` field of a study's ``[study]`` or ``[scenario]`` table ``t``: the
    extras of podbench its committed tables need (default ``default``), each a known extra.
    Whether they are installed is checked when the study is run (:func:`check_requires`),
    not when it is read: listing or inspecting a study needs no extra.

    Raises
    ------
    StructureFileError
        ``<file>: field `<table>.requires`: ...`` — an unknown extra (with the closest name).
    """
    requires = tuple(t.strings("requires", list(default)))
    known = known_extras()
    for i, extra in enumerate(requires):
        if known and extra not in known:
            t.fail(f"requires[{i}]", f'unknown extra "{extra}"{did_you_mean(extra, known)} '
                                     f"(podbench's extras: {', '.join(sorted(known))})")
    return requires


def check_requires(path, table: str, requires) -> None:
    """Refuse to run the study file ``path`` whose ``[table]`` requires extras that are not
    installed: one line naming the file, the field, the missing packages and the install
    command (:class:`ScenarioFileError`), before any work."""
    unmet = unmet_extras_message(requires)
    if unmet is not None:
        raise ScenarioFileError(f"{display_path(Path(path))}: field `{table}.requires`: {unmet}")


def _declares(path: Path, runners: list[str]) -> bool:
    """Whether ``path`` is a study file with its own runner (a ``[study]`` table); a file
    that has a runner's own table but neither ``[study]`` nor ``[scenario]`` is refused
    with the line it lacks."""
    doc = read_toml(path)
    if doc is None:
        return False
    if STUDY_TABLE in doc:
        return True
    own = [r for r in runners if r in doc]
    if own and "scenario" not in doc:
        raise ScenarioFileError(
            f"{display_path(path)}: field `{STUDY_TABLE}.runner`: missing (a [{own[0]}] table "
            f"is run by its own runner: add [{STUDY_TABLE}] runner = \"{own[0]}\")")
    return False


def own_study_file(files, runners: Iterable[str]) -> Path | None:
    """The study file with its own runner among ``files`` (None if there is none).

    Raises
    ------
    ScenarioFileError
        Such a file among other files (a study with its own runner is run alone), or a
        runner's own table without the ``[study]`` table naming the runner.
    """
    runners = list(runners)
    files = [Path(f) for f in files]
    own = [f for f in files if f.suffix == ".toml" and _declares(f, runners)]
    if not own:
        return None
    if len(files) > 1:
        other = next(f for f in files if f != own[0])
        raise ScenarioFileError(
            f"{display_path(own[0])}: a study with its own runner ([{STUDY_TABLE}] runner) is "
            f"run alone, not with {display_path(other)}")
    return own[0]


def load_own_study(path, runners: Iterable[str]) -> OwnStudy:
    """Read and check the ``[study]`` table of ``path``: ``runner`` (one of ``runners``), an
    optional ``title`` and ``requires`` (:func:`read_requires`); other fields of ``[study]``
    are refused. The runner's own tables are left to the runner.

    Raises
    ------
    ScenarioFileError
        ``<file>: field `study.runner`: ...`` — missing, not a string, or not a runner
        (with the closest name and the list of runners).
    """
    path = Path(path)
    shown = display_path(path)
    doc = read_toml(path)
    if doc is None:
        raise ScenarioFileError(f"{shown}: cannot be read as TOML")
    runners = list(runners)
    try:
        top = Table(doc, file=shown)
        study = top.table(STUDY_TABLE, required=True)
        runner = study.string("runner")
        if runner not in runners:
            study.fail("runner", f'unknown runner "{runner}"{did_you_mean(runner, runners)} '
                                 f"(runners: {', '.join(runners)})")
        title = study.string("title", "")
        requires = read_requires(study)
        study.close()
        top.accept_all()  # the runner reads its own tables
    except StructureFileError as exc:  # Table raises StructureFileError; re-badge it
        raise ScenarioFileError(str(exc)) from None
    return OwnStudy(path=path, runner=runner, title=title, name=path.resolve().parent.name,
                    requires=requires)
