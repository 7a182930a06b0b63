"""Claims of a study (``claims.toml`` beside its scenarios), judged on the measured table.

A claim is a sentence of the dissertation turned into checks on the study's table; this
module reads the claims file (every check parsed once, into :class:`Check`), judges each
claim (:func:`evaluate_claims`: :class:`ClaimResult` with a :class:`Verdict`) and counts the
text's claims once each (:func:`text_claims`, :func:`headline`).

Format::

    [[claims]]
    id = "lti-free-disp-mds-accurate"      # unique
    source = "§4.1.1, Fig. 4.8"
    quote = "..."                          # the dissertation's words
    restated = [{ source = "§5.3", quote = "..." }]   # optional: later sentences that
                                           # assert the same (judged once, by this entry)
    scenario = "beam_free_displacement"    # or a list: judged in each (e.g. one per noise
                                           # level); FINDINGS gives the verdict in each
    structure = "lti_beam"                 # or a list: the checks must hold for each
    target = "w3"                          # or a list
    checks = ["MDS.total_error < 0.05", "POVR.total_error < MDS.total_error"]
    criterion = "how the words became a threshold"
    note = "optional: what podbench found and why (written after measuring)"
    finding = "optional: the note in one line, shown in FINDINGS.md's table"
    variant = "optional: what this entry judges besides the text's claim under its best-
               supported reading (another reading, solver, target, unit scale, scatter);
               such entries are listed under "also judged" and not counted in the headline"
    part_of = "optional: the id of the claim this entry completes (the same sentence of
               the text judged on another structure); counted once with it"
    checkable = false                      # optional: the literal reading cannot test the
                                           # claim (it holds or fails by construction); not
                                           # counted as reproduced or not: see its sensitivity

With any of ``variant``, ``part_of``, ``checkable`` in the file, FINDINGS.md opens with the
text's claims counted once each (a claim and its ``part_of`` entries together) and lists
the variants below, under "also judged"; there two counted entries (claims of the text and
their ``part_of`` parts) may not run the same checks on the same (scenario, structure,
target): a sentence that asserts what another already did is that claim's ``restated``.

    [[remarks]]                            # optional free-text findings that are not claims
    title = "..."
    text = "..."

    noise_seeds = [0, 1, 2, 3, 4]          # optional (top level): judge every check over
                                           # these noise seeds (below)
    sensitivity = "../sensitivity"         # optional (top level): the folder of the study
                                           # that varies the unstated parameters; its
                                           # verdicts are linked from FINDINGS.md
    [noise_levels]                         # optional: the unstated noise level (below)
    [[bounds]]                             # optional: see podbench.study.bounds
    [nonlinearity]                         # optional: see podbench.study.nonlinearity

**Checks.** A check is ``<operand> <op> <operand>`` with ``op`` one of ``< <= > >=`` and
each operand a number or ``METHOD.metric`` (a method label and a column of the summary
table). A metric operand may name another scenario's row of the same structure and target,
``SCENARIO:METHOD.metric``, and carry a positive factor, ``1.1*SCENARIO:METHOD.metric`` (how
Chapter 5 compares a noisy run with the clean one), and an added or subtracted number,
``SCENARIO:METHOD.metric + 10`` (an absolute margin; with a factor, ``f*REF + c`` is
``f × REF + c``). ``SCENARIO/STRUCTURE/TARGET:METHOD.metric`` names a row of another
structure and target too (how §5.2's rubber-band beam is compared with Chapter 4's NL beam,
a scenario of the same study: the value is measured in the same run, never written into the
check). A claim is *reproduced* when every check holds on every (scenario, structure,
target) row, *not reproduced* when one fails, and *not measured* when a value is missing or
NaN (the one precedence rule, :func:`combine`: a failure outranks a missing value, which
outranks a tie).

**Noise seeds** (``noise_seeds``). A virtual experiment's noisy records are one realization
of the noise; with ``noise_seeds`` every check that reads a row the seeds change (a
threshold, "< 20", as a comparison, "A more accurate than B", "e_noisy <= 1.1 × e_clean") is
judged on each seed's realization (the study's table is the first seed's, the committed
records; the others come from the same experiment file with the noise redrawn,
:mod:`podbench.harness.seeds`). One rule for every check: it **holds** when it holds on
every seed, **fails** when it fails on every seed, and is a **tie** (:attr:`Outcome.TIE`)
when the seeds disagree; the check's line gives the range, mean and standard deviation of
``left − right`` over the seeds. Why the sign on every seed and not ``|mean| < 2 SE``: it is
the paired sign test (the same sign on all of 5 seeds happens by chance with probability
2/2⁵ = 6 % when the two sides are exchangeable), it needs no normal distribution, and one
realization's outlier cannot turn a check that holds on every other seed into a failure.
Rows the seeds do not change (clean records) have one value, judged once.

**The unstated noise level** (``[noise_levels]``)::

    [noise_levels]
    levels = { beam_noise_0pct = 0.0, beam_noise_0p1pct = 0.001, ... }   # one or more
                                           # series (a scenario per level)
    suggested = 0.001                      # the level the text points to
    source = "appendix, tlsdeconv"
    quote = "tol = 1000; %based on SNR of data"
    reading = "how the words give the level"

A claim judged at several of these scenarios is counted at the ``suggested`` level (its
other scenarios, not in the table, as usual); its verdicts over all the levels, and the
level where it stops holding, are reported beside it (:func:`noise_points`), as the verdicts
over any other parameter the text does not state.
"""

