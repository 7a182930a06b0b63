"""Strict reading of parsed TOML tables, with one clear message per error.

:class:`Table` wraps one TOML table (a ``dict``) and hands out its fields with a type check;
:meth:`Table.close` then rejects every field that was never asked for (a misspelt field is
otherwise a silent bug). Every error is a :class:`~podbench.errors.StructureFileError` whose
message names the file and the dotted field, e.g.::

    structures/foo.toml: field `beam.n_elements`: expected a positive integer, got -3
"""

from __future__ import annotations

import difflib
import math
import numbers
from typing import Any, Literal, NoReturn, overload

from podbench.errors import StructureFileError

__all__ = ["Table", "MISSING", "fail"]


class _Missing:
    def __repr__(self) -> str:
        return "<required>"


MISSING = _Missing()


def fail(file: str, field: str | None, message: str) -> NoReturn:
    """Raise the :class:`StructureFileError` for ``field`` of ``file``."""
    where = f"{file}: field `{field}`: " if field else f"{file}: "
    raise StructureFileError(where + message)


def _show(value) -> str:
    text = repr(value)
    if isinstance(value, str):
        text = f'"{value}"'
    elif isinstance(value, bool):
        text = "true" if value else "false"
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({_toml_type(value)})"


def _toml_type(value) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, numbers.Integral):
        return "integer"
    if isinstance(value, numbers.Real):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, dict):
        return "table"
    if isinstance(value, list):
        return "array"
    return type(value).__name__


