"""The "did you mean …" hint of an unknown name (a study, structure, method, solver or
option), shared by every reader and the API so that every such error reads alike."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(name: object, choices: Iterable) -> str:
    """``; did you mean 'SL'?`` for the closest of ``choices`` to ``name`` (letter case
    aside: ``sl`` finds ``SL``), or ""."""
    by_lower: dict[str, str] = {}
    for c in map(str, choices):
        by_lower.setdefault(c.lower(), c)
    close = difflib.get_close_matches(str(name).lower(), list(by_lower), n=1, cutoff=0.6)
    return f"; did you mean {by_lower[close[0]]!r}?" if close else ""


def percent_hint(value: object) -> str:
    """``"; a percentage? 90 % is 0.9"`` when ``value`` looks like a fraction written as a
    percentage (``5 <= value <= 100``: a value just above 1, such as 1.5, is more likely a
    fraction out of range than 1.5 %), else ""."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return ""
    if not 5.0 <= v <= 100.0:
        return ""
    return f"; a percentage? {v:g} % is {v / 100:g}"


def noise_level_hint(value: float) -> str:
    """The hint for a noise level above 1 (std = level × each channel's RMS, so 5 is 500 %):
    ``"; a percentage? 5 % is 0.05"`` up to 100, else ``""``. Above 1 a level is much more
    likely a percentage than noise larger than the signal, so every value up to 100 gets it."""
    return f"; a percentage? {value:g} % is {value / 100:g}" if 1 < value <= 100 else ""
