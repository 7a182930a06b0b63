"""ML on periodic excitation: the kernel over one period, and models across force levels.

The dissertation's ML (Eq. 3.48) convolves the measured inputs with a kernel ``H`` to give
the POC histories ``v = Uᵀy``. Under a periodic excitation in steady state (a multisine
repeated over periods of ``N`` samples) the natural kernel is the one over a whole period,
and the convolution is *circular*: ``v̄[s] = Δt Σ_{p<N} H[p] ū[(s − p) mod N]`` for the
period-averaged signals. Its DFT over the period is, line by line,
``V̄(k) = Ĥ(k) Ū(k)`` (``Ĥ`` the DFT of ``Δt·H``): the kernel over one period *is* the
frequency response on the excited lines, and the least-squares kernel from several
records is the frequency response pooled over them
(:func:`podbench.sysid.periodic.pooled_response`); lines the inputs do not excite carry
nothing and are left at zero. A kernel of ``N`` lags holds the structure's whole memory
up to one period (a truncated FIR of a lightly damped structure does not).

* :class:`MultipleLoadPeriodic` (``ML``): the POMs ``U`` of the training outputs, the
  kernel over one period from the period-averaged POC and input spectra of the
  steady-state periods of every record, pooled by least squares. With ``k = n_out`` it
  equals the best linear approximation (BLA) to round-off (``U`` is then a rotation of
  the outputs).
* :class:`BestLinearApproximation` (``BLA``): the same in the output channels (no POD):
  Pintelon & Schoukens' nonparametric best linear approximation, pooled over the records,
  with the noise variance of its frequency response (``noise_variance_``).
* :class:`LevelInterpolatedML` (``ML-interp``): one kernel per force level (records of
  one level pooled), interpolated in the input RMS of the target's steady state — a
  linear model whose parameters vary with the excitation amplitude (a "linear parameter-
  varying" model frozen at the target's level).

Prediction from the input alone (``predict``): the whole record, from rest, is the
*linear* convolution of the measured input with the period's kernel (``N`` lags): in
every period after the first it equals the circular one (the steady state); over the first
period it is the kernel's transient. ``predict_periodic`` gives one steady-state period
from the target's period-averaged input spectrum (the BLA's own prediction).

Units: the frequency response in (output unit)/(input unit) (e.g. (m/s²)/N), the kernel
``kernel_`` in (output unit)/(input unit·s), as :class:`~podbench.sysid.methods.inputs.
MultipleLoadIO`'s.
"""

from __future__ import annotations

import numpy as np

from podbench.core.iorecords import IORecord, check_records
from podbench.errors import InputError
from podbench.sysid.methods.inputs import MultipleLoadIO, given_basis, io_records
from podbench.sysid.periodic import (
    LINE_THRESHOLD,
    excited_lines,
    noise_variance,
    period_spectra,
    periodic_prediction,
    pooled_response,
    steady_periods,
)

__all__ = ["MultipleLoadPeriodic", "BestLinearApproximation", "LevelInterpolatedML",
           "input_rms", "interpolation_weights"]


def input_rms(record: IORecord, period: int, transient: int) -> float:
    """RMS of a record's inputs over its steady-state periods (all input channels; the
    input unit, e.g. N): the force level a model of that record belongs to."""
    x = steady_periods(record.u, period, transient, f"{record.name}: field `inputs`")
    return float(np.sqrt(np.mean(x ** 2)))


def interpolation_weights(levels, x: float, *, scale: str = "linear",
                          extrapolate: str = "clamp") -> np.ndarray:
    """Weights of piecewise-linear interpolation at ``x`` between the sorted, distinct
    ``levels``: the two neighbours of ``x`` share the weight by their distance (in ``x`` or,
    ``scale="log"``, in ``log x``). Outside the range ``extrapolate="clamp"`` gives the
    nearest level its whole weight, ``"linear"`` continues the end segment. One level: 1."""
    r = np.asarray(levels, dtype=float)
    w = np.zeros(r.size)
    if r.size == 1:
        w[0] = 1.0
        return w
    if scale == "log":
        r, x = np.log(r), float(np.log(x))
    if extrapolate == "clamp" and (x <= r[0] or x >= r[-1]):
        w[0 if x <= r[0] else -1] = 1.0
        return w
    i = int(np.clip(np.searchsorted(r, x), 1, r.size - 1))
    t = (x - r[i - 1]) / (r[i] - r[i - 1])
    w[i - 1], w[i] = 1.0 - t, t
    return w


