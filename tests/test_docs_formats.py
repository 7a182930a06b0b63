"""The file-format references (docs/reference/scenarios.md, claims.md, records.md and the
labels of docs/structures.md) name every field the parsers read, and every field, value and
label they name is one the parsers accept: a documented value the parser rejects (the former
scenario template's `shape = "triangular"`, which the parser spells "triangle") fails here.

Fields read are found in the readers' source (each ``table.string("key")``-like call), the
values from the readers' own constants, so a field or value added to a parser without its
line in the reference fails too."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest
import tomllib

from podbench import api
from podbench.core.recordfiles import FORMATS
from podbench.core.units import UNITS
from podbench.dynamics import excitations
from podbench.structures.files import KINDS, list_structures, load_structure
from podbench.study import bounds, claims, nonlinearity, scenarios
from podbench.sysid.conditioning import DETREND_KINDS
from podbench.sysid.noise import NOISE_MODELS

ROOT = Path(__file__).resolve().parents[1]
REF = ROOT / "docs" / "reference"
SCENARIOS = (REF / "scenarios.md").read_text(encoding="utf-8")
CLAIMS = (REF / "claims.md").read_text(encoding="utf-8")
RECORDS = (REF / "records.md").read_text(encoding="utf-8")
STRUCTURES = (ROOT / "docs" / "structures.md").read_text(encoding="utf-8")

_READ = re.compile(r"\b\w+\.(?:string|strings|integer|integers|number|numbers|boolean|raw|"
                   r"table|tables|has|exclusive)\(\s*\"(\w+)\"|"
                   r"(?:read_excitation|_listify|_boolean)\(\w+, \"(\w+)\"")


def _fields_read(module) -> set[str]:
    """Every TOML key a reader module reads."""
    return {a or b for a, b in _READ.findall(inspect.getsource(module))}


def _spans(text: str) -> set[str]:
    """The contents of the code spans of ``text``, the quoted values inside them, and the
    names of the tables they write (`[scenario]`, `[[methods]]`, `[cases.<name>]`)."""
    out = set()
    for s in re.findall(r"`([^`\n]+)`", text):
        out.add(s.strip())
        out.update(re.findall(r'"([^"]+)"', s))
        if (m := re.fullmatch(r"\[{1,2}(\w+)(?:\.<\w+>)?\]{1,2}", s.strip())):
            out.add(m.group(1))
    return out


def _section(text: str, heading: str) -> str:
    """From ``heading`` (a whole line) to the next heading of the same or a higher level."""
    level = len(heading) - len(heading.lstrip("#"))
    start = text.index("\n" + heading + "\n")
    end = re.search(rf"\n#{{1,{level}}} ", text[start + len(heading) + 2:])
    return text[start:start + len(heading) + 2 + (end.start() if end else len(text))]


def _fenced(text: str, first_line: str) -> str:
    (body,) = [b for b in re.findall(r"```toml\n(.*?)```", text, re.S)
               if b.startswith(first_line)]
    return body


# ------------------------------------------------------------------------------ scenarios
def test_every_scenario_field_the_parser_reads_is_documented():
    documented = _spans(SCENARIOS)
    missing = sorted(k for k in _fields_read(scenarios) if k not in documented)
    assert not missing, f"docs/reference/scenarios.md does not name: {missing}"


@pytest.mark.parametrize("kind, cls", [
    ("static_displacement", excitations.StaticDisplacement),
    ("impulse_velocity", excitations.ImpulseVelocity),
    ("pulse", excitations.Pulse),
    ("force_history", excitations.ForceHistory),
])
def test_each_excitation_kinds_table_lists_exactly_its_constructors_arguments(kind, cls):
    """The table under ``### `kind = "<kind>"` `` names every constructor argument (in a
    row of its own or in a shared row) and nothing else."""
    section = _section(SCENARIOS, f'### `kind = "{kind}"`' + SECTION_SUFFIX[kind])
    rows = [ln for ln in section.splitlines() if ln.startswith("| `")]
    named = {f for ln in rows for f in re.findall(r"`(\w+)`", ln.split("|")[1])}
    params = set(inspect.signature(cls).parameters)
    assert named == params, (sorted(named - params), sorted(params - named))


SECTION_SUFFIX = {"static_displacement": " (an initial displacement)",
                  "impulse_velocity": " (an initial velocity)", "pulse": " (a force)",
                  "force_history": " (a force)", "combined": " (a force)"}


def test_the_documented_excitation_kinds_and_values_are_the_parsers():
    kinds = set(re.findall(r'^### `kind = "(\w+)"`', SCENARIOS, re.M))
    assert kinds == {k for ks in scenarios._EXCITATION_KINDS.values() for k in ks}
    pulse = _section(SCENARIOS, '### `kind = "pulse"` (a force)')
    (shape_row,) = [ln for ln in pulse.splitlines() if ln.startswith("| `shape`")]
    assert re.findall(r'`"(\w+)"`', shape_row.split("|")[2]) == list(excitations.Pulse.SHAPES)
    velocity = _section(SCENARIOS, '### `kind = "impulse_velocity"` (an initial velocity)')
    (row,) = [ln for ln in velocity.splitlines() if ln.startswith("| `velocity`")]
    assert re.findall(r'`"(\w+)"`', row.split("|")[2]) == list(
        excitations.ImpulseVelocity.VELOCITIES)
    # no other page names a pulse shape the parser does not know
    for doc in (ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))):
        for shape in re.findall(r'shape = "(\w+)"', doc.read_text(encoding="utf-8")):
            assert shape in excitations.Pulse.SHAPES, (doc.name, shape)


def _choices(section_heading: str, field: str) -> list[str]:
    section = _section(SCENARIOS, section_heading)
    (row,) = [ln for ln in section.splitlines() if ln.startswith(f"| `{field}`")]
    return re.findall(r'`"([\w-]+)"`', row.split("|")[2])


def test_the_documented_choices_are_the_parsers():
    assert _choices("## `[scenario]`", "engine") == list(scenarios.ENGINES)
    assert _choices("## `[sweep]`", "noise_model") == list(NOISE_MODELS)
    assert _choices("## `[sweep]`", "coupled_train") == list(scenarios.COUPLED_TRAIN)
    assert _choices("## `[sweep]`", "noise_on") == list(scenarios.NOISE_QUANTITIES)
    assert _choices("## `[conditioning]`", "detrend") == list(DETREND_KINDS)
    methods = _section(SCENARIOS, "## `[[methods]]`")
    (row,) = [ln for ln in methods.splitlines() if ln.startswith("| `method`")]
    named = re.findall(r"`([\w-]+)`", row.split("the built-in methods are", 1)[1]
                       .split("):", 1)[1].split("(")[0])
    assert named == list(scenarios.BUILTIN_METHODS)
    runners = _section(SCENARIOS, "## Studies with their own runner: `[study]`")
    (row,) = [ln for ln in runners.splitlines() if ln.startswith("| `runner`")]
    assert sorted(re.findall(r"`(\w+)`", row.split("|")[3])) == sorted(api.RUNNERS)


def test_the_complete_example_loads(tmp_path):
    """The reference's complete example is a valid scenario (it also runs, in
    tests/test_docs_commands.py)."""
    folder = tmp_path / "my_study"
    folder.mkdir()
    (folder / "my_study.toml").write_text(_fenced(SCENARIOS, "[scenario]"), encoding="utf-8")
    sc = scenarios.load_scenario(folder / "my_study.toml")
    assert [m.label for m in sc.methods] == ["SL", "ML"] and sc.targets == ("load5",)
    assert len(sc.cases) == 5 and sc.method("SL").twin == "ML"


def test_the_variant_and_inheritance_examples_are_the_bundled_files():
    variant = tomllib.loads(_fenced(SCENARIOS, "# a variant of the NL beam"))
    bundled = tomllib.loads((ROOT / "scenarios" / "sensitivity" / "nl_mixed.toml").read_text(
        encoding="utf-8"))
    assert variant["variants"].items() <= bundled["variants"].items()
    child = tomllib.loads(_fenced(SCENARIOS, "# scenarios/chapter5/linear_beam_noise_5pct"))
    path = ROOT / "scenarios" / "chapter5" / "linear_beam_noise_5pct.toml"
    bundled = tomllib.loads(path.read_text(encoding="utf-8"))
    assert child["scenario"] == bundled["scenario"]
    assert child["cases"].items() <= bundled["cases"].items()
    sc = scenarios.load_scenario(path)  # and it loads, inheriting the rest
    assert sc.base is not None and sc.cases["load4"].file == child["cases"]["load4"]["file"]


# ------------------------------------------------------------------------------ claims
def test_every_claims_field_the_parsers_read_is_documented():
    documented = _spans(CLAIMS)
    read = _fields_read(claims) | _fields_read(bounds) | _fields_read(nonlinearity)
    missing = sorted(k for k in read if k not in documented)
    assert not missing, f"docs/reference/claims.md does not name: {missing}"
    assert set(bounds.MEASURES) <= documented and set(bounds.STATISTICS) <= documented


def test_every_documented_check_operand_is_the_grammars():
    table = _section(CLAIMS, "### Checks")
    examples = [re.findall(r"`([^`]+)`", ln.split("|")[2]) for ln in table.splitlines()
                if ln.startswith("| ") and not ln.startswith(("| form", "|---"))]
    operands = [e for row in examples for e in row]
    assert len(operands) >= 8
    for op in operands:
        assert claims.CHECK_RE.match(f"{op} < 1"), op


def test_the_claims_example_loads(tmp_path):
    body = _fenced(CLAIMS, "# one claim of scenarios/chapter4/claims.toml")
    (tmp_path / "claims.toml").write_text(body, encoding="utf-8")
    f = claims.load_claims_file(tmp_path / "claims.toml")
    (c,) = f.claims
    bundled = {x.id: x for x in claims.load_claims_file(
        ROOT / "scenarios" / "chapter4" / "claims.toml").claims}
    assert c.checks == bundled[c.id].checks and c.structures == bundled[c.id].structures


# ------------------------------------------------------------------------------ records
def test_the_record_formats_and_units_are_the_readers():
    documented = _spans(RECORDS)
    assert set(FORMATS) <= documented  # .npz, .mat, .csv, .uff, .unv
    units = {u for table in UNITS.values() for u in table}
    assert units <= documented, sorted(units - documented)


# ------------------------------------------------------------------------------ labels
def test_every_label_the_structures_page_names_exists():
    """The labels quoted in docs/structures.md's *Sensor and DOF labels* (templates with
    ``<…>`` aside) are labels of a shipped structure, and every shipped structure kind has a
    row."""
    section = _section(STRUCTURES, "## Sensor and DOF labels")
    labels = set()
    for name in list_structures():
        s = load_structure(name)
        labels |= set(s.sensor_labels) | set(s.dof_labels)
    quoted = {x for x in re.findall(r"`([\w@.]+)`", section)
              if re.search(r"\d", x) and not re.fullmatch(r"[\d.e-]+", x)}
    assert quoted, section[:200]
    missing = sorted(quoted - labels)
    assert not missing, missing
    kinds = set(re.findall(r"^\| `(\w+)` \|", section, re.M))
    assert kinds == {k for k, parse in KINDS.items() if parse.__module__.startswith("podbench.")}


# ------------------------------------------------------------------------------ any page
def _named(pattern: str) -> set[tuple[str, str]]:
    """``(page, value)`` of every ``<pattern>"value"`` on the README and the docs pages,
    templates (``<name>``, ``…``) and user paths (``file.py:Class``) aside."""
    out = set()
    for doc in (ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))):
        for v in re.findall(pattern + r'"([^"]+)"', doc.read_text(encoding="utf-8")):
            if not re.search(r"[<…:]", v):
                out.add((doc.relative_to(ROOT).as_posix(), v))
    return out


def test_every_solver_method_and_kind_a_page_names_exists():
    from podbench.sysid.deconvolution import available_solvers

    # the solver option in a scenario (solver = "ls") or in Python (solver="ls"); a scenario's
    # method and kind entries (TOML: spaces around "=")
    bad = [x for x in _named(r"\bsolver ?= ?") if x[1] not in available_solvers()]
    bad += [x for x in _named(r"\bmethod = ") if x[1] not in scenarios.BUILTIN_METHODS]
    kinds = set(KINDS) | {k for ks in scenarios._EXCITATION_KINDS.values() for k in ks}
    bad += [x for x in _named(r"(?<![\w.])kind = ") if x[1] not in kinds]
    assert not bad, sorted(bad)
