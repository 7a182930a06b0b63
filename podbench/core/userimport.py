"""Import user code named in a structure or scenario file (one helper for the whole package).

A user names a Python object as ``"module:name"`` (an importable module) or
``"file.py:name"`` (a file, relative to the structure or scenario file that names it).
A file is imported once per process under a name derived from its absolute path, so the
same file named from two places is the same module, and a worker process (``--jobs``, Dask)
that reads the same scenario imports it the same way: nothing is registered in a global
table that a worker would not see.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from pathlib import Path

from podbench.errors import InputError

__all__ = ["split_target", "import_module_or_file", "import_object", "UserImportError"]


class UserImportError(InputError):
    """User code named in a file cannot be imported (the message says why, on one line)."""


def split_target(target: str) -> tuple[str, str]:
    """``("module" or "file.py", "name")`` from ``"module:name"``; UserImportError if malformed."""
    if not isinstance(target, str) or target.count(":") != 1 or not all(target.split(":")):
        raise UserImportError(f'expected "module:name" or "file.py:name", got {target!r}')
    module, name = target.split(":")
    return module, name


def import_module_or_file(module: str, base_dir: Path | str | None = None):
    """Import ``module`` (a dotted name) or, if it ends in ``.py``, the file ``base_dir/module``.

    Raises
    ------
    UserImportError
        No such file, or the import raised (the exception's type and message are kept).
    """
    if module.endswith(".py"):
        path = (Path(base_dir or ".") / module).resolve()
        if not path.is_file():
            raise UserImportError(f'no such file "{path}"')
        digest = hashlib.sha1(str(path).encode("utf-8")).hexdigest()[:12]
        key = f"podbench_user_{digest}_{path.stem}"
        found = sys.modules.get(key)
        if found is not None:
            return found
        spec = importlib.util.spec_from_file_location(key, path)
        if spec is None or spec.loader is None:
            raise UserImportError(f'cannot import "{path}" as a Python module')
        mod = importlib.util.module_from_spec(spec)
        sys.modules[key] = mod
        try:
            spec.loader.exec_module(mod)
        except Exception as exc:
            sys.modules.pop(key, None)
            raise UserImportError(
                f'importing "{path}" failed: {type(exc).__name__}: {" ".join(str(exc).split())}'
            ) from None
        return mod
    try:
        return importlib.import_module(module)
    except Exception as exc:  # a user's module failing to import is bad input, not a crash
        raise UserImportError(
            f'cannot import module "{module}" ({type(exc).__name__}: '
            f'{" ".join(str(exc).split())}); give a file "name.py:{module}" next to the file '
            "that names it, or install the module"
        ) from None


def import_object(target: str, base_dir: Path | str | None = None):
    """The object ``name`` of ``"module:name"`` / ``"file.py:name"`` (UserImportError if absent)."""
    module, name = split_target(target)
    mod = import_module_or_file(module, base_dir)
    obj = getattr(mod, name, None)
    if obj is None:
        raise UserImportError(f'"{module}" has no "{name}"')
    return obj
