"""How far an iterative solver's answer is determined: the significant digits it fixes.

An iterative solve stops at the first iteration whose stopping test passes: its answer is
determined only to the tolerance, and round-off (another CPU) can move the stopping
iteration. A solver with a stopping test declares its :class:`StoppingRule` (class attribute
``stopping``: how far a decade of tolerance moves the numbers it gives, and how far the
round-off of the kernel moves them; the measurements are in ``docs/noise.md``, *Digits of an
iterative solve*). :meth:`Solver.determined <podbench.deconvolution.Solver.determined>`
turns it, at the tolerance the solver runs with, into a :class:`Determined` (the digits of
its numbers and of its relative residual), which every :class:`SolverResult` carries, also
as the text ``info["determined"]`` that a method passes on with its diagnostics. A direct
solver declares nothing: its numbers keep the tables' digits.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["ITERATIVE_MARGIN", "MOST_DIGITS", "iterative_digits", "StoppingRule", "Determined"]

ITERATIVE_MARGIN = 3
"""Margin, in decimal digits, kept between the last digit written and the round-off that
moves it between CPUs: a written value then changes only where the unrounded one
lies within 1e-3…1e-2 of a last-digit unit of a rounding boundary."""

MOST_DIGITS = 6
"""The most significant digits a table writes (:data:`podbench.harness.tables.FLOAT_FORMAT`)."""


def iterative_digits(tolerance_move: float, roundoff: float, margin: int = ITERATIVE_MARGIN,
                     most: int = MOST_DIGITS, least: int = 1) -> int:
    """Significant digits of a number derived from an iterative solve: those its stopping
    tolerance determines, kept ``margin`` digits above the round-off of the kernel.

    A value ``v`` written at ``d`` significant digits has a last-digit unit of at least
    ``10^(1−d)·|v|/10`` and at most ``10^(1−d)·|v|``. The tolerance determines digit ``d``
    when a decade of tolerance moves ``v`` by less than that unit:
    ``d ≤ ⌊−log10(tolerance_move)⌋ + 1``; the margin asks the kernel's round-off to stay
    ``margin`` digits below it: ``d ≤ ⌊−log10(roundoff)⌋ + 1 − margin``. The result is the
    smaller, at most ``most`` and at least ``least`` (0 for a residual: not even the first
    digit, only the decade)."""
    by_tol = math.floor(-math.log10(tolerance_move)) + 1 if tolerance_move > 0 else most
    by_roundoff = math.floor(-math.log10(roundoff)) + 1 - margin if roundoff > 0 else most
    return max(least, min(most, by_tol, by_roundoff))


@dataclass(frozen=True)
class StoppingRule:
    """What an iterative solver's stopping test leaves undetermined, measured.

    A move of the stopping point by a decade of tolerance ``tol`` moves every number the
    solve gives by at most ``gain·tol**power`` (relative; ``power`` 1 for a test on a
    residual norm, ½ for one on the decrease of an objective near its minimum) and the
    relative residual by ``residual_gain·tol**residual_power``; ``roundoff`` and
    ``residual_roundoff`` are the largest relative moves of the same between two BLAS
    kernels with the same stopping test."""

    gain: float
    power: float
    roundoff: float
    residual_gain: float
    residual_power: float
    residual_roundoff: float

    def tolerance_move(self, tol: float) -> float:
        """The relative move of a number that a decade of tolerance can make."""
        return self.gain * float(tol) ** self.power

    def determined(self, tol: float) -> Determined:
        """The digits a solve stopped at ``tol`` determines."""
        return Determined(
            tol=float(tol),
            digits=iterative_digits(self.tolerance_move(tol), self.roundoff),
            residual_digits=iterative_digits(
                self.residual_gain * float(tol) ** self.residual_power,
                self.residual_roundoff, least=0))


_INFO = re.compile(r"^digits=(\d+);residual_digits=(\d+);tol=(\S+)$")


@dataclass(frozen=True)
class Determined:
    """The significant digits an iterative solve at tolerance ``tol`` determines of its
    numbers (``digits``) and of its relative residual (``residual_digits``; 0: only its
    decade)."""

    tol: float
    digits: int
    residual_digits: int

    def as_info(self) -> str:
        """The text of ``SolverResult.info["determined"]`` (:meth:`from_info` reads it)."""
        return f"digits={self.digits};residual_digits={self.residual_digits};tol={self.tol!r}"

    @classmethod
    def from_info(cls, text) -> Determined | None:
        """The :class:`Determined` written by :meth:`as_info` (None for anything else)."""
        m = _INFO.match(text) if isinstance(text, str) else None
        return None if m is None else cls(float(m.group(3)), int(m.group(1)), int(m.group(2)))

    @staticmethod
    def fewest(items) -> Determined | None:
        """The least determined of several (the fewest digits of each kind; None if none)."""
        items = [d for d in items if d is not None]
        if not items:
            return None
        return Determined(max(d.tol for d in items), min(d.digits for d in items),
                          min(d.residual_digits for d in items))
