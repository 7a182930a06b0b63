"""When regenerating a table rewrites the committed file: every committed number regenerates.

podbench writes each number at the significant digits its computation determines
(:mod:`podbench.harness.digits`): six for direct solves, fewer for ERA/OKID and the iterative
solvers, two for diagnostics. Another CPU's round-off moves a number, far below
its last written digit, and the written digits change only when the number lies within that
round-off of a rounding boundary. That is rare per number and not rare per study (at three
digits a number moved by 3.3e-6, relative, is written differently in 0.12 % of cases;
docs/noise.md counts the flips of a study). No number of digits removes those flips; only a
comparison with what is already written can.

The rule: a regenerated text file (a ``.csv`` table, a ``.md`` page) replaces the one already
on disk unless the two differ only in numbers that each moved by at most **one unit of the
last digit written** (:func:`unmoved`). Text, verdicts, labels, integers (model orders,
counts) and any number that moved further always rewrite the file; so does one more or one
fewer number, row or column. A file that is rewritten is rewritten whole, with every number as
this run computed it.

What this promises: on any CPU, regenerating a committed study in place
(``podbench run <study>`` on a fresh clone) leaves ``git status`` clean unless a number moved
by more than its last digit. Into an empty folder (``--out``), two CPUs agree to one unit of a
last digit, at the rate above.
"""

from __future__ import annotations

import math
import re

__all__ = ["NUMBER", "last_digit_unit", "significant_digits", "same_number", "unmoved",
           "TEXT_SUFFIXES"]

#: A number as podbench's tables and pages write it: optional sign, digits with an optional
#: decimal point, optional exponent; not part of a word (``noise_1pct``, ``h5``, ``ML4``).
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?!\w)")

#: Files compared by :func:`unmoved`; any other file is kept only when byte-identical.
TEXT_SUFFIXES = (".csv", ".md")


def _mantissa_exponent(token: str) -> tuple[str, int]:
    m, _, e = token.lower().partition("e")
    return m.lstrip("+-"), int(e) if e else 0


def last_digit_unit(token: str) -> float:
    """The value of one unit of the last digit written in ``token`` (``"0.0841"`` → 1e-4,
    ``"3.64399e+07"`` → 100, ``"49"`` → 1)."""
    m, e = _mantissa_exponent(token)
    decimals = len(m.partition(".")[2])
    return 10.0 ** (e - decimals)


def significant_digits(token: str) -> int:
    """Significant digits written in ``token`` (leading zeros not counted; ``"0.0841"`` → 3,
    ``"49"`` → 2, ``"0"`` → 1)."""
    digits = _mantissa_exponent(token)[0].replace(".", "").lstrip("0")
    return max(1, len(digits))


def same_number(old: str, new: str) -> bool:
    """Whether ``new`` is ``old`` moved by at most one unit of the last digit written.

    The unit is that of the token with more significant digits (``"0.084"`` and ``"0.0841"``
    are 0.0840 and 0.0841 at three digits: one unit; ``"49"`` and ``"49.1"``: one unit of
    0.1). Only numbers written with a fraction or an exponent (estimates) and at least two
    significant digits qualify: a pair of integers (``"5"``, ``"6"``: an order, a count) or a
    one-digit number is kept only when equal."""
    if old == new:
        return True
    if not any(c in t for t in (old, new) for c in ".eE"):
        return False
    try:
        a, b = float(old), float(new)
    except ValueError:
        return False
    if not (math.isfinite(a) and math.isfinite(b)) or (a < 0) != (b < 0):
        return False
    longer = max((old, new), key=significant_digits)
    if significant_digits(longer) < 2:
        return False
    return abs(a - b) <= last_digit_unit(longer) * (1 + 1e-9)


def unmoved(old: bytes, new: bytes) -> bool:
    """Whether the regenerated text ``new`` may leave the file ``old`` as it is: the same
    text once every number is set aside, and every number :func:`same_number` (the rule of
    this module). Anything not UTF-8 is compared byte for byte."""
    if old == new:
        return True
    try:
        a, b = old.decode("utf-8"), new.decode("utf-8")
    except UnicodeDecodeError:
        return False
    if NUMBER.split(a) != NUMBER.split(b):
        return False
    na, nb = NUMBER.findall(a), NUMBER.findall(b)
    return len(na) == len(nb) and all(same_number(x, y) for x, y in zip(na, nb, strict=True))
