"""The signal-to-noise ratio of the data of a deconvolution, estimated from the data alone.

The appendix's ``tlsdeconv`` keeps the directions of ``[X y]`` with ``σ_1/σ_i <= tol`` and
sets ``tol = 1000; %based on SNR of data``, asking for the choice to be "automated, not
specified like it is now". :func:`system_snr` is that automation's measurement: the
amplitude SNR (RMS of the signal over the standard deviation of the noise, 1000 = 60 dB) of
the modal forces whose shifts are the columns of ``X`` (the smallest over the load cases and
modes). The noise is white measurement noise; its standard deviation is estimated from the
signal's fourth differences by their median absolute value (:func:`noise_std`), which a
smooth response and a few short force pulses leave almost untouched. Nothing but the
samples is used: no noise level, no clean record.

Why the forces in ``X`` and not also ``y``: ``tol`` bounds ``σ_1/σ_i`` of ``[X y]``, whose
scale and noise directions the ``n`` shifted force columns set (``y`` is one column). A POC
history of a weak POM has a low SNR because its signal is small, not because its noise is
large (ML's second column on the Chapter 5 records: 0.7–6.7 where the forces read 20 at
5 % noise); the smallest SNR over ``X`` and ``y`` is the named alternative
(``include_response=True``).
"""

from __future__ import annotations

from math import comb

import numpy as np

__all__ = ["DIFFERENCE_ORDER", "noise_std", "snr", "system_snr"]

DIFFERENCE_ORDER = 4
"""Order ``k`` of the differences :func:`noise_std` reads. White noise of standard deviation
``s`` gives ``k``-th differences of standard deviation ``s·√C(2k, k)`` (``√70`` at ``k = 4``);
a sinusoid of frequency ``f`` sampled at ``Δt`` is multiplied by ``(2 sin(π f Δt))^k``, so a
fourth difference keeps 1.7 % (relative to ``√70``) of a component at a tenth of the sampling
rate and 2e-4 of one at a thirtieth: the beam records' responses (modes below 400 Hz at
10 kHz) read as clean to SNRs of 10⁴ and above."""

_MAD = 1.482602218505602
"""``1/Φ⁻¹(3/4)``: the median absolute value of a standard normal sample times this is 1."""


def noise_std(x, order: int = DIFFERENCE_ORDER) -> float:
    """The standard deviation of white noise in the samples ``x``: ``1.4826 ×`` the median
    absolute ``order``-th difference over ``√C(2·order, order)``.

    The median ignores the few differences a force pulse or a fast transient makes large
    (up to half of them); 0 for a record without noise (a clean force's zeros).
    """
    x = np.asarray(x, dtype=float).ravel()
    if x.size <= order:
        return 0.0
    d = np.diff(x, n=order)
    return float(_MAD * np.median(np.abs(d)) / np.sqrt(comb(2 * order, order)))


def snr(x, order: int = DIFFERENCE_ORDER) -> float:
    """Amplitude signal-to-noise ratio of the samples ``x``: ``√(RMS(x)² − s²)/s`` with
    ``s`` = :func:`noise_std` (``inf`` when ``s`` is 0, NaN for a record of zeros)."""
    x = np.asarray(x, dtype=float).ravel()
    ms = float(np.mean(x * x)) if x.size else 0.0
    if ms == 0.0:
        return float("nan")
    s = noise_std(x, order)
    if s == 0.0:
        return float("inf")
    return float(np.sqrt(max(ms - s * s, 0.0)) / s)


def system_snr(system, column: int = 0, *, include_response: bool = False) -> float:
    """The SNR of the data of one right-hand side of a
    :class:`~podbench.deconvolution.ConvolutionSystem`: the smallest :func:`snr` over its
    modal forces (each load case's, each mode's: the columns of ``X`` are their shifts;
    with ``include_response`` also over the load cases' segments of the POC history
    ``y = B[:, column]``). Signals of zeros are skipped; ``inf`` when every signal is free
    of noise (a clean force is exactly zero between its pulses)."""
    G, Y = system.G, system.Y  # (n, n_cases, k), (n, n_cases, r)
    signals = [G[:, j, i] for j in range(G.shape[1]) for i in range(G.shape[2])]
    if include_response:
        signals += [Y[:, j, column] for j in range(Y.shape[1])]
    values = [v for v in (snr(s) for s in signals) if not np.isnan(v)]
    return min(values) if values else float("inf")
