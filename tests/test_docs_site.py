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
