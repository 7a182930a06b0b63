"""What a study's figures draw beside the displacement norm (Eq. 4.1): the response at two
sensors and the amplitude spectrum over all sensors, of the truth and of every prediction.

The runner keeps them per target in :attr:`podbench.harness.runner.UnitResult.series`
(:func:`truth_series` once, :func:`prediction_series` per method), so the report draws them
and computes nothing. The two sensors are chosen from the target's truth alone, before any
method is seen (:func:`pick_sensors`): the one that moves most (the tip of a cantilever)
and the one nearest mid-span.
"""

from __future__ import annotations

import numpy as np

__all__ = ["pick_sensors", "amplitude_spectrum", "truth_series", "prediction_series"]


def _nearest(positions: np.ndarray, rms: np.ndarray, at: float, exclude: int) -> int:
    """The sensor nearest position ``at`` (among sensors at the same position, the one with
    the largest RMS; ``exclude`` is never chosen unless it is the only sensor)."""
    dist = np.abs(positions - at)
    if positions.size > 1:
        dist[exclude] = np.inf
    tied = np.flatnonzero(dist == dist.min())
    return int(tied[np.argmax(rms[tied])])


def pick_sensors(W, positions=None, labels=()) -> list[dict]:
    """The sensors a target's figure shows, chosen from its truth ``W`` (m × n) alone.

    The first is the sensor of the largest RMS response (the tip of a cantilever); its role
    is ``"tip"`` when it sits at an end of the sensor line (the largest or smallest of
    ``positions``), ``"largest response"`` otherwise. The second is the sensor nearest the
    middle of the sensor line (``"mid-span"``; among the sensors at one position, e.g. a
    truss face's three coordinates, the one that moves most), or nearest its quarter
    (``"quarter span"``) when the first sensor is itself at mid-span; without positions, the middle
    sensor by index (``"middle sensor"``). Ties go to the lower index. One sensor only when
    ``m = 1``.

    Parameters
    ----------
    W : (m, n) array
        The target's truth (in).
    positions : (m,) array, optional
        The sensors' positions along the structure (in), e.g.
        :attr:`podbench.structures.Structure.sensor_positions`.
    labels : sequence of str, optional
        The sensors' labels (default ``"sensor i"``).

    Returns
    -------
    list of dict
        ``{"index", "label", "role", "position"}`` per sensor (``position`` None without
        positions).
    """
    W = np.asarray(W, dtype=float)
    m = W.shape[0]
    rms = np.sqrt(np.mean(W ** 2, axis=1)) if W.shape[1] else np.zeros(m)
    labels = list(labels) if labels is not None and len(labels) == m else [
        f"sensor {i}" for i in range(m)]
    pos = None
    if positions is not None and np.size(positions) == m:
        pos = np.asarray(positions, dtype=float).ravel()
    first = int(np.argmax(rms))
    if pos is None:
        role1 = "largest response"
        second, role2 = (m // 2 if m // 2 != first else (m // 2 + 1) % m), "middle sensor"
    else:
        lo, hi = float(pos.min()), float(pos.max())
        role1 = "tip" if hi > lo and pos[first] in (lo, hi) else "largest response"
        second, role2 = _nearest(pos, rms, (lo + hi) / 2, first), "mid-span"
        if abs(pos[first] - (lo + hi) / 2) <= abs(pos[second] - (lo + hi) / 2):
            second, role2 = _nearest(pos, rms, lo + (hi - lo) / 4, first), "quarter span"
    picks = [(first, role1)] + ([(second, role2)] if m > 1 else [])
    return [{"index": i, "label": labels[i], "role": role,
             "position": None if pos is None else float(pos[i])} for i, role in picks]


def amplitude_spectrum(W, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The one-sided amplitude spectrum of a record over all its sensors.

    Each sensor's history is weighted by a Hann window (the records are not periodic: an
    undamped free response never decays) and transformed; at frequency ``f_k = k / (n·dt)``
    the amplitude of sensor i is ``a_ik = 2 |X_ik| / Σ_j h_j`` (``|X_i0| / Σ h`` at 0 Hz,
    the amplitude of a sinusoid at a bin frequency), and the spectrum is
    ``A(f_k) = (Σ_i a_ik²)^½``, the frequency-domain companion of ‖w(t)‖ (Eq. 4.1).

    Parameters
    ----------
    W : (m, n) array
        Displacements (in), column j at ``t_j = j·dt``.
    dt : float
        Sampling interval (s).

    Returns
    -------
    f : (n // 2 + 1,) array
        Frequencies (Hz).
    A : (n // 2 + 1,) array
        Amplitudes (in, the unit of ``W``).
    """
    W = np.atleast_2d(np.asarray(W, dtype=float))
    n = W.shape[1]
    h = np.hanning(n) if n > 1 else np.ones(n)
    a = np.abs(np.fft.rfft(W * h, axis=1)) / max(float(h.sum()), np.finfo(float).tiny)
    a[:, 1:] *= 2.0
    if n % 2 == 0 and n > 1:  # the Nyquist bin is not doubled either
        a[:, -1] /= 2.0
    return np.fft.rfftfreq(n, dt), np.sqrt(np.sum(a ** 2, axis=0))


def truth_series(W, dt: float, *, positions=None, labels=(), unit: str = "in") -> dict:
    """The truth's entries of a target's figure series: the chosen sensors
    (:func:`pick_sensors`) and their histories, the amplitude spectrum
    (:func:`amplitude_spectrum`) and the displacement unit."""
    W = np.asarray(W, dtype=float)
    picks = pick_sensors(W, positions, labels)
    f, amp = amplitude_spectrum(W, dt)
    return {"sensors": picks, "sensor_truth": W[[p["index"] for p in picks]],
            "freq": f, "spectrum": amp, "unit": unit}


def prediction_series(label: str, W_hat, dt: float, sensors: list[dict]) -> dict:
    """A prediction's entries of a target's figure series, under its method's ``label``:
    its histories at the truth's chosen ``sensors`` (``<label>__sensors``) and its
    amplitude spectrum (``<label>__spectrum``)."""
    W_hat = np.asarray(W_hat, dtype=float)
    return {label + "__sensors": W_hat[[p["index"] for p in sensors]],
            label + "__spectrum": amplitude_spectrum(W_hat, dt)[1]}
