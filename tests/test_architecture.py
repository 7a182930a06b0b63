"""The shape of the code (docs/ARCHITECTURE.md), checked like any other property.

* the import-linter contracts of pyproject.toml are kept: the layers (core → structures →
  dynamics → sysid → study → harness → report → api → cli, each importing only those below
  it), the exceptions importing no layer, and no import circle among the modules of any
  package;
* no podbench module is imported inside a function (only optional third-party packages may
  be: exudyn's GUI, Dask, pyuff, matplotlib in a worker, ...);
* no module imports another module's private name (``_name``);
* no function is longer than 80 lines (``def`` to its last line, the docstring not counted)
  — ruff's C901 (McCabe complexity ≤ 15) and PLR0915 (≤ 50 statements) check the rest.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "podbench"
MAX_FUNCTION_LINES = 80


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "_bundled" not in p.parts)


def _parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def test_the_import_contracts_are_kept():
    cli = pytest.importorskip("importlinter.cli")
    assert cli.lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True) == 0, \
        "lint-imports reports a broken contract (run `lint-imports` to see it)"


def test_no_podbench_import_inside_a_function():
    found = []
    for path in _modules():
        for fn in ast.walk(_parse(path)):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                names = ([node.module or ""] if isinstance(node, ast.ImportFrom)
                         else [a.name for a in node.names] if isinstance(node, ast.Import)
                         else [])
                if isinstance(node, ast.ImportFrom) and node.level:
                    names = ["podbench (relative)"]
                found += [f"{path.relative_to(ROOT)}:{node.lineno} {n}" for n in names
                          if n.startswith("podbench")]
    assert not found, "imports of podbench inside functions:\n" + "\n".join(found)


def test_no_module_imports_another_modules_private_name():
    found = []
    for path in _modules():
        for node in ast.walk(_parse(path)):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("podbench"):
                found += [f"{path.relative_to(ROOT)}:{node.lineno} {node.module}.{a.name}"
                          for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")
                          and a.name != "_compat"]
    assert not found, "private names imported across modules:\n" + "\n".join(found)


def _length(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    lines = fn.end_lineno - fn.lineno + 1
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        lines -= body[0].end_lineno - body[0].lineno + 1
    return lines


def test_no_function_is_longer_than_80_lines():
    long = [f"{p.relative_to(ROOT)}:{fn.lineno} {fn.name} ({_length(fn)} lines)"
            for p in _modules() for fn in ast.walk(_parse(p))
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
            and _length(fn) > MAX_FUNCTION_LINES]
    assert not long, "functions over 80 lines (docstring excluded):\n" + "\n".join(long)


def test_the_old_module_names_are_the_new_modules():
    """What users imported before the re-layout imports the same module objects."""
    import podbench.deconvolution.kernel as old_kernel
    import podbench.excitations as old_excitations
    import podbench.fem.files as old_files
    import podbench.methods.forced as old_forced
    from podbench.methods import MultipleLoad

    import podbench
    from podbench.dynamics import excitations
    from podbench.structures import files
    from podbench.sysid.deconvolution import kernel
    from podbench.sysid.methods import forced

    assert old_forced is forced and old_kernel is kernel and old_files is files
    assert old_excitations is excitations and MultipleLoad is forced.MultipleLoad
    assert podbench.methods is podbench.sysid.methods
    assert podbench.deconvolution is podbench.sysid.deconvolution
    assert callable(podbench.simulate) and callable(podbench.load_structure)
    assert podbench.Record.__module__ == "podbench.core.records"


ARCHITECTURE = ROOT / "docs" / "ARCHITECTURE.md"


def _contract_layers() -> list[str]:
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contract = next(c for c in config["tool"]["importlinter"]["contracts"]
                    if c["type"] == "layers")
    return [name.removeprefix("podbench.") for name in contract["layers"]]


def test_the_documented_layers_are_the_import_contracts():
    """docs/ARCHITECTURE.md draws the layers, top to bottom, as the import-linter contract of
    pyproject.toml lists them, each at the folder or file it names, and counts them."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    drawn = [(m.group(1), m.group(2)) for m in re.finditer(
        r"^  (\w+) +(podbench/[\w/.]+)", text, flags=re.MULTILINE)]
    layers = _contract_layers()
    assert [name for name, _ in drawn] == layers
    for name, where in drawn:
        assert where in (f"podbench/{name}/", f"podbench/{name}.py"), (name, where)
        assert (ROOT / where).exists(), where
    words = {8: "eight", 9: "nine", 10: "ten"}
    assert f"podbench is {words[len(layers)]} layers" in text


def test_the_worked_example_adds_a_method_with_one_class_and_one_registry_line():
    """The python block of docs/ARCHITECTURE.md's "Worked example: adding a method" runs:
    one class, one registry entry, and the base class's contract (records, band) works."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    section = text.split("### Worked example: adding a method", 1)[1]
    block = section.split("```python\n", 1)[1].split("```", 1)[0]
    assert block.count("class ") == 1 and block.count("Entry(") == 1
    namespace: dict = {}
    exec(compile(block, str(ARCHITECTURE), "exec"), namespace)  # noqa: S102 - our own docs
    model = namespace["model"]
    assert model.abbreviation == "SCALED" and namespace["entry"].build().get_params() == {}