from __future__ import annotations

import math
import operator
import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import NamedTuple

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from podbench.core.hints import did_you_mean
from podbench.errors import ScenarioFileError, StructureFileError
from podbench.structures.spec import Table
from podbench.study.bounds import parse_bounds
from podbench.study.nonlinearity import parse_spec

__all__ = ["Verdict", "Outcome", "combine", "Operand", "Check", "Claim", "ClaimsFile",
           "NoiseLevels", "CheckResult", "ClaimResult", "TextClaim", "SeedRows",
           "load_claims", "load_claims_file", "evaluate_claims", "text_claims", "headline",
           "counts_words",
           "check", "checked_rows", "noise_points", "seed_names", "is_comparison",
           "operand_rows", "CHECK_RE", "TIE", "TIE_CHECK", "NOT_CHECKABLE", "MIN_SEEDS"]


class Verdict(str, Enum):
    """A claim's verdict (its value is the words FINDINGS.md writes)."""

    REPRODUCED = "reproduced"
    NOT_REPRODUCED = "not reproduced"
    NOT_MEASURED = "not measured"
    TIE = "tie within the noise seeds' spread"
    NOT_CHECKABLE = "not checkable under the literal reading"

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)


class Outcome(str, Enum):
    """What one check gave on one row (over the noise seeds where they apply)."""

    HOLDS = "holds"
    FAILS = "fails"
    TIE = "tie"
    NOT_MEASURED = "not measured"

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    @property
    def verdict(self) -> Verdict:
        return _OF_OUTCOME[self]


_OF_OUTCOME = {Outcome.HOLDS: Verdict.REPRODUCED, Outcome.FAILS: Verdict.NOT_REPRODUCED,
               Outcome.TIE: Verdict.TIE, Outcome.NOT_MEASURED: Verdict.NOT_MEASURED}

_PRECEDENCE = (Verdict.NOT_REPRODUCED, Verdict.NOT_MEASURED, Verdict.TIE, Verdict.REPRODUCED)
"""The one precedence rule: a failing part makes a claim not reproduced; otherwise a part
not measured makes it not measured; otherwise a tie makes it a tie."""


def combine(parts: Iterable) -> Verdict:
    """The verdict of several parts (:class:`Verdict` or :class:`Outcome` values, e.g. a
    claim's checks, its scenarios, a claim and its ``part_of`` entries), by
    :data:`_PRECEDENCE`; reproduced when there is none."""
    got = {p.verdict if isinstance(p, Outcome) else Verdict(p) for p in parts}
    return next((v for v in _PRECEDENCE if v in got), Verdict.REPRODUCED)


TIE = Verdict.TIE
"""A claim's verdict when nothing fails and a check is a tie over the noise seeds."""
TIE_CHECK = Outcome.TIE
"""A check's outcome when the noise seeds disagree."""
NOT_CHECKABLE = Verdict.NOT_CHECKABLE

