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
the variants below, under "also judged".

    [[remarks]]                            # optional free-text findings that are not claims
    title = "..."
    text = "..."

    noise_seeds = [0, 1, 2, 3, 4]          # optional (top level): judge every comparison
                                           # over these noise seeds (below)
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

**Comparisons over noise seeds** (``noise_seeds``; issue 24 item 8). A *comparison* is a
check with a measured quantity on both sides ("ML-tls.total_error < SL-tls.total_error",
"TLS at or below LS", "e_noisy <= 1.1 × e_clean"); a check against a plain number is a
threshold. With ``noise_seeds`` every comparison is judged on each seed's realization of
the noisy records (the study's table is the first seed's, the committed records; the
others come from the same experiment file with the noise redrawn, :mod:`podbench.harness.
seeds`), as the paired difference ``d_k = A_k − B_k`` of its two sides on seed ``k``. The
rule: the comparison **holds** when it holds on every seed, **fails** when it fails on
every seed, and is a **tie** (:data:`TIE`) when the seeds disagree — its mean difference is
then smaller than the seeds' spread of ``d`` (their range straddles 0), so the seeds'
run-to-run scatter, not the methods, decides it; the check's line gives ``d``'s range,
mean and standard deviation over the seeds. Why the sign on every seed and not
``|mean d| < 2 SE``: it is the paired sign test (the same sign on all of 5 seeds happens by
chance with probability 2/2⁵ = 6 % when the two sides are exchangeable), it needs no
normal distribution of ``d``, and one realization's outlier cannot turn a comparison won
on every seed into a tie (SL-tls at 5 % noise on the linear beam: 1.28 on seed 0, 0.31
on the others, which makes ``2 SE`` larger than ML's lead on every seed). A claim with a
failing check is *not reproduced*; otherwise one with a tie is a :data:`TIE`. Records the
seeds do not change (the clean ones) have one value, judged as before. Thresholds
("< 20") are judged on the first seed only.
"""

from __future__ import annotations

import math
import operator
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from podbench.errors import ScenarioFileError, StructureFileError
from podbench.structures.spec import Table
from podbench.study.bounds import parse_bounds
from podbench.study.nonlinearity import parse_spec

__all__ = ["Claim", "ClaimsFile", "load_claims", "load_claims_file", "evaluate_claims",
           "CHECK_RE", "SeedRows", "TIE", "TIE_CHECK", "is_comparison", "operand_rows",
           "seed_names", "comparison_rows"]

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
    variant: str = ""
    """Non-empty: an "also judged" entry (another reading, solver, unit scale, …), not one
    of the text's claims counted in the headline."""
    part_of: str = ""
    """The id of the text claim this entry completes (counted once with it)."""
    checkable: bool = True
    """False: the literal reading cannot test the claim (not counted either way)."""

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
    noise_seeds: tuple[int, ...] = ()
    """The noise seeds every comparison is judged over (empty: the study's records only)."""


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
                variant=t.string("variant", ""), part_of=t.string("part_of", ""),
                checkable=_boolean(t, "checkable"),
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
        main = {c.id for c in claims if not c.variant and not c.part_of}
        for i, c in enumerate(claims):
            if c.part_of and c.part_of not in main:
                top.tables("claims", [])[i].fail(
                    "part_of", f'"{c.part_of}" is not the id of a claim of the text (one '
                               "without `variant` or `part_of`)")
            if c.variant and c.part_of:
                top.tables("claims", [])[i].fail(
                    "part_of", "give `variant` or `part_of`, not both")
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
        seeds = _noise_seeds(top)
        top.close()
    except StructureFileError as exc:
        raise ScenarioFileError(str(exc)) from None
    return ClaimsFile(path, claims, remarks, bounds, sensitivity, nonlinearity, seeds)


MIN_SEEDS = 5
"""The fewest noise seeds a comparison is judged over (issue 24: "measured over ≥ 5
seeds")."""


def _noise_seeds(top: Table) -> tuple[int, ...]:
    seeds = tuple(top.integers("noise_seeds", [], minimum=0))
    if seeds and len(seeds) < MIN_SEEDS:
        top.fail("noise_seeds", f"expected at least {MIN_SEEDS} seeds (a spread needs "
                                f"them), got {list(seeds)}")
    if len(set(seeds)) != len(seeds):
        top.fail("noise_seeds", f"a seed is listed twice: {list(seeds)}")
    return seeds


def _boolean(t: Table, key: str) -> bool:
    v = t.raw(key, True)
    if not isinstance(v, bool):
        t.fail(key, f"expected true or false, got {v!r}")
    return v


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


def _values(expr: str, rows: dict, other=None):
    """``(a, op, b, shown)`` of one check: both operands' values (NaN when not measurable),
    the operator and the check as FINDINGS shows it."""
    m = CHECK_RE.match(expr)
    a, sa = _value(m.group(1), rows, other)
    b, sb = _value(m.group(3), rows, other)
    shown = f"{sa} {m.group(2)} {sb}" if not _is_num(m.group(3)) else f"{sa} {m.group(2)} {b:g}"
    return a, m.group(2), b, shown


def check(expr: str, rows: dict, other=None) -> tuple[bool | None, str]:
    """Evaluate one check on ``rows`` (method label -> row dict). None when not measurable.

    ``other(scenario, structure=None, target=None)`` gives the rows of another scenario (by
    default of the same structure and target) for ``SCENARIO:METHOD.metric`` and
    ``SCENARIO/STRUCTURE/TARGET:METHOD.metric`` operands."""
    a, op, b, shown = _values(expr, rows, other)
    if math.isnan(a) or math.isnan(b):
        return None, shown
    return bool(_OPS[op](a, b)), shown


def is_comparison(expr: str) -> bool:
    """Whether a check compares two measured quantities (both operands ``METHOD.metric``),
    not a quantity with a plain number (a threshold)."""
    m = CHECK_RE.match(expr)
    return m is not None and not _is_num(m.group(1)) and not _is_num(m.group(3))


def operand_rows(expr: str, scenario: str, structure: str, target: str) -> list[tuple]:
    """The rows a check reads: ``(scenario, structure, target, method, metric)`` of each
    measured operand (another scenario's, structure's or target's where the operand names
    it)."""
    m = CHECK_RE.match(expr)
    out = []
    for operand in (m.group(1), m.group(3)):
        if _is_num(operand):
            continue
        ref = operand
        if (om := _OFFSET_RE.match(ref)) is not None:
            ref = om.group(1)
        if (fm := _FACTOR_RE.match(ref)) is not None:
            ref = fm.group(2)
        label, _, metric = ref.rpartition(".")
        scen, sep, label = label.rpartition(":")
        where = [scenario, structure, target]
        if sep:
            first, *rest = scen.split("/")
            where = [first, *(rest if len(rest) == 2 else (structure, target))]
        out.append((*where, label.strip(), metric))
    return out


TIE_CHECK = "tie"
"""A comparison's value in ``details[...]["holds"]`` when the noise seeds disagree."""


def seed_names(seeds) -> str:
    """``seeds 0–4`` for consecutive seeds, else ``seeds 0, 3, 7``."""
    seeds = list(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"seeds {seeds[0]}–{seeds[-1]}"
    return "seed " + str(seeds[0]) if len(seeds) == 1 else \
        "seeds " + ", ".join(str(k) for k in seeds)


def _over_seeds(expr: str, rows_at, other_at, seeds) -> tuple[bool | str | None, str]:
    """A comparison judged on every seed (module docstring: holds on all, fails on all,
    else a tie), shown as the first seed's check and the paired difference over the
    seeds."""
    diffs, holds, shown0 = [], [], ""
    for i, k in enumerate(seeds):
        a, op, b, shown = _values(expr, rows_at(k), other_at(k))
        if i == 0:
            shown0 = shown
        if math.isnan(a) or math.isnan(b):
            return None, f"{shown} (seed {k})"
        diffs.append(a - b)
        holds.append(bool(_OPS[op](a, b)))
    d = np.asarray(diffs)
    n_hold = sum(holds)
    verdict: bool | str = True if n_hold == len(seeds) else False if n_hold == 0 \
        else TIE_CHECK
    sd = float(d.std(ddof=1))
    if sd <= d.size * np.finfo(float).eps * float(np.abs(d).max()):
        sd = 0.0  # equal differences: what is left is the mean's round-off (sd 7.8e-18 / 0)
    spread = (f"; over {seed_names(seeds)}: holds on {n_hold} of {len(seeds)}, left − right "
              f"from {d.min():+.3g} to {d.max():+.3g} (mean {d.mean():+.3g}, sd {sd:.2g})")
    return verdict, shown0 + spread


@dataclass(frozen=True)
class SeedRows:
    """The comparisons' rows on every noise seed (:mod:`podbench.harness.seeds`).

    ``table`` holds the rows of the scenarios in ``varied`` (those whose records the seed
    changes) with a ``seed`` column, for every seed but the first; the first seed's rows
    are the study's table. A scenario not in ``varied`` has the same rows on every seed."""

    seeds: tuple[int, ...]
    table: object
    varied: frozenset = frozenset()


def _is_num(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


TIE = "tie within the noise seeds' spread"
"""A claim's verdict when no check fails and a comparison is a tie over the seeds."""


def _verdict(oks) -> str:
    if any(v is False for v in oks):
        return "not reproduced"
    if any(v is None for v in oks):
        return "not measured"
    if any(v == TIE_CHECK for v in oks):
        return TIE
    return "reproduced"


def _rows_of(table, scen, s, t) -> dict:
    sub = table[(table.scenario == scen) & (table.structure == s) & (table.target == t)]
    return {r["method"]: r for r in sub.to_dict("records")}


def evaluate_claims(claims, table, *, scenarios=None, seeds: SeedRows | None = None
                    ) -> list[dict]:
    """Verdicts of every claim on the summary table (a pandas DataFrame).

    A claim over several scenarios is judged in those of ``scenarios`` (default: all it
    names); ``by_scenario`` maps each to its own verdict, the overall verdict combines them.
    With ``seeds`` every comparison is judged over the noise seeds (module docstring).
    """

    def rows_of(scen, s, t, k=None):
        if seeds is None or k is None or k == seeds.seeds[0] or scen not in seeds.varied:
            return _rows_of(table, scen, s, t)
        sub = seeds.table
        return _rows_of(sub[sub.seed == k], scen, s, t)

    out = []
    for c in claims:
        details, verdicts, by_scenario = [], [], {}
        for scen in c.all_scenarios():
            if scenarios is not None and scen not in scenarios:
                continue
            mine = []
            for s in c.structures:
                for t in c.targets:
                    for expr in c.checks:
                        if seeds is not None and is_comparison(expr):
                            ok, shown = _over_seeds(
                                expr, lambda k, sc=scen, s=s, t=t: rows_of(sc, s, t, k),
                                lambda k, s=s, t=t: (lambda o, s2=None, t2=None:
                                                     rows_of(o, s2 or s, t2 or t, k)),
                                seeds.seeds)
                        else:
                            ok, shown = check(
                                expr, rows_of(scen, s, t),
                                lambda o, s2=None, t2=None, s=s, t=t: rows_of(o, s2 or s,
                                                                              t2 or t))
                        mine.append(ok)
                        details.append({"scenario": scen, "structure": s, "target": t,
                                        "check": expr, "shown": shown, "holds": ok})
            by_scenario[scen] = _verdict(mine)
            verdicts.extend(mine)
        out.append({"claim": c, "verdict": _verdict(verdicts), "details": details,
                    "by_scenario": by_scenario})
    return out


NOT_CHECKABLE = "not checkable under the literal reading"


def text_claims(evaluated) -> list[tuple[dict, list[dict], str]]:
    """The text's claims, each once: ``(entry, parts, verdict)`` with the entries that are
    ``part_of`` it and the verdict over all of them (not reproduced if one is, not measured
    if one is and none fails, a :data:`TIE` if one is and none fails or is not measured;
    :data:`NOT_CHECKABLE` for a claim marked ``checkable =
    false``)."""
    out = []
    for e in evaluated:
        c = e["claim"]
        if c.variant or c.part_of:
            continue
        parts = [p for p in evaluated if p["claim"].part_of == c.id]
        verdicts = [x["verdict"] for x in [e, *parts]]
        if not c.checkable:
            v = NOT_CHECKABLE
        elif "not reproduced" in verdicts:
            v = "not reproduced"
        elif "not measured" in verdicts:
            v = "not measured"
        elif TIE in verdicts:
            v = TIE
        else:
            v = "reproduced"
        out.append((e, parts, v))
    return out


def comparison_rows(claims, scenarios=None) -> dict:
    """``(scenario, structure) → (methods, targets)``: the rows every comparison of
    ``claims`` reads (in the ``scenarios`` judged, default all), as sorted tuples — what
    :mod:`podbench.harness.seeds` refits on the other noise seeds."""
    need: dict = {}
    for c in claims:
        for scen in c.all_scenarios():
            if scenarios is not None and scen not in scenarios:
                continue
            for s in c.structures:
                for t in c.targets:
                    for expr in c.checks:
                        if not is_comparison(expr):
                            continue
                        for sc, st, tg, label, _ in operand_rows(expr, scen, s, t):
                            m, ts = need.setdefault((sc, st), (set(), set()))
                            m.add(label)
                            ts.add(tg)
    return {k: (tuple(sorted(m)), tuple(sorted(ts))) for k, (m, ts) in sorted(need.items())}
