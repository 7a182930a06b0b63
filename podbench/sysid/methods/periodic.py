"""The best linear approximation, and ML's periodic kernel interpolated across force levels.

Under a periodic excitation in steady state ML's kernel over one period is a circular
convolution, i.e. the frequency response on the excited lines
(:class:`~podbench.sysid.methods.MultipleLoad` with ``inputs="periodic"``,
:mod:`podbench.sysid.periodic`). Two models are built on it here:

* :class:`BestLinearApproximation` (``BLA``): the same in the output channels (no POD):
  Pintelon & Schoukens' nonparametric best linear approximation, pooled over the records,
  with the noise variance of its frequency response (``noise_variance_``). It is the
  benchmark's nonparametric reference, not an ML: with ``k = n_out`` POMs ML's periodic
  kernel equals it to round-off (``U`` is then a rotation of the outputs).
* :class:`LevelInterpolatedML` (``ML-interp``): one periodic kernel per force level
  (records of one level pooled), interpolated in the input RMS of the target's steady
  state — a linear model whose parameters vary with the excitation amplitude (a "linear
  parameter-varying" model frozen at the target's level). A family of kernels indexed by
  level rather than ML's one kernel, hence its own class.

Prediction from the input alone (``predict``): the whole record, from rest, is the linear
convolution of the measured input with the period's kernel; ``predict_periodic`` gives one
steady-state period from the target's period-averaged input spectrum.

Units: the frequency response in (output unit)/(input unit) (e.g. (m/s²)/N), the kernel in
(output unit)/(input unit·s).
"""

from __future__ import annotations

import numpy as np

from podbench.errors import InputError
from podbench.sysid.methods.forced import MultipleLoad
from podbench.sysid.params import InstanceOf, Interval, Options
from podbench.sysid.periodic import (
    input_rms,
    interpolation_weights,
    pooled_response,
)

__all__ = ["BestLinearApproximation", "LevelInterpolatedML", "input_rms",
           "interpolation_weights"]

_PERIODIC = {"period": [None, Interval("integer", 2)],
             "transient_periods": [Interval("integer", 0)],
             "lines": [Options("auto"), InstanceOf((tuple, list, np.ndarray),
                                                   "a sequence of DFT line indices")]}


class BestLinearApproximation(MultipleLoad):
    """The best linear approximation (Pintelon & Schoukens) in the output channels: the
    frequency response on the excited lines, pooled over the training records by least
    squares (ML's periodic kernel without the POD: ``U = I``).

    Parameters
    ----------
    period : int
        Samples per period of the excitation (required).
    transient_periods : int
        Leading periods of every record left out of the fit (the start-up transient).
    lines : "auto" or sequence of int
        The lines (DFT indices over one period) identified (see
        :class:`~podbench.sysid.methods.MultipleLoad`).
    """

    abbreviation = "BLA"
    coupled = False
    _parameter_constraints = dict(_PERIODIC)

    # ML's hyperparameters this model fixes (read by the periodic fit)
    inputs = "periodic"
    n_modes = None
    basis = "first"
    n_lags = None
    prior = None
    solver = "ls"
    solver_options = None

    def __init__(self, *, period=None, transient_periods=1, lines="auto"):
        self.period = period
        self.transient_periods = transient_periods
        self.lines = lines

    def _measured_basis(self, recs):
        """The output channels themselves (``U = I``) and their RMS over the records."""
        m = recs[0].n_outputs
        return np.eye(m), np.linalg.norm(np.hstack([r.y for r in recs]), axis=1)


class LevelInterpolatedML(MultipleLoad):
    """ML's periodic kernel per force level, interpolated in the target's input RMS
    (module docstring).

    The records of one level (equal steady-state input RMS to 1e-6) are pooled into one
    frequency response; the target's response is the piecewise-linear interpolation of
    the levels' responses at the target's steady-state input RMS
    (:func:`~podbench.sysid.periodic.interpolation_weights`).

    Parameters
    ----------
    n_modes : int, optional
        ``k`` (default: every output channel).
    period, transient_periods, lines
        As :class:`~podbench.sysid.methods.MultipleLoad` with ``inputs="periodic"``.
    scale : "linear" or "log"
        Interpolate in the input RMS or in its logarithm.
    extrapolate : "clamp" or "linear"
        Outside the training levels: the nearest level's model, or the end segment
        continued.

    Attributes
    ----------
    levels_ : (n_levels,) ndarray
        The training levels' input RMS (input unit), increasing.
    level_responses_ : (n_levels, k, n_in, L) complex ndarray
    """

    abbreviation = "ML-interp"
    _parameter_constraints = {"n_modes": MultipleLoad._parameter_constraints["n_modes"],
                              **_PERIODIC, "scale": [Options("linear", "log")],
                              "extrapolate": [Options("clamp", "linear")]}

    inputs = "periodic"
    basis = "first"
    n_lags = None
    prior = None
    solver = "ls"
    solver_options = None

    def __init__(self, *, n_modes=None, period=None, transient_periods=1, lines="auto",
                 scale="linear", extrapolate="clamp"):
        self.n_modes = n_modes
        self.period = period
        self.transient_periods = transient_periods
        self.lines = lines
        self.scale = scale
        self.extrapolate = extrapolate

    def _fit_response(self, recs, spectra, lines) -> None:
        P, T = self._period()
        rms = np.array([input_rms(r.u, P, T, f"{r.name}: field `inputs`") for r in recs])
        groups: list[list[int]] = []
        for j in np.argsort(rms, kind="stable"):
            if groups and abs(rms[j] - rms[groups[-1][0]]) <= 1e-6 * rms[groups[-1][0]]:
                groups[-1].append(int(j))
            else:
                groups.append([int(j)])
        self.levels_ = np.array([np.mean(rms[g]) for g in groups])
        self.level_responses_ = np.stack([
            pooled_response([spectra[j].U_mean for j in g], [spectra[j].Y_mean for j in g],
                            lines) for g in groups])
        super()._fit_response(recs, spectra, lines)

    def _response_for(self, record) -> np.ndarray:
        P, T = self._period()
        if record.u is None:
            raise InputError(f"{record.name}: field `inputs`: missing (the level is the "
                             "input's RMS)")
        w = interpolation_weights(self.levels_, input_rms(record.u, P, T,
                                                          f"{record.name}: field `inputs`"),
                                  scale=self.scale, extrapolate=self.extrapolate)
        return np.einsum("l,lkim->kim", w, self.level_responses_)
