"""Package-level promises: the public names, and that methods depend only on arrays."""

from __future__ import annotations

import ast
from pathlib import Path

import podbench.sysid.methods as methods

PACKAGE = Path(methods.__file__).resolve().parents[1]
FORBIDDEN = ("fem", "dynamics", "harness", "excitations", "scenarios", "data")


def _imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            names.add("." * node.level + (node.module or ""))
    return names


def test_methods_import_nothing_from_simulation_or_harness():
    files = [PACKAGE / "pod.py", *sorted((PACKAGE / "deconvolution").glob("*.py")),
             *sorted((PACKAGE / "methods").glob("*.py")),
             *sorted((PACKAGE / "methods" / "peers").glob("*.py"))]
    assert len(files) >= 19
    for path in files:
        for name in _imported_modules(path):
            parts = [p for p in name.replace("podbench.", "").lstrip(".").split(".") if p]
            assert not (parts and parts[0] in FORBIDDEN), f"{path.name} imports {name}"


def test_public_names():
    assert set(methods.__all__) == {"PODMethod", "POVR", "MDS", "SingleLoad", "MultipleLoad",
                                    "MixedResponse", "Superposition", "ERA", "DMDc", "OpInf",
                                    "FIRLeastSquares", "Mdof", "BUILTIN_METHODS"}
    abbreviations = [getattr(methods, n).abbreviation for n in methods.__all__[1:6]]
    assert abbreviations == ["POVR", "MDS", "SL", "ML", "MR"]
    assert {k: c.abbreviation for k, c in methods.BUILTIN_METHODS.items()
            if k not in ("superposition", "mdof")} == {
        k: k for k in ("POVR", "MDS", "SL", "ML", "MR", "FIR-LS", "ERA", "DMDc", "OpInf", "BLA",
                       "ML-interp")}
