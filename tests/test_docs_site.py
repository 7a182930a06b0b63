"""The documentation site: the CLI reference is the parser's own help, and the site builds
with warnings as errors (``mkdocs build --strict``, where MkDocs is installed: the `docs`
extra and CI's docs job)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from podbench import cli

ROOT = Path(__file__).resolve().parents[1]


def test_the_cli_reference_is_generated_from_the_parser():
    got = (ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8")
    assert got == cli.reference_markdown(), (
        "docs/reference/cli.md is out of date: regenerate it with python -c \"from podbench "
        "import cli; open('docs/reference/cli.md', 'w').write(cli.reference_markdown())\"")
    for command in ("run", "regress", "sweep", "list", "experiment", "predict", "methods"):
        assert f"## podbench {command}\n" in got


@pytest.mark.slow
def test_the_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    mkdocs = shutil.which("mkdocs") or f"{sys.executable} -m mkdocs"
    r = subprocess.run([*mkdocs.split(), "build", "--strict", "-d", str(tmp_path / "site")],
                       cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (tmp_path / "site" / "reference" / "api" / "index.html").is_file()


@pytest.mark.heavy
def test_every_docstring_parses_as_numpydoc_without_warnings():
    """The check behind the site's strict build, in the default suite: griffe (the parser
    mkdocstrings uses, ``docstring_style: numpy``) parses every docstring of the package and
    warns on a paragraph it takes for a parameter (a ``Diagnostics:`` paragraph left under
    ``Parameters`` lists "Diagnostics" as a parameter that is not in the signature), on an
    unparsable line, or on a parameter without a type. Any warning fails the site build."""
    griffe = pytest.importorskip("griffe")
    import logging

    seen: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record):
            seen.append(record.getMessage())

    log = logging.getLogger("griffe")
    handler, level = Collect(logging.WARNING), log.level
    log.addHandler(handler)
    log.setLevel(logging.WARNING)
    try:
        package = griffe.load("podbench", search_paths=[str(ROOT)], docstring_parser="numpy",
                              resolve_aliases=False)
        stack, parsed = [package], 0
        while stack:
            obj = stack.pop()
            if obj.docstring is not None:
                _ = obj.docstring.parsed  # parsing logs the warnings
                parsed += 1
            stack.extend(m for m in obj.members.values()
                         if not m.is_alias and (m.is_module or m.is_class or m.is_function))
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    assert parsed > 500, f"only {parsed} docstrings found: is griffe reading the package?"
    assert not seen, "\n".join(seen[:20])