def _is_number(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


class Table:
    """A TOML table read field by field.

    Parameters
    ----------
    data : dict
        The parsed table.
    file : str
        The file name shown in messages.
    prefix : str
        Dotted path of this table inside the file ("" for the top level).
    """

    def __init__(self, data: dict, *, file: str, prefix: str = ""):
        if not isinstance(data, dict):
            fail(file, prefix or None, f"expected a table, got {_show(data)}")
        self.data = data
        self.file = file
        self.prefix = prefix
        self._used: set[str] = set()

    # ------------------------------------------------------------------ helpers
    def field(self, key: str) -> str:
        """Dotted name of ``key`` in this table."""
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str | None, message: str) -> NoReturn:
        fail(self.file, self.field(key) if key is not None else (self.prefix or None), message)

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, default):
        self._used.add(key)
        if key in self.data:
            return self.data[key], True
        if default is MISSING:
            self.fail(key, "missing (this field is required)" + self._typo_hint(key))
        return default, False

    def _typo_hint(self, key: str) -> str:
        spare = [k for k in self.data if k not in self._used]
        close = difflib.get_close_matches(key, spare, n=1)
        return f"; is `{self.field(close[0])}` a misspelling?" if close else ""

    def raw(self, key: str, default=MISSING):
        """The value as parsed, unchecked."""
        return self._get(key, default)[0]

    # ------------------------------------------------------------------ scalars
    def string(self, key: str, default=MISSING, *, choices=None, nonempty: bool = True):
        value, present = self._get(key, default)
        if not present:
            return value
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_show(value)}")
        if nonempty and not value.strip():
            self.fail(key, "expected a non-empty string")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(map(repr, choices))}, got {_show(value)}")
        return value

    def boolean(self, key: str, default=MISSING) -> bool:
        value, present = self._get(key, default)
        if present and not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_show(value)}")
        return value

    def number(self, key: str, default=MISSING, *, positive=False, nonnegative=False,
               below=None, above=None) -> float:
        """A finite real number (an integer is accepted and converted to float)."""
        value, present = self._get(key, default)
        if not present:
            return value
        return self._check_number(key, value, positive, nonnegative, below, above)

    def _check_number(self, key, value, positive, nonnegative, below, above) -> float:
        word = "positive " if positive else "non-negative " if nonnegative else ""
        if not _is_number(value) or not math.isfinite(float(value)):
            self.fail(key, f"expected a finite {word}number, got {_show(value)}")
        value = float(value)
        if (positive and value <= 0) or (nonnegative and value < 0):
            self.fail(key, f"expected a {word}number, got {value!r}")
        if below is not None and not value < below:
            self.fail(key, f"expected a number below {below!r}, got {value!r}")
        if above is not None and not value > above:
            self.fail(key, f"expected a number above {above!r}, got {value!r}")
        return value

    def integer(self, key: str, default=MISSING, *, minimum=None, maximum=None,
                positive=False) -> int:
        value, present = self._get(key, default)
        if not present:
            return value
        if positive:
            minimum = 1 if minimum is None else max(minimum, 1)
        word = "a positive integer" if positive else "an integer"
        if not isinstance(value, numbers.Integral) or isinstance(value, bool):
            self.fail(key, f"expected {word}, got {_show(value)}")
        value = int(value)
        if minimum is not None and value < minimum:
            if positive and minimum == 1:
                self.fail(key, f"expected a positive integer, got {value}")
            self.fail(key, f"expected an integer >= {minimum}, got {value}")
        if maximum is not None and value > maximum:
            self.fail(key, f"expected an integer <= {maximum}, got {value}")
        return value

    # ------------------------------------------------------------------ arrays
    def numbers(self, key: str, default=MISSING, *, positive=False, nonnegative=False,
                scalar_ok=False) -> list[float] | float:
        """A list of finite numbers (or one number if ``scalar_ok``)."""
        value, present = self._get(key, default)
        if not present:
            return value
        if scalar_ok and _is_number(value):
            return self._check_number(key, value, positive, nonnegative, None, None)
        if not isinstance(value, list) or not value:
            what = "a number or a non-empty array of numbers" if scalar_ok else (
                "a non-empty array of numbers")
            self.fail(key, f"expected {what}, got {_show(value)}")
        return [self._check_number(f"{key}[{i}]", v, positive, nonnegative, None, None)
                for i, v in enumerate(value)]

    def integers(self, key: str, default=MISSING, *, minimum=None) -> list[int]:
        value, present = self._get(key, default)
        if not present:
            return value
        if not isinstance(value, list) or not value:
            self.fail(key, f"expected a non-empty array of integers, got {_show(value)}")
        out = []
        for i, v in enumerate(value):
            if not isinstance(v, numbers.Integral) or isinstance(v, bool):
                self.fail(f"{key}[{i}]", f"expected an integer, got {_show(v)}")
            if minimum is not None and v < minimum:
                self.fail(f"{key}[{i}]", f"expected an integer >= {minimum}, got {v}")
            out.append(int(v))
        return out

    def _array_of(self, key: str, default, kind: type, what: str) -> tuple[Any, bool]:
        """``(value, present)`` of the array ``key`` whose items must all be ``kind``
        (``what`` names them in the message); ``(default, False)`` when absent."""
        value, present = self._get(key, default)
        if present and (not isinstance(value, list)
                        or not all(isinstance(v, kind) for v in value)):
            self.fail(key, f"expected an array of {what}, got {_show(value)}")
        return value, present

    def strings(self, key: str, default=MISSING) -> list[str]:
        value, present = self._array_of(key, default, str, "strings")
        return list(value) if present else value

    # ------------------------------------------------------------------ sub-tables
    @overload
    def table(self, key: str, *, required: Literal[True]) -> Table: ...

    @overload
    def table(self, key: str, *, required: bool = False) -> Table | None: ...

    def table(self, key: str, *, required: bool = False) -> Table | None:
        """The sub-table ``key`` (``None`` if absent and not required)."""
        value, present = self._get(key, MISSING if required else None)
        if not present:
            return None
        if not isinstance(value, dict):
            self.fail(key, f"expected a table ([{self.field(key)}]), got {_show(value)}")
        return Table(value, file=self.file, prefix=self.field(key))

    def tables(self, key: str, default=MISSING) -> list[Table]:
        """An array of tables (``[[key]]`` or ``key = [{...}, ...]``)."""
        value, present = self._array_of(key, default, dict, "tables")
        if not present:
            return value
        return [Table(v, file=self.file, prefix=f"{self.field(key)}[{i}]")
                for i, v in enumerate(value)]

    def exclusive(self, *keys: str, required: bool = True) -> str | None:
        """Check that exactly one (at most one if not ``required``) of ``keys`` is present."""
        present = [k for k in keys if k in self.data]
        if len(present) > 1:
            self.fail(present[1], f"give only one of {self._names(keys)}")
        if not present:
            if required:
                hint = "".join(self._typo_hint(k) for k in keys)[:120]
                self.fail(keys[0], f"missing: give one of {self._names(keys)}{hint}")
            return None
        return present[0]

    def accept_all(self) -> None:
        """Mark every field as read (for free-form tables checked elsewhere)."""
        self._used.update(self.data)

    def _names(self, keys) -> str:
        return ", ".join(f"`{self.field(k)}`" for k in keys)

    def close(self) -> None:
        """Reject the fields that were never read (unknown or misspelt)."""
        unknown = [k for k in self.data if k not in self._used]
        if not unknown:
            return
        key = unknown[0]
        known = sorted(self._used)
        close = difflib.get_close_matches(key, known, n=1)
        hint = f"; did you mean `{close[0]}`?" if close else ""
        where = f"[{self.prefix}]" if self.prefix else "the top level"
        self.fail(key, f"unknown field{hint} (fields of {where}: {', '.join(known) or 'none'})")
