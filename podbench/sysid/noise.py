"""Measurement noise the way a laboratory meets it: per measured channel, on the channels that
are measured.

A test measures each response channel with its own sensor and each applied force with one
load cell at the loaded point. The default model, ``"per_channel"``, follows that:

* every sensor row ``i`` of ``W`` gets independent Gaussian noise of standard deviation
  ``level × RMS(W[i])`` (the channel's own record);
* a **force channel exists where a load is applied**: the rows of ``F`` that are not
  identically zero in the clean record are instrumented and get noise of standard deviation
  ``level × RMS(F[i])``; the other rows of ``F`` are zero by construction and stay zero (no
  load cell measures them);
* the initial profiles ``w0``, ``v0`` (only if named in ``on``) are one snapshot across the
  sensors: each sensor's value gets independent noise of standard deviation
  ``level × RMS(profile)`` (a single sample has no record of its own to scale by).

The former model, ``"per_entry_rms"``, adds noise of standard deviation ``level × RMS`` of the
whole matrix to every entry of each quantity in ``on`` — every row of ``F``, also the 24 rows
of a beam record where no force acts. It is kept as a named option to compare with.

A signal-to-noise ratio in decibels is the same thing as a level:
``SNR = 20 log10(RMS(signal)/RMS(noise))``, so ``level = 10**(−snr_db/20)`` (40 dB = 1 %,
26 dB ≈ 5 %); see :func:`level_from_snr_db`.

Disturbances after simulation (on the *measured* force, i.e. the instrumented rows of ``F``):
``force_offset`` (a constant) and ``force_drift`` (a linear ramp from 0 at ``t = 0`` to its
value at the last sample), both relative to the channel's peak ``max |F[i]|``. They model a
load cell whose zero is off or wanders (charge amplifier drift); signal conditioning
(:mod:`podbench.conditioning`, ``detrend``) is what removes them. Double and triple hits are
not measurement errors but a different excitation, part of the truth: they are a pulse option,
``hits = [[delay_s, rel_amp], ...]`` (:class:`podbench.excitations.Pulse`).

Streams: every channel's draws come from :func:`noise_generator` keyed by
``(seed, scenario, structure, case, quantity, channel)`` — SHA-256 of the key, never the
global RNG — so the same seed gives the same pattern at every level (common random numbers)
on every machine, process and thread.

Example
-------
>>> from podbench.noise import NoiseSpec, noisy
>>> spec = NoiseSpec(level=0.01, seed=3)                     # 1 %, per channel  # doctest: +SKIP
>>> measured = noisy(response, spec, "my_scenario", "lti_beam", "load1")  # doctest: +SKIP
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass

import numpy as np

from podbench.core.response import Response
from podbench.errors import InputError

__all__ = ["NoiseSpec", "NOISE_MODELS", "NOISE_QUANTITIES", "noise_generator", "noisy",
           "force_channels", "level_from_snr_db", "snr_db_from_level"]

NOISE_MODELS = ("per_channel", "per_entry_rms")
"""``per_channel`` (default): per measured channel, on measured channels only;
``per_entry_rms``: one RMS per quantity, noise on every entry (podbench's first noise model)."""
NOISE_QUANTITIES = ("W", "F", "w0", "v0")


def level_from_snr_db(snr_db: float) -> float:
    """The relative level ``10**(−snr_db/20)`` of a signal-to-noise ratio in dB (amplitude:
    ``SNR = 20 log10(RMS signal / RMS noise)``)."""
    x = float(snr_db)
    if not math.isfinite(x):
        raise InputError(f"Parameter `snr_db`: expected a finite number of dB, got {snr_db!r}")
    return 10.0 ** (-x / 20.0)


def snr_db_from_level(level: float) -> float:
    """``−20 log10(level)`` dB (inf for level 0)."""
    return math.inf if level == 0 else -20.0 * math.log10(level)


@dataclass(frozen=True)
class NoiseSpec:
    """Measurement noise on the training records (see the module docstring).

    Parameters
    ----------
    level : float
        Relative standard deviation (0.01 = 1 % of the channel's RMS).
    seed : int
        Selects the realization.
    on : tuple of str
        Quantities that get noise: ``"W"``, ``"F"``, ``"w0"``, ``"v0"``.
    model : {"per_channel", "per_entry_rms"}
        Noise model (module docstring).
    force_offset, force_drift : float
        Offset and end-of-record drift of every measured force channel, relative to the
        channel's peak (0 = none); applied whatever ``level`` is.
    """

    level: float
    seed: int = 0
    on: tuple[str, ...] = ("W", "F")
    model: str = "per_channel"
    force_offset: float = 0.0
    force_drift: float = 0.0

    def __post_init__(self):
        for name in ("level", "force_offset", "force_drift"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"Parameter `{name}`: expected a finite number, got {v!r}")
        if self.level < 0:
            raise InputError(f"Parameter `level`: expected a level >= 0, got {self.level!r}")
        if self.model not in NOISE_MODELS:
            raise InputError(f"Parameter `model`: unknown noise model {self.model!r}; expected "
                             f"one of {', '.join(NOISE_MODELS)}")
        bad = [q for q in self.on if q not in NOISE_QUANTITIES]
        if bad:
            raise InputError(f"Parameter `on`: unknown quantity {bad[0]!r}; expected some of "
                             f"{', '.join(NOISE_QUANTITIES)}")

    @classmethod
    def from_snr_db(cls, snr_db: float, **kwargs) -> NoiseSpec:
        """The spec of a sensor SNR in dB (:func:`level_from_snr_db`)."""
        return cls(level=level_from_snr_db(snr_db), **kwargs)

    @property
    def is_null(self) -> bool:
        """True when nothing is added (level 0, no offset, no drift)."""
        return self.level == 0 and self.force_offset == 0 and self.force_drift == 0


def noise_generator(seed: int, *key: str) -> np.random.Generator:
    """The generator of one noise stream: ``SeedSequence`` entropy ``[seed, h_0 … h_7]``
    with ``h`` the eight 32-bit words of SHA-256 of the JSON list ``key``. Never the global
    RNG; identical on every machine, process and thread."""
    digest = hashlib.sha256(json.dumps(list(key)).encode("utf-8")).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 32, 4)]
    return np.random.default_rng(np.random.SeedSequence([int(seed), *words]))


