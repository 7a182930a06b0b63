"""Reading a TOML file of podbench's (a structure, a scenario, a claims or experiment file)
with one line naming the file for each way it can fail."""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["load_toml", "typed_field"]


def load_toml(path, shown: str, error: type[Exception]) -> tuple[bytes, dict]:
    """The bytes of ``path`` and their parsed table.

    Raises
    ------
    error
        ``<shown>: TOML syntax error: …``, ``<shown>: not UTF-8 text (…)`` or ``<shown>:
        cannot read (…)`` (``shown``: the file as messages name it).
    """
    try:
        raw = Path(path).read_bytes()
        return raw, tomllib.loads(raw.decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{shown}: TOML syntax error: {exc}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{shown}: not UTF-8 text ({exc})") from None
    except OSError as exc:
        raise error(f"{shown}: cannot read ({exc.strerror or exc})") from None


_REQUIRED = object()


def typed_field(table: dict, key: str, kind: type, where: str, error: type[Exception],
                default=_REQUIRED):
    """``table[key]``, checked to be a ``kind`` (``str``, ``int``, ``float``, ``list``,
    ``dict``; a TOML integer is taken as a float, a boolean is never a number).

    ``default`` is returned when the key is absent and a default is given. Raises ``error``
    with one line, ``<where>: field `<key>`: missing`` or ``<where>: field `<key>`: expected
    <kind>, got <value>`` (``where``: the file and table as messages name them).
    """
    if key not in table:
        if default is _REQUIRED:
            raise error(f"{where}: field `{key}`: missing")
        return default
    value = table[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise error(f"{where}: field `{key}`: expected {kind.__name__}, got {value!r}")
    return value
