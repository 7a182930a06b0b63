"""The identification layer stays readable: no function over 80 lines (docstring excluded),
none over McCabe complexity 15 or 50 statements (ruff's C901 / PLR0915, when ruff is at
hand)."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SYSID = Path(__file__).resolve().parents[2] / "podbench" / "sysid"


def _long_functions(limit: int = 80) -> list[str]:
    out = []
    for path in sorted(SYSID.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                doc = node.body[0] if node.body else None
                if isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant) \
                        and isinstance(doc.value.value, str):
                    lines -= doc.end_lineno - doc.lineno + 1
                if lines > limit:
                    out.append(f"{path.relative_to(SYSID)}:{node.lineno} {node.name} ({lines})")
    return out


@pytest.mark.heavy
def test_no_function_over_80_lines():
    assert _long_functions() == []


def test_no_function_over_complexity_15_or_50_statements():
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    if not Path(ruff).exists():
        pytest.skip("ruff is not installed")
    res = subprocess.run([ruff, "check", str(SYSID), "--select", "C901,PLR0915",
                          "--config", "lint.mccabe.max-complexity=15", "--no-cache",
                          "--output-format", "concise"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout
