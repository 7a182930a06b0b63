"""Every file or folder of the project that the README and the docs cite exists.

A cited path is a code span (`` `scenarios/chapter4/claims.toml` ``) or a relative link
(``[text](docs/methods.md)``) starting with one of the project's folders. Templates
(``<study>``), brace lists (``{1,2,5}``) and globs (``*``) are expanded; ``results/`` paths
are outputs (``results/my_study/``) and ``podbench/_bundled/`` exists only in a wheel, so
neither is required.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
        ROOT / "benchmarks" / "README.md"]
FOLDERS = ("podbench/", "scenarios/", "structures/", "docs/", "tests/", "benchmarks/",
           ".github/", ".ci/", "tools/")
SPAN = re.compile(r"`([^`\s]+)`|\]\(([^)\s#]+)")


def _expand(path: str) -> list[str]:
    parts = re.split(r"(\{[^}]*\})", path)
    options = [p[1:-1].split(",") if p.startswith("{") else [p] for p in parts]
    return ["".join(c) for c in itertools.product(*options)]


def _cited(doc: Path):
    for m in SPAN.finditer(doc.read_text(encoding="utf-8")):
        text = (m.group(1) or m.group(2)).rstrip(".,:;)")
        if m.group(2):  # a link: relative to the document
            if "://" in text:
                continue
            text = (doc.parent / text).resolve().relative_to(ROOT).as_posix() \
                if (doc.parent / text).resolve().is_relative_to(ROOT) else text
        if not text.startswith(FOLDERS) or "<" in text or "_bundled" in text:
            continue
        yield from _expand(text)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_cited_path_exists(doc):
    missing = sorted({p for p in _cited(doc)
                      if not (any(ROOT.glob(p)) if "*" in p else (ROOT / p).exists())})
    assert not missing, f"{doc.name} cites paths that do not exist: {missing}"
