"""The modal comparison of a study: each fit's identified modes against the finite-element
modes of the simulated structure (``modal.csv``), and the POMs against the normal modes
(``pom_modes.csv``).

* **truth**: :func:`podbench.dynamics.modes.fe_modes` at ``t = 0`` as podbench's Newmark at
  the scenario's ``dt`` samples them (the modes the records hold: the comparison judges the
  identification, not the integrator); for a time-varying structure the linear part at
  ``t = 0``, for a nonlinear one its linear twin, marked in the ``truth`` column;
* **band**: the modes the training records excite, the finite-element modes of frequency at
  most the frequency below which :data:`BAND_ENERGY` of the training responses' energy lies
  (their periodogram, summed over the sensors and the records) and below Nyquist;
* **identified**: the fit realized (:func:`podbench.sysid.realize.to_statespace`) and its
  physical modes (:func:`podbench.sysid.realize.StateSpaceModel.modes`: hard criteria and
  stabilization at orders ``N + 2``, ``N + 4``). A kernel or free-decay method is realized
  at the numerical rank of its Hankel matrix (``order="rank"``, the largest order the lag
  rule of ``podbench fit`` considers): one realization, where the lag rule's one per
  candidate order would cost more than the study's own fits. ERA and the other
  state-space methods keep their own order. A fit on exponentially
  windowed records (``τ``) identifies ``s − 1/τ``, corrected here by ``+1/τ``;
* **matching**: by MAC, not by index, MAC ties broken by frequency
  (:func:`podbench.sysid.modal.match_modes`); one row per
  band mode, its identified partner's frequency, damping ratio, the frequency error (%),
  the damping error (absolute, the damping ratio's difference) and the MAC; a band mode
  without a partner reads ``unmatched``, a method without a state-space form one row with
  the reason.

Digits (:data:`DIGITS`): frequencies to five significant digits, damping ratios to three,
errors to two (and round-off written as 0: :data:`ERROR_DECIMALS`, damping ratios within
:data:`~podbench.sysid.modal.ZETA_ROUNDOFF` of 0), MAC to four decimals: the eigenvalues of
a realization move between CPUs in their last digits, far below these.
"""

from __future__ import annotations

import numpy as np

from podbench.core.modeshapes import ModeSet
from podbench.dynamics.modes import fe_modes, pom_normal_mac
from podbench.errors import PodbenchError
from podbench.sysid.conditioning import WindowCorrected
from podbench.sysid.modal import ZETA_ROUNDOFF, match_modes
from podbench.sysid.realize import to_statespace

__all__ = ["MODAL_COLUMNS", "POM_COLUMNS", "BAND_ENERGY", "DIGITS", "excited_band",
           "modal_rows", "pom_rows"]

BAND_ENERGY = 0.999
"""Share of the training responses' energy below the top of the excited band."""

MODAL_COLUMNS = ("scenario", "structure", "method", "mode", "frequency_hz", "damping_ratio",
                 "identified_frequency_hz", "identified_damping_ratio",
                 "frequency_error_pct", "damping_error", "mac", "truth", "status")
"""Columns of ``modal.csv``: the finite-element mode (``mode`` numbered by frequency in the
band, ``frequency_hz`` in Hz, ``damping_ratio`` a fraction of critical), its identified
partner, ``frequency_error_pct`` = 100 (f_id − f)/f, ``damping_error`` = ζ_id − ζ (fraction
of critical), ``mac`` (0–1)."""

POM_COLUMNS = ("scenario", "structure", "method", "pom", "mode", "frequency_hz", "mac")
"""Columns of ``pom_modes.csv`` (:func:`podbench.dynamics.modes.pom_normal_mac`)."""

DIGITS = {"frequency_hz": 5, "identified_frequency_hz": 5, "damping_ratio": 3,
          "identified_damping_ratio": 3, "frequency_error_pct": 2, "damping_error": 2}
"""Significant digits written per column (module docstring); ``mac``: four decimals."""

ERROR_DECIMALS = {"frequency_error_pct": 4, "damping_error": 6}
"""Decimals at most of the errors: a frequency error below 0.0001 % (a relative 1e-6) or a
damping error below 1e-6 is the eigensolver's round-off on exact records (``−4e-8 %`` on
Chapter 4's clean beam), whose digits differ between CPUs; written as 0."""




def _sig(v, digits: int) -> float:
    v = float(v)
    return float(f"{v:.{digits}g}") + 0.0 if np.isfinite(v) else v