# --------------------------------------------------------------------------- the grammar
_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_OPERAND = (rf"(?:[-+]?{_NUMBER}|[^\s<>=.][^<>=]*?\.[a-z_0-9]+"
            rf"(?:\s*[-+]\s*{_NUMBER})?)")
CHECK_RE = re.compile(rf"^\s*({_OPERAND})\s*(<=|>=|<|>)\s*({_OPERAND})\s*$")
_FACTOR_RE = re.compile(rf"^\s*({_NUMBER})\s*\*\s*(.+)$")
_OFFSET_RE = re.compile(rf"^(.*?\.[a-z_0-9]+)\s*([-+])\s*({_NUMBER})\s*$")


@dataclass(frozen=True)
class Operand:
    """One side of a check: a plain number, or ``factor × METHOD.metric + offset`` of a row
    (of another scenario, structure and target where ``scenario`` etc. are given)."""

    text: str
    number: float | None = None
    label: str = ""
    metric: str = ""
    scenario: str = ""
    structure: str = ""
    target: str = ""
    factor: float = 1.0
    offset: float = 0.0
    error: str = ""
    """Why the operand names no row (a malformed ``SCENARIO/…`` part), else empty."""

    @classmethod
    def parse(cls, text: str) -> Operand:
        text = text.strip()
        try:
            return cls(text, number=float(text))
        except ValueError:
            pass
        ref, factor, offset = text, 1.0, 0.0
        if (om := _OFFSET_RE.match(ref)) is not None:
            ref = om.group(1)
            offset = float(om.group(3)) * (1.0 if om.group(2) == "+" else -1.0)
        if (fm := _FACTOR_RE.match(ref)) is not None:
            factor, ref = float(fm.group(1)), fm.group(2)
        label, _, metric = ref.rpartition(".")
        scen, sep, label = label.rpartition(":")
        where, error = ["", "", ""], ""
        if sep:
            first, *rest = scen.split("/")
            if len(rest) not in (0, 2) or not all([first, *rest]):
                error = "expected SCENARIO or SCENARIO/STRUCTURE/TARGET"
            where = [first, *(rest if len(rest) == 2 else ("", ""))]
        return cls(text, label=label.strip(), metric=metric, scenario=where[0],
                   structure=where[1], target=where[2], factor=factor, offset=offset,
                   error=error)

    @property
    def is_number(self) -> bool:
        return self.number is not None

    def row(self, scenario: str, structure: str, target: str) -> tuple:
        """``(scenario, structure, target, method, metric)`` this operand reads when the
        check is judged on the given row."""
        return (self.scenario or scenario, self.structure or structure,
                self.target or target, self.label, self.metric)

    def value(self, rows_of, scenario: str, structure: str, target: str) -> tuple:
        """``(value, shown)``: NaN with the reason where the row or column is missing
        (``rows_of(scenario, structure, target)``: method label → row dict)."""
        if self.number is not None:
            return self.number, self.text
        if self.error:
            return math.nan, f"{self.text} ({self.error})"
        sc, st, tg, label, metric = self.row(scenario, structure, target)
        row = rows_of(sc, st, tg).get(label)
        if row is None or metric not in row:
            return math.nan, f"{self.text} (no such row/column)"
        v = self.factor * float(row[metric]) + self.offset
        return v, f"{self.text} = {v:.4g}"


@dataclass(frozen=True)
class Check:
    """A check ``left op right``, parsed once (:meth:`parse`)."""

    text: str
    left: Operand
    op: str
    right: Operand

    @classmethod
    def parse(cls, text) -> Check:
        if isinstance(text, Check):
            return text
        m = CHECK_RE.match(str(text))
        if m is None:
            raise ValueError(f'"{text}" is not `<operand> <op> <operand>` (op one of < <= > '
                             ">=, operand a number or METHOD.metric)")
        return cls(str(text), Operand.parse(m.group(1)), m.group(2), Operand.parse(m.group(3)))

    def __str__(self) -> str:
        return self.text

    @property
    def is_comparison(self) -> bool:
        """A measured quantity on both sides (not a quantity against a plain number)."""
        return not self.left.is_number and not self.right.is_number

    def rows(self, scenario: str, structure: str, target: str) -> list[tuple]:
        """The rows the check reads on ``(scenario, structure, target)``:
        ``(scenario, structure, target, method, metric)`` of each measured operand."""
        return [o.row(scenario, structure, target) for o in (self.left, self.right)
                if not o.is_number]

    def values(self, rows_of, scenario: str, structure: str, target: str) -> tuple:
        """``(a, b, shown)``: both sides' values (NaN when not measurable) and the check
        as FINDINGS shows it."""
        a, sa = self.left.value(rows_of, scenario, structure, target)
        b, sb = self.right.value(rows_of, scenario, structure, target)
        shown = f"{sa} {self.op} {sb}" if not self.right.is_number else f"{sa} {self.op} {b:g}"
        return a, b, shown

    def holds(self, a: float, b: float) -> bool:
        return bool(_OPS[self.op](a, b))