def _period_param(value, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InputError(f"Parameter `{name}`: expected an integer >= {low}, got {value!r}")
    return int(value)


class MultipleLoadPeriodic(MultipleLoadIO):
    """ML with the kernel over one period of a periodic excitation (module docstring).

    Parameters
    ----------
    n_modes : int, optional
        ``k`` (default: the number of output channels).
    period : int
        Samples per period of the excitation (required).
    transient_periods : int
        Leading periods of every record left out of the fit (the start-up transient).
    lines : "auto" or sequence of int
        The lines (DFT indices over one period) the kernel is identified on: ``"auto"``,
        those whose input power is at least ``line_threshold`` × the strongest line's
        (summed over the training records); or given.
    line_threshold : float
        The relative input power of an excited line for ``lines="auto"``
        (:data:`~podbench.sysid.periodic.LINE_THRESHOLD`).

    Attributes
    ----------
    modes_ : (n_out, k) ndarray
    lines_ : (L,) ndarray of int
    frequencies_ : (L,) ndarray
        The lines in Hz.
    response_ : (k, n_in, L) complex ndarray
        The frequency response in the POC coordinates (the kernel's DFT over one period).
    kernel_ : (k, n_in, period) ndarray
        ``H[p]`` in (output unit)/(input unit·s), lag ``p = 0 … period − 1``.
    noise_variance_ : (k, L) ndarray
        Variance of ``response_`` from the spread over the periods (one input; NaN
        otherwise).
    """

    abbreviation = "ML"
    coupled = True

    def __init__(self, *, n_modes=None, period=None, transient_periods=1, lines="auto",
                 line_threshold=LINE_THRESHOLD):
        self.n_modes = n_modes
        self.period = period
        self.transient_periods = transient_periods
        self.lines = lines
        self.line_threshold = line_threshold

    # the truncated-kernel hyperparameters of the parent do not apply
    n_lags = None
    prior = None
    feedthrough = "auto"
    solver = "ls"

    def _check_params(self) -> tuple[int, int]:
        if self.period is None:
            raise InputError("Parameter `period`: required (the samples per period of the "
                             "periodic excitation)")
        P = _period_param(self.period, "period", 2)
        T = _period_param(self.transient_periods, "transient_periods", 0)
        thr = self.line_threshold
        if isinstance(thr, bool) or not isinstance(thr, (int, float)) or not 0 < thr <= 1:
            raise InputError(f"Parameter `line_threshold`: expected a number in (0, 1], got "
                             f"{thr!r}")
        return P, T

    def _lines(self, U_means, period: int) -> np.ndarray:
        if isinstance(self.lines, str) and self.lines == "auto":
            return excited_lines(U_means, float(self.line_threshold))
        if isinstance(self.lines, str):
            raise InputError(f"Parameter `lines`: expected 'auto' or DFT line indices, got "
                             f"{self.lines!r}")
        lines = np.asarray(self.lines)
        if lines.ndim != 1 or lines.size == 0 or lines.dtype.kind not in "iu" or \
                lines.min() < 1 or lines.max() > period // 2 or np.any(np.diff(lines) <= 0):
            raise InputError(f"Parameter `lines`: expected increasing indices in 1 … "
                             f"{period // 2}, got {self.lines!r}")
        return lines

    def _spectra(self, recs, U):
        P, T = self._check_params()
        return [period_spectra(r.u, U.T @ r.y, P, T, r.name) for r in recs]

    def fit(self, records, basis=None) -> MultipleLoadPeriodic:
        """Identify the kernel over one period from training IORecords; returns ``self``.

        ``basis`` (n_out × k): the POMs to use instead of the records' own."""
        recs = io_records(records)
        P, T = self._check_params()
        check_records(recs, min_samples=(T + 1) * P)
        U, povs = self._basis(recs) if basis is None else given_basis(recs, basis)
        spectra = self._spectra(recs, U)
        lines = self._lines([s.U_mean for s in spectra], P)
        self.modes_ = U
        self.povs_ = povs
        self.n_modes_ = U.shape[1]
        self.dt_ = recs[0].dt
        self.reference_ = recs[0]
        self.lines_ = lines
        self.frequencies_ = lines / (P * self.dt_)
        self._fit_response(recs, spectra, lines)
        self.info_ = {"n_lines": int(lines.size), "f_min_Hz": float(self.frequencies_[0]),
                      "f_max_Hz": float(self.frequencies_[-1]), "period": P,
                      "steady_periods": int(min(s.n_periods for s in spectra))}
        return self

    def _fit_response(self, recs, spectra, lines) -> None:
        """The pooled response, its noise variance and kernel (the subclasses' own rule)."""
        G = pooled_response([s.U_mean for s in spectra], [s.Y_mean for s in spectra], lines)
        self.response_ = G
        self.noise_variance_ = _pooled_noise(spectra, lines)
        self.kernel_ = self._kernel(G)

    def _kernel(self, G) -> np.ndarray:
        """``H[p]`` (k, n_in, period) of a response on the lines: its inverse DFT over one
        period, divided by ``Δt`` (the kernel of ``v = Δt Σ H u``)."""
        P = int(self.period)
        full = np.zeros(G.shape[:2] + (P // 2 + 1,), dtype=complex)
        full[:, :, self.lines_] = G
        return np.fft.irfft(full, n=P, axis=2) / self.dt_

    def frozen_params(self) -> dict:
        """The lines chosen by ``lines="auto"`` (the band's refits keep them)."""
        self._check_is_fitted()
        if isinstance(self.lines, str):
            return {"lines": tuple(int(k) for k in self.lines_)}
        return {}

    def _response_for(self, record) -> np.ndarray:
        """The frequency response (k, n_in, L) the target is predicted with."""
        return self.response_

    def predict_coordinates(self, record) -> np.ndarray:
        """The POC histories ``v̂`` (k × n) of the target's whole record from rest: the
        linear convolution of its inputs with the kernel over one period."""
        rec = self._target(record)
        G = self._response_for(rec)
        H = self.kernel_ if G is self.response_ else self._kernel(G)
        n = rec.n_samples
        nfft = 1 << int(np.ceil(np.log2(n + H.shape[2] - 1)))
        Uf = np.fft.rfft(rec.u, nfft, axis=1)
        Hf = np.fft.rfft(H * self.dt_, nfft, axis=2)
        return np.fft.irfft(np.einsum("kif,if->kf", Hf, Uf), nfft, axis=1)[:, :n]

    def predict(self, record, coverage=None) -> np.ndarray:
        """Predicted outputs ``ŷ = U v̂`` (n_out × n, the training output unit) of the
        target's whole record from rest; ``coverage=c`` returns a
        :class:`~podbench.sysid.methods.bands.Prediction` (handled by
        :class:`~podbench.sysid.methods.base.PODMethod`)."""
        self._check_is_fitted()
        return self.modes_ @ self.predict_coordinates(record)

    def frequency_response(self, record=None) -> np.ndarray:
        """The frequency response in the output channels (n_out, n_in, L) on ``lines_``:
        ``U·response_`` (for :class:`LevelInterpolatedML`, at ``record``'s level)."""
        self._check_is_fitted()
        G = self.response_ if record is None else self._response_for(self._target(record))
        return np.einsum("ok,kil->oil", self.modes_, G)

    def predict_periodic(self, record) -> np.ndarray:
        """One steady-state period (n_out × period) of the target's response: the frequency
        response times the target's period-averaged input spectrum on the lines."""
        rec = self._target(record)
        P, T = self._check_params()
        spec = period_spectra(rec.u, None, P, T, rec.name)
        return periodic_prediction(self.frequency_response(rec), self.lines_,
                                   spec.U_mean, P)


def _pooled_noise(spectra, lines) -> np.ndarray:
    """Noise variance of the pooled response (k, L): ``Σ_l w_l² var(Ĝ_l)`` with the
    pooling weights ``w_l = |Ū_l|²/Σ|Ū|²`` (one input)."""
    power = np.array([np.sum(np.abs(s.U_mean[:, lines]) ** 2, axis=0) for s in spectra])
    w = power / power.sum(axis=0)
    return sum(wl[None, :] ** 2 * noise_variance(s, lines)
               for wl, s in zip(w, spectra, strict=True))


class BestLinearApproximation(MultipleLoadPeriodic):
    """The best linear approximation (Pintelon & Schoukens) in the output channels: the
    frequency response on the excited lines, pooled over the training records by least
    squares (:class:`MultipleLoadPeriodic` without the POD: ``U = I``)."""

    abbreviation = "BLA"
    coupled = False

    def __init__(self, *, period=None, transient_periods=1, lines="auto",
                 line_threshold=LINE_THRESHOLD):
        self.period = period
        self.transient_periods = transient_periods
        self.lines = lines
        self.line_threshold = line_threshold

    @property
    def n_modes(self):
        return None

    def _basis(self, recs):
        m = recs[0].n_outputs
        return np.eye(m), np.linalg.norm(np.hstack([r.y for r in recs]), axis=1)


class LevelInterpolatedML(MultipleLoadPeriodic):
    """ML per force level, interpolated in the target's input RMS (module docstring).

    The records of one level (equal steady-state input RMS to 1e-6) are pooled into one
    frequency response; the target's response is the piecewise-linear interpolation of
    the levels' responses at the target's steady-state input RMS
    (:func:`interpolation_weights`).

    Parameters
    ----------
    n_modes, period, transient_periods, lines, line_threshold
        As :class:`MultipleLoadPeriodic`.
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

    def __init__(self, *, n_modes=None, period=None, transient_periods=1, lines="auto",
                 line_threshold=LINE_THRESHOLD, scale="linear", extrapolate="clamp"):
        super().__init__(n_modes=n_modes, period=period, transient_periods=transient_periods,
                         lines=lines, line_threshold=line_threshold)
        self.scale = scale
        self.extrapolate = extrapolate

    def _fit_response(self, recs, spectra, lines) -> None:
        if self.scale not in ("linear", "log"):
            raise InputError(f"Parameter `scale`: expected 'linear' or 'log', got "
                             f"{self.scale!r}")
        if self.extrapolate not in ("clamp", "linear"):
            raise InputError(f"Parameter `extrapolate`: expected 'clamp' or 'linear', got "
                             f"{self.extrapolate!r}")
        P, T = self._check_params()
        rms = np.array([input_rms(r, P, T) for r in recs])
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
        P, T = self._check_params()
        w = interpolation_weights(self.levels_, input_rms(record, P, T), scale=self.scale,
                                  extrapolate=self.extrapolate)
        return np.einsum("l,lkim->kim", w, self.level_responses_)
