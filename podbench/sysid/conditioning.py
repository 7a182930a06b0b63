"""Signal conditioning before identification: what an experimentalist does to an impact test's
records, using only what the measurement shows — never the truth.

Three operations, applied in this order by :func:`condition` (and by the harness to every
training record of a scenario or sweep with a ``[conditioning]`` table):

1. **Detrending** (``detrend = "mean"`` or ``"linear"``). A load-cell offset or a slow drift
   of the charge amplifier is removed from each force channel by fitting a constant or a
   line to the channel's *quiet* part — the samples outside the detected impacts, where an
   impact force is zero — and subtracting it over the whole record. A response channel is
   not zero after the trigger, so its baseline is fitted to the *pre-trigger* part only (the
   samples before the first detected impact on any force channel, less a margin) and only
   when there are at least ``min_pretrigger`` of them; otherwise the response is left as it
   is (podbench's simulated pulses start at sample 1: no pre-trigger part). Brandt, *Noise
   and Vibration Analysis* (2011), §§11.2, 13.3 (offset removal, pre-trigger); Ewins, *Modal
   Testing* (2000), §3.9.
2. **Force window** (``force_window = {pre = 1e-4, post = 2e-3}``, seconds). Each force
   channel is kept from ``pre`` before to ``post`` after every detected impact (double and
   triple hits are kept) and set to zero elsewhere: the noise between and after the impacts
   is removed, since the true force is zero there. Ewins §3.9.4 ("force window"); Brandt
   §13.5.
3. **Exponential window** (``exponential_window = {tau = 0.05}``, seconds). Responses and
   forces are multiplied by ``e^{−t/τ}`` (``v0 → v0 − w0/τ`` so the initial state stays that
   of the windowed signal). For a linear system this is exact, not an approximation: the
   windowed records are the records of the same structure with apparent extra damping
   ``σ = 1/τ`` (every pole moves left by ``1/τ``), and for the convolution model
   ``W = C * F`` (Eq. 3.39) windowing both gives ``W e^{−t/τ} = (C e^{−t/τ}) * (F e^{−t/τ})``,
   sample by sample. A method identifies the windowed kernel; the correction un-windows it,
   ``C = C_w e^{+t/τ}`` — :class:`WindowCorrected` does it on the prediction,
   ``Ŵ = e^{+t/τ} · predict(F e^{−t/τ})``, which is the same thing for every method that is
   exact on a linear system. Noise: the window attenuates late samples of signal and noise
   alike (the local SNR is unchanged) but shortens the effective kernel, so the
   deconvolution is better conditioned and its regularization acts on a decayed tail; the
   un-windowing then multiplies the kernel's error at time t by ``e^{t/τ}`` — late errors
   are amplified, so ``τ`` much shorter than the record trades a better-posed fit for a
   noisier late prediction (measured in docs: choose ``τ`` of the order of the record).
   Fladung & Rost, "Application and correction of the exponential window for frequency
   response functions", *Mech. Syst. Signal Process.* 11(1) 23–36 (1997); Ewins §3.9.4.

Impact detection (:func:`detect_impacts`) reads the measured force alone: a baseline line is
fitted to the quiet samples, the noise floor is ``1.4826 × MAD`` of the quiet residual, and a
sample belongs to an impact where ``|f − baseline| > max(threshold × peak, noise_factor ×
floor)``; two passes refine the quiet part. Force channels are the rows of the measured ``F``
that are not identically zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from podbench.core.records import Record
from podbench.core.validation import check_positive
from podbench.errors import InputError

__all__ = ["Conditioning", "condition", "detect_impacts", "detrend", "force_window",
           "exponential_window", "unwindow", "WindowCorrected", "DETREND_KINDS"]

DETREND_KINDS = ("mean", "linear")


@dataclass(frozen=True)
class Conditioning:
    """What :func:`condition` does to a record (module docstring).

    Parameters
    ----------
    detrend : {None, "mean", "linear"}
        Baseline removal.
    force_window : (pre_s, post_s) or None
        Keep each force channel from ``pre`` s before to ``post`` s after every impact.
    exponential_window : float or None
        ``τ`` (s) of the exponential window on responses and forces.
    threshold : float
        Impact detection: fraction of the channel's peak (default 0.05).
    noise_factor : float
        Impact detection: multiple of the noise floor (default 5).
    min_pretrigger : int
        Fewest pre-trigger samples for a response baseline (default 8).
    """

    detrend: str | None = None
    force_window: tuple[float, float] | None = None
    exponential_window: float | None = None
    threshold: float = 0.05
    noise_factor: float = 5.0
    min_pretrigger: int = 8

    def __post_init__(self):
        if self.detrend is not None and self.detrend not in DETREND_KINDS:
            raise InputError(f"Parameter `detrend`: expected one of {', '.join(DETREND_KINDS)} "
                             f"or None, got {self.detrend!r}")
        if self.force_window is not None:
            try:
                pre, post = (float(x) for x in self.force_window)
            except (TypeError, ValueError):
                raise InputError("Parameter `force_window`: expected (pre_s, post_s), got "
                                 f"{self.force_window!r}") from None
            if not (math.isfinite(pre) and math.isfinite(post) and pre >= 0 and post >= 0):
                raise InputError("Parameter `force_window`: expected pre, post >= 0 s, got "
                                 f"{self.force_window!r}")
            object.__setattr__(self, "force_window", (pre, post))
        if self.exponential_window is not None:
            object.__setattr__(self, "exponential_window",
                               check_positive(self.exponential_window, "exponential_window"))
        check_positive(self.threshold, "threshold")
        check_positive(self.noise_factor, "noise_factor", allow_zero=True)
        if int(self.min_pretrigger) != self.min_pretrigger or self.min_pretrigger < 1:
            raise InputError(f"Parameter `min_pretrigger`: expected an integer >= 1, got "
                             f"{self.min_pretrigger!r}")

    @property
    def is_identity(self) -> bool:
        return (self.detrend is None and self.force_window is None
                and self.exponential_window is None)


# ----------------------------------------------------------------------------- detection
def _force_rows(F: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.any(F != 0.0, axis=1))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(j0, j1)`` of every run of True in ``mask`` (j1 one past the end)."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(),
                    strict=True))


def _baseline(f: np.ndarray, quiet: np.ndarray, kind: str) -> np.ndarray:
    j = np.flatnonzero(quiet)
    if j.size == 0:
        return np.zeros_like(f)
    if kind == "mean" or j.size < 2:
        return np.full_like(f, float(np.mean(f[j])))
    a, b = np.polyfit(j.astype(float), f[j], 1)
    return a * np.arange(f.size) + b


def _detect(f: np.ndarray, threshold: float, noise_factor: float, kind: str = "linear"):
    """Impact runs and the quiet mask of one force channel (two passes)."""
    n = f.size
    quiet = np.ones(n, dtype=bool)
    margin = max(2, n // 200)
    runs: list[tuple[int, int]] = []
    for _ in range(3):
        r = f - _baseline(f, quiet, kind)
        q = np.abs(r[quiet]) if quiet.any() else np.abs(r)
        floor = 1.4826 * float(np.median(np.abs(q - np.median(q)))) if q.size else 0.0
        peak = float(np.max(np.abs(r)))
        if peak == 0.0:
            return [], np.ones(n, dtype=bool)
        thr = max(threshold * peak, noise_factor * floor)
        runs = _runs(np.abs(r) > thr)
        new = np.ones(n, dtype=bool)
        for j0, j1 in runs:
            new[max(0, j0 - margin):min(n, j1 + margin)] = False
        if np.array_equal(new, quiet):
            break
        quiet = new
    return runs, quiet


def detect_impacts(f, *, threshold: float = 0.05, noise_factor: float = 5.0):
    """Impacts of one measured force channel, from the channel alone.

    Parameters
    ----------
    f : (n,) array
        The measured force (lbf).
    threshold, noise_factor : float
        A sample is in an impact where ``|f − baseline| > max(threshold × peak,
        noise_factor × floor)`` (module docstring).

    Returns
    -------
    list of (j0, j1)
        Sample ranges of the impacts (``j1`` one past the last), in time order.
    """
    f = np.asarray(f, dtype=float)
    if f.ndim != 1:
        raise InputError(f"Parameter `f`: expected one force channel (n,), got shape {f.shape}")
    return _detect(f, threshold, noise_factor)[0]


# ----------------------------------------------------------------------------- operations
def detrend(W, F, kind: str = "linear", *, threshold: float = 0.05,
            noise_factor: float = 5.0, min_pretrigger: int = 8):
    """``(W, F)`` with their baselines removed (module docstring, item 1). ``F`` may be None
    (a free response: no trigger, responses unchanged)."""
    if kind not in DETREND_KINDS:
        raise InputError(f"Parameter `kind`: expected one of {', '.join(DETREND_KINDS)}, got "
                         f"{kind!r}")
    W = np.array(W, dtype=float)
    if F is None:
        return W, None
    F = np.array(F, dtype=float)
    first = None
    for i in _force_rows(F):
        runs, quiet = _detect(F[i], threshold, noise_factor, kind)
        F[i] -= _baseline(F[i], quiet, kind)
        if runs:
            first = runs[0][0] if first is None else min(first, runs[0][0])
    if first is not None:
        margin = max(2, W.shape[1] // 200)
        pre = np.zeros(W.shape[1], dtype=bool)
        pre[:max(0, first - margin)] = True
        if pre.sum() >= min_pretrigger:
            for i in range(W.shape[0]):
                W[i] -= _baseline(W[i], pre, kind)
    return W, F


def force_window(F, dt: float, pre: float, post: float, *, threshold: float = 0.05,
                 noise_factor: float = 5.0) -> np.ndarray:
    """``F`` with every force channel kept from ``pre`` s before to ``post`` s after each
    detected impact and zero elsewhere (module docstring, item 2)."""
    dt = check_positive(dt, "dt")
    F = np.array(F, dtype=float)
    n = F.shape[1]
    a, b = int(math.ceil(pre / dt - 1e-9)), int(math.ceil(post / dt - 1e-9))
    for i in _force_rows(F):
        keep = np.zeros(n, dtype=bool)
        for j0, j1 in _detect(F[i], threshold, noise_factor)[0]:
            keep[max(0, j0 - a):min(n, j1 + b)] = True
        F[i, ~keep] = 0.0
    return F


def _decay(n: int, dt: float, tau: float) -> np.ndarray:
    return np.exp(-np.arange(n) * dt / tau)


def exponential_window(W, F, dt: float, tau: float, w0=None, v0=None):
    """``(W e^{−t/τ}, F e^{−t/τ}, w0, v0 − w0/τ)`` (module docstring, item 3); ``F``,
    ``w0``, ``v0`` may be None."""
    dt, tau = check_positive(dt, "dt"), check_positive(tau, "tau")
    W = np.asarray(W, dtype=float)
    e = _decay(W.shape[1], dt, tau)
    Fw = None if F is None else np.asarray(F, dtype=float) * e
    if v0 is not None:
        v0 = np.asarray(v0, dtype=float) - (0.0 if w0 is None else np.asarray(w0) / tau)
    return W * e, Fw, w0, v0


def unwindow(W_hat, dt: float, tau: float) -> np.ndarray:
    """``Ŵ e^{+t/τ}``: the correction of an exponential window (module docstring)."""
    W_hat = np.asarray(W_hat, dtype=float)
    return W_hat / _decay(W_hat.shape[-1], dt, tau)


def _replace(record, **arrays):
    if isinstance(record, Record):
        return record.replace(**arrays)
    base = {k: getattr(record, k, None) for k in ("W", "F", "w0", "v0", "dt")}
    return Record(**{**base, **arrays})


def condition(record, spec: Conditioning):
    """``record`` conditioned by ``spec``: detrend, force window, exponential window, in that
    order. Reads only the record's own arrays (``W, F, w0, v0, dt``). A
    :class:`~podbench.data.Response` or :class:`~podbench.records.Record` comes back as the
    same type; any other record-like object as a Record."""
    if spec.is_identity:
        return record
    W = np.asarray(record.W, dtype=float)
    F = getattr(record, "F", None)
    F = None if F is None else np.asarray(F, dtype=float)
    w0, v0, dt = getattr(record, "w0", None), getattr(record, "v0", None), record.dt
    if spec.detrend is not None:
        W, F = detrend(W, F, spec.detrend, threshold=spec.threshold,
                       noise_factor=spec.noise_factor, min_pretrigger=spec.min_pretrigger)
    if spec.force_window is not None and F is not None:
        F = force_window(F, dt, *spec.force_window, threshold=spec.threshold,
                         noise_factor=spec.noise_factor)
    if spec.exponential_window is not None:
        W, F, w0, v0 = exponential_window(W, F, dt, spec.exponential_window, w0, v0)
    return _replace(record, W=W, F=F, w0=w0, v0=v0)


class WindowCorrected:
    """A fitted method whose training records were exponentially windowed (``τ``), with its
    prediction corrected: ``predict(r) = e^{+t/τ} · method.predict(r windowed)`` — exact for
    every method exact on a linear system (module docstring, item 3). Every other attribute
    (``modes_``, ``diagnostics_``, ``coupled``, …) is the wrapped method's."""

    def __init__(self, method, tau: float):
        self.method = method
        self.tau = check_positive(tau, "tau")

    def __getattr__(self, name):
        return getattr(self.__dict__["method"], name)

    def predict(self, record):
        spec = Conditioning(exponential_window=self.tau)
        W_hat = self.method.predict(condition(record, spec))
        return unwindow(W_hat, record.dt, self.tau)