def is_comparison(expr) -> bool:
    """Whether a check compares two measured quantities (a str or :class:`Check`)."""
    try:
        return Check.parse(expr).is_comparison
    except ValueError:
        return False


def operand_rows(expr, scenario: str, structure: str, target: str) -> list[tuple]:
    """The rows a check reads (:meth:`Check.rows`)."""
    return Check.parse(expr).rows(scenario, structure, target)


def check(expr, rows: dict, other=None) -> tuple[bool | None, str]:
    """One check on ``rows`` (method label → row dict): ``(holds, shown)``, ``holds`` None
    when not measurable. ``other(scenario, structure=None, target=None)`` gives the rows of
    another scenario (by default of the same structure and target)."""
    c = Check.parse(expr)

    def rows_of(sc, st, tg):
        if sc == "":
            return rows
        return other(sc, st or None, tg or None) if other is not None else {}

    a, b, shown = c.values(rows_of, "", "", "")
    if math.isnan(a) or math.isnan(b):
        return None, shown
    return c.holds(a, b), shown


# ------------------------------------------------------------------------- the claims
@dataclass(frozen=True)
class Claim:
    id: str
    source: str
    quote: str
    scenario: str
    """The first (or only) scenario the claim is judged in."""
    structures: tuple[str, ...]
    targets: tuple[str, ...]
    checks: tuple
    """The checks, each a :class:`Check` (strings given to the constructor are parsed)."""
    criterion: str
    note: str
    finding: str = ""
    scenarios: tuple[str, ...] = ()
    """Every scenario the claim is judged in (``scenario`` given as a list); empty means
    ``(scenario,)``."""
    variant: str = ""
    """Non-empty: an "also judged" entry (another reading, solver, unit scale, …), not one
    of the text's claims counted in the headline."""
    part_of: str = ""
    """The id of the text claim this entry completes (counted once with it)."""
    checkable: bool = True
    """False: the literal reading cannot test the claim (not counted either way)."""
    restated: tuple = ()
    """``(source, quote)`` of later sentences asserting the same (judged by this entry)."""

    def __post_init__(self):
        object.__setattr__(self, "checks", tuple(Check.parse(c) for c in self.checks))

    def all_scenarios(self) -> tuple[str, ...]:
        return self.scenarios or (self.scenario,)

    @property
    def counted(self) -> bool:
        """Whether the entry is one of the text's claims or a part of one."""
        return not self.variant


@dataclass(frozen=True)
class NoiseLevels:
    """The ``[noise_levels]`` table: the per-channel noise level of each scenario of the
    noise series and the level the text points to."""

    levels: dict
    suggested: float
    source: str
    quote: str
    reading: str

    def suggested_scenarios(self) -> set:
        """The scenarios at the suggested level (one per series)."""
        return {s for s, v in self.levels.items() if v == self.suggested}


@dataclass(frozen=True)
class ClaimsFile:
    """Everything a claims file declares; ``sensitivity`` is the resolved folder or None."""

    path: Path
    claims: list
    remarks: list
    bounds: list
    sensitivity: Path | None
    nonlinearity: object = None
    """The ``[nonlinearity]`` table (:class:`~podbench.study.nonlinearity.
    NonlinearitySpec`) or None."""
    noise_seeds: tuple[int, ...] = ()
    """The noise seeds every check is judged over (empty: the study's records only)."""
    noise_levels: NoiseLevels | None = None


