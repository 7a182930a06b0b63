"""Every place that tells a reader the unit system says that it is not always inch–lbf:
structure files take SI (``units = "m, N, second"``, tests/structures/test_si_units.py) and
record files state their own units."""

import re
from pathlib import Path

from podbench import cli

ROOT = Path(__file__).resolve().parents[1]


def _unit_statements(text: str) -> list[str]:
    """Each paragraph (or list item) that states the unit system as inch, lbf, second."""
    parts = re.split(r"\n\s*\n|\n- ", text)
    stated = re.compile(r"[Uu]nits(:| are) inch,\s+lbf,?\s+(and\s+)?second")
    return [p for p in parts if stated.search(p)]


def test_every_statement_of_the_units_names_si_structures_too():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    found = {}
    for page in pages:
        for para in _unit_statements(page.read_text(encoding="utf-8")):
            found.setdefault(page.relative_to(ROOT).as_posix(), []).append(para)
    found["podbench --help"] = _unit_statements(cli._EPILOG)
    assert {"README.md", "docs/index.md", "docs/conventions.md", "podbench --help"} <= set(found)
    stale = {where: p[:80] for where, paras in found.items() for p in paras
             if "SI" not in p and "dissertation's records" not in p}
    assert not stale, f"states inch, lbf, second as the only units: {stale}"
    assert "throughout" not in cli._EPILOG
