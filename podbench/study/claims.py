"""Claims of a study (``claims.toml`` beside its scenarios), checked on the measured table.

Format::

    [[claims]]
    id = "lti-free-disp-mds-accurate"      # unique
    source = "§4.1.1, Fig. 4.8"
    quote = "..."                          # the dissertation's words
    scenario = "beam_free_displacement"    # or a list: judged in each (e.g. one per noise
                                           # level); FINDINGS gives the verdict in each
    structure = "lti_beam"                 # or a list: the checks must hold for each
    target = "w3"                          # or a list
    checks = ["MDS.total_error < 0.05", "POVR.total_error < MDS.total_error"]
    criterion = "how the words became a threshold"
    note = "optional: what podbench found and why (written after measuring)"
    finding = "optional: the note in one line, shown in FINDINGS.md's table"

    [[remarks]]                            # optional free-text findings that are not claims
    title = "..."
    text = "..."

    sensitivity = "../sensitivity"         # optional (top level): the folder of the study
                                           # that varies the unstated parameters; its
                                           # verdicts are linked from FINDINGS.md
    [[bounds]]                             # optional: see podbench.study.bounds
    [nonlinearity]                         # optional: see podbench.study.nonlinearity

A check is ``<operand> <op> <operand>`` with ``op`` one of ``< <= > >=`` and each operand a
number or ``METHOD.metric`` (a method label and a column of the summary table). A metric
operand may name another scenario's row of the same structure and target,
``SCENARIO:METHOD.metric``, and carry a positive factor, ``1.1*SCENARIO:METHOD.metric`` (how
Chapter 5 compares a noisy run with the clean one), and an added or subtracted number,
``SCENARIO:METHOD.metric + 10`` (an absolute margin: §5.3's "5-10%" read as percentage
points; with a factor, ``f*REF + c`` is ``f × REF + c``).
``SCENARIO/STRUCTURE/TARGET:METHOD.metric`` names a row of another structure and target
too (how §5.2's rubber-band beam is compared with Chapter 4's NL beam, a scenario of the
same study: the value is measured in the same run, never written into the check). A
claim is *reproduced* when every check holds on every (scenario, structure, target) row,
*not reproduced* when one fails, and *not measured* when a value is missing or NaN.
"""

from __future__ import annotations

import math
import operator
import re
import sys
from dataclasses import dataclass
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from podbench.errors import ScenarioFileError, StructureFileError
from podbench.structures.spec import Table
from podbench.study.bounds import parse_bounds
from podbench.study.nonlinearity import parse_spec

__all__ = ["Claim", "ClaimsFile", "load_claims", "load_claims_file", "evaluate_claims",
           "CHECK_RE"]

_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_OPERAND = (rf"(?:[-+]?{_NUMBER}|[^\s<>=.][^<>=]*?\.[a-z_0-9]+"
            rf"(?:\s*[-+]\s*{_NUMBER})?)")
CHECK_RE = re.compile(rf"^\s*({_OPERAND})\s*(<=|>=|<|>)\s*({_OPERAND})\s*$")


@dataclass(frozen=True)
class Claim:
    id: str
    source: str
    quote: str
    scenario: str
    """The first (or only) scenario the claim is judged in."""
    structures: tuple[str, ...]
    targets: tuple[str, ...]
    checks: tuple[str, ...]
    criterion: str
    note: str
    finding: str = ""
    scenarios: tuple[str, ...] = ()
    """Every scenario the claim is judged in (``scenario`` given as a list); empty means
    ``(scenario,)``."""

    def all_scenarios(self) -> tuple[str, ...]:
        return self.scenarios or (self.scenario,)


def _listify(t: Table, key: str) -> tuple[str, ...]:
    v = t.raw(key)
    if isinstance(v, str):
        return (v,)
    if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
        return tuple(v)
    t.fail(key, f"expected a string or a non-empty array of strings, got {v!r}")
    return ()  # pragma: no cover


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


def load_claims(path) -> tuple[list[Claim], list[dict]]:
    """Claims and remarks of a claims file (clear errors naming the file and field)."""
    f = load_claims_file(path)
    return f.claims, f.remarks


