"""Time laws ``m(t)`` for a :class:`~podbench.fem.structure.VariableMass` (lbf·s²/in, t in s).

Small frozen dataclasses rather than lambdas, so that a structure with a variable mass can be
pickled (sent to a worker process) and printed. Every law is smooth or piecewise linear and
non-negative for ``t >= 0``; ``str(law)`` states it as a formula.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podbench.core.validation import check_positive
from podbench.errors import InputError

__all__ = ["ConstantLaw", "SineLaw", "LinearLaw", "scaled_law"]


def _finite(x, name: str) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise InputError(f"Parameter `{name}`: expected a number, got {x!r}") from None
    if not np.isfinite(x):
        raise InputError(f"Parameter `{name}`: must be finite, got {x!r}")
    return x


@dataclass(frozen=True)
class ConstantLaw:
    """``m(t) = value``."""

    value: float

    def __post_init__(self):
        check_positive(self.value, "value", allow_zero=True)

    def __call__(self, t):
        return np.full(np.shape(t), float(self.value))

    def __str__(self) -> str:
        return f"m(t) = {self.value:.6g} lbf·s²/in"


@dataclass(frozen=True)
class SineLaw:
    """``m(t) = mean + amplitude · sin(2π t / period + phase)``.

    ``|amplitude| <= mean`` keeps the mass non-negative.
    """

    mean: float
    amplitude: float
    period: float
    phase: float = 0.0

    def __post_init__(self):
        check_positive(self.mean, "mean", allow_zero=True)
        check_positive(self.period, "period")
        amp = _finite(self.amplitude, "amplitude")
        _finite(self.phase, "phase")
        if abs(amp) > self.mean:
            raise InputError(
                f"Parameter `amplitude`: |amplitude| = {abs(amp)!r} exceeds mean = "
                f"{self.mean!r}, so the mass would become negative"
            )

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return self.mean + self.amplitude * np.sin(2.0 * np.pi * t / self.period + self.phase)

    def __str__(self) -> str:
        ph = f" + {self.phase:.6g}" if self.phase else ""
        return (f"m(t) = {self.mean:.6g} + {self.amplitude:.6g}·sin(2π t / {self.period:.6g} s"
                f"{ph}) lbf·s²/in")


@dataclass(frozen=True)
class LinearLaw:
    """``m(t)`` ramps linearly from ``initial`` (t = 0) to ``final`` (t = ``duration``), then
    stays at ``final``."""

    initial: float
    final: float
    duration: float

    def __post_init__(self):
        check_positive(self.initial, "initial", allow_zero=True)
        check_positive(self.final, "final", allow_zero=True)
        check_positive(self.duration, "duration")

    def __call__(self, t):
        s = np.clip(np.asarray(t, dtype=float) / self.duration, 0.0, 1.0)
        return self.initial + (self.final - self.initial) * s

    def __str__(self) -> str:
        return (f"m(t) = {self.initial:.6g} + ({self.final:.6g} − {self.initial:.6g})·"
                f"min(t / {self.duration:.6g} s, 1) lbf·s²/in")


def scaled_law(kind: str, factor: float = 1.0, **params):
    """A law of ``kind`` with its masses multiplied by ``factor``.

    ``"constant"``: ``value``; ``"sine"``: ``mean``, ``amplitude``, ``period``, ``phase``
    (default 0); ``"linear"``: ``initial``, ``final``, ``duration``. The masses (value, mean,
    amplitude, initial, final) are scaled, times (period, duration) and the phase are not.
    """
    if kind == "constant":
        return ConstantLaw(factor * params["value"])
    if kind == "sine":
        return SineLaw(factor * params["mean"], factor * params["amplitude"], params["period"],
                       params.get("phase", 0.0))
    if kind == "linear":
        return LinearLaw(factor * params["initial"], factor * params["final"],
                         params["duration"])
    raise InputError(f'Parameter `kind`: expected "constant", "sine" or "linear", got {kind!r}')