def _listify(t: Table, key: str) -> tuple[str, ...]:
    v = t.raw(key)
    if isinstance(v, str):
        return (v,)
    if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
        return tuple(v)
    t.fail(key, f"expected a string or a non-empty array of strings, got {v!r}")
    return ()  # pragma: no cover


def _boolean(t: Table, key: str) -> bool:
    v = t.raw(key, True)
    if not isinstance(v, bool):
        t.fail(key, f"expected true or false, got {v!r}")
    return v


def _restated(t: Table) -> tuple:
    out = []
    for i, r in enumerate(t.raw("restated", [])):
        if not (isinstance(r, dict) and set(r) == {"source", "quote"}
                and all(isinstance(x, str) and x for x in r.values())):
            t.fail(f"restated[{i}]", "expected { source = \"…\", quote = \"…\" }")
        out.append((r["source"], r["quote"]))
    return tuple(out)


def _claim(t: Table) -> Claim:
    scens = _listify(t, "scenario")
    checks = tuple(t.strings("checks"))
    parsed = []
    for i, chk in enumerate(checks):
        try:
            parsed.append(Check.parse(chk))
        except ValueError as exc:
            t.fail(f"checks[{i}]", str(exc))
    c = Claim(id=t.string("id"), source=t.string("source"), quote=t.string("quote"),
              scenario=scens[0], scenarios=scens if len(scens) > 1 else (),
              structures=_listify(t, "structure"), targets=_listify(t, "target"),
              checks=tuple(parsed), criterion=t.string("criterion", ""),
              note=t.string("note", ""), finding=t.string("finding", ""),
              variant=t.string("variant", ""), part_of=t.string("part_of", ""),
              checkable=_boolean(t, "checkable"), restated=_restated(t))
    t.close()
    return c


def _check_links(top: Table, claims: list) -> None:
    """``part_of`` names a claim of the text; in a file that counts the text's claims apart
    from its variants, no two counted entries run the same checks on the same rows (a
    restatement is its claim's ``restated``)."""
    main = {c.id for c in claims if not c.variant and not c.part_of}
    text_first = any(c.variant or c.part_of or not c.checkable for c in claims)
    seen: dict = {}
    for i, c in enumerate(claims):
        t = top.tables("claims", [])[i]
        if c.part_of and c.part_of not in main:
            t.fail("part_of", f'"{c.part_of}" is not the id of a claim of the text (one '
                              "without `variant` or `part_of`)")
        if c.variant and c.part_of:
            t.fail("part_of", "give `variant` or `part_of`, not both")
        if not c.counted or not text_first:
            continue
        key = (frozenset(str(k) for k in c.checks), frozenset(
            (s, st, tg) for s in c.all_scenarios() for st in c.structures for tg in c.targets))
        if key in seen:
            t.fail("checks", f'the same checks on the same rows as claim "{seen[key]}": a '
                             "sentence that asserts the same is that claim's `restated`")
        seen[key] = c.id


def _noise_levels(top: Table) -> NoiseLevels | None:
    if not top.has("noise_levels"):
        return None
    t = top.table("noise_levels")
    raw = t.raw("levels")
    if not (isinstance(raw, dict) and len(raw) >= 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < 1
            for v in raw.values())):
        t.fail("levels", "expected a table of at least two `scenario = level` (a fraction "
                         "in [0, 1))")
    levels = {str(k): float(v) for k, v in sorted(raw.items(), key=lambda kv: kv[1])}
    suggested = t.number("suggested")
    if suggested not in levels.values():
        t.fail("suggested", f"{suggested!r} is not one of the levels {sorted(levels.values())}")
    out = NoiseLevels(levels, suggested, t.string("source"), t.string("quote"),
                      t.string("reading"))
    t.close()
    return out


def load_claims(path) -> tuple[list[Claim], list[dict]]:
    """Claims and remarks of a claims file (clear errors naming the file and field)."""
    f = load_claims_file(path)
    return f.claims, f.remarks