def force_channels(F) -> np.ndarray:
    """Rows of ``F`` that carry a load cell: those not identically zero in the record
    ("a force channel exists where a load is applied"), as sorted row indices."""
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        return np.zeros(0, dtype=int)
    return np.flatnonzero(np.any(F != 0.0, axis=1))


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a**2))) if a.size else 0.0


def _per_channel(a: np.ndarray, rows, level: float, seed: int, key: tuple, q: str,
                 scale=None) -> np.ndarray:
    out = a.copy()
    for i in rows:
        s = _rms(a[i]) if scale is None else scale
        z = noise_generator(seed, *key, q, str(int(i))).standard_normal(a.shape[1:])
        out[i] = a[i] + (level * s) * z
    return out


def noisy(response, noise: NoiseSpec, *key: str) -> Response:
    """``response`` as a laboratory would have measured it under ``noise``.

    The harness uses ``key = (scenario, structure, case)``, with the unit's structure name
    also for its linear twin (the nonlinear and the linear data of a case carry the same
    pattern). The standard normal draws are scaled by the level, so the same seed gives the
    same pattern at every level. A null spec (:attr:`NoiseSpec.is_null`) returns
    ``response`` itself.

    ``response`` is a :class:`~podbench.data.Response` (any object with ``t, W, F, w0, v0,
    dt`` works; the result is a Response).
    """
    if noise.is_null:
        return response
    arrays = {q: np.array(getattr(response, q), dtype=float) for q in NOISE_QUANTITIES}
    F = arrays["F"]  # the clean force (the arrays below are replaced, not modified)
    measured_f = force_channels(F)  # decided on the clean record, before anything is added
    if noise.level > 0:
        lvl, seed = float(noise.level), int(noise.seed)
        for q in noise.on:
            a = arrays[q]
            if noise.model == "per_entry_rms":
                z = noise_generator(seed, *key, q).standard_normal(a.shape)
                arrays[q] = a + (lvl * _rms(a)) * z
            elif q == "W":
                arrays[q] = _per_channel(a, range(a.shape[0]), lvl, seed, key, q)
            elif q == "F":
                arrays[q] = _per_channel(a, measured_f, lvl, seed, key, q)
            else:  # w0 / v0: one snapshot, each sensor independent, scaled by the profile RMS
                arrays[q] = _per_channel(a[:, None], range(a.shape[0]), lvl, seed, key, q,
                                         scale=_rms(a))[:, 0]
    if noise.force_offset or noise.force_drift:
        n = F.shape[1]
        ramp = np.arange(n) / max(n - 1, 1)
        for i in measured_f:
            peak = float(np.max(np.abs(F[i])))
            arrays["F"][i] += peak * (noise.force_offset + noise.force_drift * ramp)
    return Response(t=response.t, dt=response.dt, structure=getattr(response, "structure", ""),
                    engine=getattr(response, "engine", ""), label=getattr(response, "label", ""),
                    **arrays)
