"""Exceptions and warnings raised by podbench.

Every error that podbench raises on bad input derives from :class:`PodbenchError` and from
the matching built-in (``ValueError`` for bad input, ``RuntimeError`` for a computation that
fails), so a caller can catch either precisely.
"""

from __future__ import annotations

__all__ = [
    "PodbenchError",
    "InputError",
    "InvalidParameterError",
    "DimensionError",
    "RecordTooShortError",
    "IllConditionedError",
    "NotFittedError",
    "StructureFileError",
    "ScenarioFileError",
    "UnknownNameError",
    "ConvergenceError",
    "PodbenchWarning",
]


class PodbenchError(Exception):
    """Base class of every podbench exception."""


class InputError(PodbenchError, ValueError):
    """Input data that podbench cannot use (NaN/Inf, wrong type, out-of-range value)."""


class InvalidParameterError(InputError):
    """A hyperparameter of a method or solver with a bad value; :attr:`param` names it.

    The message is one line: "Parameter `n_modes`: expected an integer >= 1, got 0"
    (scikit-learn's ``InvalidParameterError``, podbench's message style).
    """

    def __init__(self, message: str = "", param: str | None = None):
        super().__init__(message)
        self.param = param

    def __reduce__(self):  # keep `param` across processes
        return type(self), (str(self), self.param)


class DimensionError(InputError):
    """Arrays whose shapes or sample counts do not match."""


class RecordTooShortError(DimensionError):
    """A record with fewer samples than the model needs (its lags, horizon or order);
    :attr:`samples` is the record's length, :attr:`needed` the least the model takes. The
    callers that read files prefix the message with the file's name."""

    def __init__(self, message: str = "", samples: int = 0, needed: int = 0):
        super().__init__(message)
        self.samples, self.needed = int(samples), int(needed)

    def __reduce__(self):  # keep the counts across processes
        return type(self), (str(self), self.samples, self.needed)


class IllConditionedError(InputError):
    """A system that cannot be solved reliably: dependent data sets, a near-zero divisor.

    The message names the quantity and reports its condition number or magnitude.
    """


class NotFittedError(PodbenchError, ValueError, AttributeError):
    """``predict`` (or a fitted attribute) was used before ``fit``."""


class UnknownNameError(InputError, KeyError):
    """A structure, scenario, method, kind or engine name that podbench does not know."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class StructureFileError(InputError):
    """A malformed structure file; the message names the file and the field."""


class ScenarioFileError(InputError):
    """A malformed scenario file; the message names the file and the field."""


class ConvergenceError(PodbenchError, RuntimeError):
    """An iteration (Newton in the nonlinear Newmark integrator) did not converge."""


class PodbenchWarning(UserWarning):
    """A result that is computed but may be inaccurate (e.g. a poorly conditioned fit)."""