def _written(m, k: str, digits: int) -> float:
    v = float(m[k])
    if k in ("damping_ratio", "identified_damping_ratio") and abs(v) < ZETA_ROUNDOFF:
        v = 0.0  # an undamped mode's ±1e-17 (FE) or ±1e-9 (identified): round-off
    if k in ERROR_DECIMALS and np.isfinite(v):
        v = round(v, ERROR_DECIMALS[k])
    return _sig(v, digits)


def excited_band(records, dt: float) -> float:
    """The top (Hz) of the band the training ``records`` excite: the frequency below which
    :data:`BAND_ENERGY` of their responses' energy lies (module docstring)."""
    arrays = [np.asarray(r.W if getattr(r, "W", None) is not None else r.y, dtype=float)
              for r in records]
    if not arrays:
        return 0.5 / dt
    n = max(a.shape[1] for a in arrays)  # one frequency grid: every record padded to n
    power = sum(np.sum(np.abs(np.fft.rfft(a, n=n, axis=1)) ** 2, axis=0) for a in arrays)
    if not np.any(power > 0):
        return 0.5 / dt
    cum = np.cumsum(power) / np.sum(power)
    f = np.fft.rfftfreq(n, dt)
    return float(f[min(int(np.searchsorted(cum, BAND_ENERGY)), f.size - 1)])


def _truth_label(structure) -> str:
    if not structure.is_linear:
        return "linear twin (nonlinear structure)"
    if not structure.is_time_invariant:
        return "linear part at t = 0 s (time-varying structure)"
    return "finite-element modes"


def _identified(est) -> ModeSet:
    """The physical modes of a fit (a windowed fit's poles moved back by ``+1/τ``)."""
    inner, shift = est, 0.0
    if isinstance(est, WindowCorrected):
        inner, shift = est.method, 1.0 / est.tau
    order = "rank" if hasattr(inner, "kernel_") or hasattr(inner, "Phi_") else None
    modes = to_statespace(inner, order=order).modes()
    if shift:
        modes = ModeSet(modes.poles + shift, modes.shapes, modes.channels, modes.source,
                        modes.notes, modes.stable)
    return modes


def modal_rows(est, structure, base: dict, records, dt: float, *,
               reference: dict | None = None) -> list[dict]:
    """The rows of ``modal.csv`` for one fit ``est`` (``base``: scenario, structure,
    method) trained on ``records`` sampled at ``dt`` (s). ``reference``: a dict kept by
    the caller across the fits of one structure, in which the finite-element modes are
    computed once."""
    top = excited_band(records, dt)
    truth = _truth_label(structure)
    reference = {} if reference is None else reference
    try:
        if dt not in reference:
            reference[dt] = fe_modes(structure, dt=dt)
        every = reference[dt]
        fe = every.subset(every.frequency_hz <= top).with_notes(
            f"modes in the band 0-{top:g} Hz")
        ident = _identified(est)
    except PodbenchError as exc:
        return [{**base, "mode": 0, "truth": truth,
                 "status": "no modes: " + " ".join(str(exc).split())}]
    ident = ModeSet(ident.poles, ident.shapes, fe.channels, ident.source, ident.notes,
                    ident.stable) if len(ident.channels) == len(fe.channels) else ident
    if ident.channels != fe.channels:
        return [{**base, "mode": 0, "truth": truth,
                 "status": f"no modes: the model's {len(ident.channels)} outputs are not the "
                           f"structure's {len(fe.channels)} sensors"}]
    table = match_modes(ident, fe)
    rows = []
    for _, m in table.iterrows():
        row = {**base, "mode": int(m["mode"]), "truth": truth,
               **{k: _written(m, k, d) for k, d in DIGITS.items()},
               "mac": round(float(m["mac"]), 4) if np.isfinite(m["mac"]) else np.nan,
               "status": "ok" if np.isfinite(m["identified"]) else "unmatched"}
        rows.append(row)
    return rows


def pom_rows(est, structure, base: dict) -> list[dict]:
    """The rows of ``pom_modes.csv`` for one fit: each POM's MAC with its closest
    mass-normalized normal mode at the sensors."""
    U = getattr(est, "modes_", None)
    if U is None:
        return []
    try:
        table = pom_normal_mac(structure, np.asarray(U, dtype=float))
    except PodbenchError:
        return []
    return [{**base, "pom": int(r["pom"]), "mode": int(r["mode"]),
             "frequency_hz": _sig(r["frequency_hz"], 5), "mac": round(float(r["mac"]), 4)}
            for _, r in table.iterrows()]