def load_claims_file(path) -> ClaimsFile:
    """Everything a claims file declares (clear errors naming the file and field)."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ScenarioFileError(f"{path}: cannot read the claims file ({exc})") from None
    try:
        top = Table(doc, file=str(path))
        claims, ids = [], set()
        for t in top.tables("claims", []):
            c = _claim(t)
            if c.id in ids:
                t.fail("id", f'"{c.id}" is used twice')
            ids.add(c.id)
            claims.append(c)
        _check_links(top, claims)
        remarks = []
        for t in top.tables("remarks", []):
            remarks.append({"title": t.string("title"), "text": t.string("text")})
            t.close()
        bounds = parse_bounds(top)
        sensitivity = None
        if top.has("sensitivity"):
            sensitivity = (path.parent / top.string("sensitivity")).resolve()
            if not sensitivity.is_dir():
                top.fail("sensitivity", f"{sensitivity} is not a folder of scenarios")
        nonlinearity = parse_spec(top.table("nonlinearity")) if top.has("nonlinearity") \
            else None
        seeds = _noise_seeds(top)
        levels = _noise_levels(top)
        top.close()
    except StructureFileError as exc:
        raise ScenarioFileError(str(exc)) from None
    return ClaimsFile(path, claims, remarks, bounds, sensitivity, nonlinearity, seeds, levels)


def check_claims(claims_file: ClaimsFile, scenarios: dict, metrics: Iterable[str]) -> None:
    """Check every claim on the scenarios of the run before any work: its structures and
    targets are the scenario's, each ``METHOD.metric`` names a method label of its scenario
    and a column of the summary (``metrics``). A claim on a scenario outside ``scenarios``
    (another part of the study, the nonlinearity checks' rows) is not checked here.

    Raises
    ------
    ScenarioFileError
        One line naming the claims file, the field and the name, with the valid names.
    """
    metrics = tuple(metrics)
    for i, c in enumerate(claims_file.claims):
        head = f"{claims_file.path}: field `claims[{i}]"
        for s in c.all_scenarios():
            sc = scenarios.get(s)
            for key, names, valid in (("structure", c.structures, sc and sc.structures),
                                      ("target", c.targets, sc and sc.targets)):
                for name in names if sc is not None else ():
                    if name not in valid:
                        raise ScenarioFileError(
                            f'{head}.{key}`: "{name}" is not a {key} of scenario {s} '
                            f"({', '.join(valid)}){did_you_mean(name, valid)}")
            for j, chk in enumerate(c.checks):
                for op in (chk.left, chk.right):
                    other = scenarios.get(op.scenario or s)
                    if op.is_number or op.error or other is None:
                        continue
                    labels = [m.label for m in other.methods]
                    where = f"{head}.checks[{j}]`: `{op.text}`"
                    if op.label not in labels:
                        raise ScenarioFileError(
                            f'{where}: no method labelled "{op.label}" in scenario '
                            f"{other.name} ({', '.join(labels)}){did_you_mean(op.label, labels)}")
                    if op.metric not in metrics:
                        raise ScenarioFileError(
                            f'{where}: "{op.metric}" is not a column of summary.csv '
                            f"({', '.join(metrics)}){did_you_mean(op.metric, metrics)}")


MIN_SEEDS = 5
"""The fewest noise seeds a check is judged over (a spread needs them)."""


def _noise_seeds(top: Table) -> tuple[int, ...]:
    seeds = tuple(top.integers("noise_seeds", [], minimum=0))
    if seeds and len(seeds) < MIN_SEEDS:
        top.fail("noise_seeds", f"expected at least {MIN_SEEDS} seeds (a spread needs "
                                f"them), got {list(seeds)}")
    if len(set(seeds)) != len(seeds):
        top.fail("noise_seeds", f"a seed is listed twice: {list(seeds)}")
    return seeds


# ------------------------------------------------------------------------ the verdicts
def seed_names(seeds) -> str:
    """``seeds 0–4`` for consecutive seeds, else ``seeds 0, 3, 7``."""
    seeds = list(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"seeds {seeds[0]}–{seeds[-1]}"
    return "seed " + str(seeds[0]) if len(seeds) == 1 else \
        "seeds " + ", ".join(str(k) for k in seeds)


@dataclass(frozen=True)
class SeedRows:
    """The checked rows on every noise seed (:mod:`podbench.harness.seeds`).

    ``table`` holds the rows of the scenarios in ``varied`` (those whose records the seed
    changes) with a ``seed`` column, for every seed but the first; the first seed's rows
    are the study's table. A scenario not in ``varied`` has the same rows on every seed."""

    seeds: tuple[int, ...]
    table: object
    varied: frozenset = frozenset()


@dataclass(frozen=True)
class CheckResult:
    """One check judged on one (scenario, structure, target)."""

    scenario: str
    structure: str
    target: str
    check: Check
    shown: str
    outcome: Outcome


@dataclass(frozen=True)
class ClaimResult:
    """A claim judged: its counted ``verdict``, the verdict in each scenario and every
    check's result. ``verdict`` combines the scenarios, the noise series counted at its
    suggested level (``noise_levels``); ``verdict_all`` combines every scenario."""

    claim: Claim
    verdict: Verdict
    details: tuple = ()
    by_scenario: dict = field(default_factory=dict)
    verdict_all: Verdict = Verdict.REPRODUCED

    def __getitem__(self, key: str):
        """The former dict form (``result["verdict"]``)."""
        if key not in ("claim", "verdict", "details", "by_scenario", "verdict_all"):
            raise KeyError(key)
        return getattr(self, key)


def _spread(k_hold: int, seeds, d: np.ndarray) -> str:
    sd = float(d.std(ddof=1)) if d.size > 1 else 0.0
    if sd <= d.size * np.finfo(float).eps * float(np.abs(d).max()):
        sd = 0.0  # equal differences: what is left is the mean's round-off (sd 7.8e-18 / 0)
    return (f"; over {seed_names(seeds)}: holds on {k_hold} of {len(seeds)}, left − right "
            f"from {d.min():+.3g} to {d.max():+.3g} (mean {d.mean():+.3g}, sd {sd:.2g})")


def _judge(c: Check, rows_at, seeds, where) -> tuple[Outcome, str]:
    """One check on one row: on the study's table, or on every seed (one rule: holds on
    all, fails on all, else a tie) when ``seeds`` is given."""
    diffs, holds, shown0 = [], [], ""
    for i, k in enumerate(seeds or (None,)):
        a, b, shown = c.values(rows_at(k), *where)
        if i == 0:
            shown0 = shown
        if math.isnan(a) or math.isnan(b):
            return Outcome.NOT_MEASURED, shown if k is None else f"{shown} (seed {k})"
        diffs.append(a - b)
        holds.append(c.holds(a, b))
    n_hold = sum(holds)
    outcome = (Outcome.HOLDS if n_hold == len(holds) else Outcome.FAILS if n_hold == 0
               else Outcome.TIE)
    if not seeds:
        return outcome, shown0
    return outcome, shown0 + _spread(n_hold, seeds, np.asarray(diffs))


def _rows_of(table, scen, s, t) -> dict:
    sub = table[(table.scenario == scen) & (table.structure == s) & (table.target == t)]
    return {r["method"]: r for r in sub.to_dict("records")}


def _counted(claim: Claim, by: dict, levels: NoiseLevels | None) -> Verdict:
    """The counted verdict: every scenario's, the noise series at its suggested level."""
    if levels is not None:
        noise = [s for s in by if s in levels.levels]
        at = levels.suggested_scenarios() & set(noise)
        if len(noise) > 1 and at:
            return combine(v for s, v in by.items() if s not in levels.levels or s in at)
    return combine(by.values())


def evaluate_claims(claims, table, *, scenarios=None, seeds: SeedRows | None = None,
                    noise_levels: NoiseLevels | None = None) -> list[ClaimResult]:
    """Every claim judged on the summary table (a pandas DataFrame).

    A claim over several scenarios is judged in those of ``scenarios`` (default: all it
    names); ``by_scenario`` maps each to its own verdict. With ``seeds`` every check that
    reads a row the seeds change is judged over the noise seeds (module docstring); with
    ``noise_levels`` a claim judged over the noise series is counted at its suggested level.
    """
    memo: dict = {}

    def rows_of(scen, s, t, k=None):
        key = (scen, s, t, k)
        if key not in memo:
            if seeds is None or k is None or k == seeds.seeds[0] or scen not in seeds.varied:
                memo[key] = _rows_of(table, scen, s, t)
            else:
                sub = seeds.table
                memo[key] = _rows_of(sub[sub.seed == k], scen, s, t)
        return memo[key]

    out = []
    for c in claims:
        details, by_scenario = [], {}
        for scen in c.all_scenarios():
            if scenarios is not None and scen not in scenarios:
                continue
            mine = []
            for s in c.structures:
                for t in c.targets:
                    for chk in c.checks:
                        varied = seeds is not None and any(
                            r[0] in seeds.varied for r in chk.rows(scen, s, t))
                        outcome, shown = _judge(
                            chk, lambda k: (lambda sc, st, tg, k=k: rows_of(sc, st, tg, k)),
                            seeds.seeds if varied else None, (scen, s, t))
                        mine.append(outcome)
                        details.append(CheckResult(scen, s, t, chk, shown, outcome))
            by_scenario[scen] = combine(mine)
        out.append(ClaimResult(c, _counted(c, by_scenario, noise_levels), tuple(details),
                               by_scenario, combine(by_scenario.values())))
    return out


class TextClaim(NamedTuple):
    """One of the text's claims with the entries that are ``part_of`` it, and the verdict
    over all of them."""

    entry: ClaimResult
    parts: list
    verdict: Verdict


def text_claims(evaluated, *, every_level: bool = False) -> list[TextClaim]:
    """The text's claims, each once, with the verdict over the claim and its ``part_of``
    entries (:func:`combine`; :attr:`Verdict.NOT_CHECKABLE` for a claim marked
    ``checkable = false``). ``every_level``: judged at every noise level instead of the
    suggested one (``verdict_all``)."""
    out = []
    for e in evaluated:
        c = e.claim
        if c.variant or c.part_of:
            continue
        parts = [p for p in evaluated if p.claim.part_of == c.id]
        pick = (lambda x: x.verdict_all) if every_level else (lambda x: x.verdict)
        v = Verdict.NOT_CHECKABLE if not c.checkable else combine(pick(x) for x in [e, *parts])
        out.append(TextClaim(e, parts, v))
    return out


def headline(verdicts) -> dict:
    """How many of each :class:`Verdict` (every kind present, zero or not)."""
    verdicts = list(verdicts)
    return {v: sum(x == v for x in verdicts) for v in Verdict}


_ORDER = (Verdict.REPRODUCED, Verdict.NOT_REPRODUCED, Verdict.TIE, Verdict.NOT_MEASURED,
          Verdict.NOT_CHECKABLE)


def counts_words(verdicts) -> str:
    """"5 reproduced, 3 not reproduced, …": the kinds present, reproduced and not reproduced
    always (the one way FINDINGS.md, the report and the command line count verdicts)."""
    n = headline(verdicts)
    return ", ".join(f"{n[k]} {k}" for k in _ORDER
                     if n[k] or k in (Verdict.REPRODUCED, Verdict.NOT_REPRODUCED))


def checked_rows(claims, scenarios=None) -> dict:
    """``(scenario, structure) → (methods, targets, twinned)``: the rows every check of
    ``claims`` reads (in the ``scenarios`` judged, default all), as sorted tuples, with the
    methods whose ``diagonalization_error`` is read (it needs the coupled twin) — what
    :mod:`podbench.harness.seeds` refits on the other noise seeds."""
    need: dict = {}
    for c in claims:
        for scen in c.all_scenarios():
            if scenarios is not None and scen not in scenarios:
                continue
            for s in c.structures:
                for t in c.targets:
                    for chk in c.checks:
                        for sc, st, tg, label, metric in chk.rows(scen, s, t):
                            m, ts, tw = need.setdefault((sc, st), (set(), set(), set()))
                            m.add(label)
                            ts.add(tg)
                            if metric == "diagonalization_error":
                                tw.add(label)
    return {k: (tuple(sorted(m)), tuple(sorted(ts)), tuple(sorted(tw)))
            for k, (m, ts, tw) in sorted(need.items())}


def noise_points(result: ClaimResult, levels: NoiseLevels) -> list[dict]:
    """The claim's verdict at each level of the noise series it is judged at, in increasing
    level: ``{"value": level, "verdict": Verdict, "scenario": name}`` (empty when it is
    judged at fewer than two)."""
    pts = [{"value": lv, "verdict": result.by_scenario[s], "scenario": s}
           for s, lv in levels.levels.items() if s in result.by_scenario]
    return pts if len(pts) > 1 else []