def load_claims_file(path) -> ClaimsFile:
    """The claims, remarks, bounds and sensitivity folder of a claims file (clear errors
    naming the file and field)."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ScenarioFileError(f"{path}: cannot read the claims file ({exc})") from None
    try:
        top = Table(doc, file=str(path))
        claims, ids = [], set()
        for t in top.tables("claims", []):
            scens = _listify(t, "scenario")
            c = Claim(
                id=t.string("id"), source=t.string("source"), quote=t.string("quote"),
                scenario=scens[0], scenarios=scens if len(scens) > 1 else (),
                structures=_listify(t, "structure"),
                targets=_listify(t, "target"), checks=tuple(t.strings("checks")),
                criterion=t.string("criterion", ""), note=t.string("note", ""),
                finding=t.string("finding", ""),
            )
            if c.id in ids:
                t.fail("id", f'"{c.id}" is used twice')
            ids.add(c.id)
            for i, chk in enumerate(c.checks):
                if not CHECK_RE.match(chk):
                    t.fail(f"checks[{i}]", f'"{chk}" is not `<operand> <op> <operand>` '
                                           "(op one of < <= > >=, operand a number or "
                                           "METHOD.metric)")
            t.close()
            claims.append(c)
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
        nonlinearity = None
        if top.has("nonlinearity"):
            nonlinearity = parse_spec(top.table("nonlinearity"))
        top.close()
    except StructureFileError as exc:
        raise ScenarioFileError(str(exc)) from None
    return ClaimsFile(path, claims, remarks, bounds, sensitivity, nonlinearity)


_FACTOR_RE = re.compile(r"^\s*((?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*\*\s*(.+)$")
_OFFSET_RE = re.compile(rf"^(.*?\.[a-z_0-9]+)\s*([-+])\s*({_NUMBER})\s*$")


def _value(operand: str, rows: dict, other=None):
    try:
        return float(operand), operand
    except ValueError:
        pass
    factor, offset, ref = 1.0, 0.0, operand
    if (om := _OFFSET_RE.match(ref)) is not None:
        ref = om.group(1)
        offset = float(om.group(3)) * (1.0 if om.group(2) == "+" else -1.0)
    if (fm := _FACTOR_RE.match(ref)) is not None:
        factor, ref = float(fm.group(1)), fm.group(2)
    label, _, metric = ref.rpartition(".")
    scen, sep, label = label.rpartition(":")
    if sep:
        scen, *where = scen.split("/")
        if len(where) not in (0, 2) or not all(where):
            return math.nan, f"{operand} (expected SCENARIO or SCENARIO/STRUCTURE/TARGET)"
        rows = other(scen, *where) if other is not None else {}
    row = rows.get(label)
    if row is None or metric not in row:
        return math.nan, f"{operand} (no such row/column)"
    v = factor * float(row[metric]) + offset
    return v, f"{operand} = {v:.4g}"


def check(expr: str, rows: dict, other=None) -> tuple[bool | None, str]:
    """Evaluate one check on ``rows`` (method label -> row dict). None when not measurable.

    ``other(scenario, structure=None, target=None)`` gives the rows of another scenario (by
    default of the same structure and target) for ``SCENARIO:METHOD.metric`` and
    ``SCENARIO/STRUCTURE/TARGET:METHOD.metric`` operands."""
    m = CHECK_RE.match(expr)
    a, sa = _value(m.group(1), rows, other)
    b, sb = _value(m.group(3), rows, other)
    shown = f"{sa} {m.group(2)} {sb}" if not _is_num(m.group(3)) else f"{sa} {m.group(2)} {b:g}"
    if math.isnan(a) or math.isnan(b):
        return None, shown
    return bool(_OPS[m.group(2)](a, b)), shown


def _is_num(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def _verdict(oks) -> str:
    if any(v is False for v in oks):
        return "not reproduced"
    if any(v is None for v in oks):
        return "not measured"
    return "reproduced"


def evaluate_claims(claims, table, *, scenarios=None) -> list[dict]:
    """Verdicts of every claim on the summary table (a pandas DataFrame).

    A claim over several scenarios is judged in those of ``scenarios`` (default: all it
    names); ``by_scenario`` maps each to its own verdict, the overall verdict combines them.
    """

    def rows_of(scen, s, t):
        sub = table[(table.scenario == scen) & (table.structure == s) & (table.target == t)]
        return {r["method"]: r for r in sub.to_dict("records")}

    out = []
    for c in claims:
        details, verdicts, by_scenario = [], [], {}
        for scen in c.all_scenarios():
            if scenarios is not None and scen not in scenarios:
                continue
            mine = []
            for s in c.structures:
                for t in c.targets:
                    rows = rows_of(scen, s, t)
                    for expr in c.checks:
                        ok, shown = check(
                            expr, rows,
                            lambda o, s2=None, t2=None, s=s, t=t: rows_of(o, s2 or s, t2 or t))
                        mine.append(ok)
                        details.append({"scenario": scen, "structure": s, "target": t,
                                        "check": expr, "shown": shown, "holds": ok})
            by_scenario[scen] = _verdict(mine)
            verdicts.extend(mine)
        out.append({"claim": c, "verdict": _verdict(verdicts), "details": details,
                    "by_scenario": by_scenario})
    return out
