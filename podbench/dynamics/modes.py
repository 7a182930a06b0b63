"""The finite-element modes of a structure at its sensors: the truth identified modes are
compared with.

* :func:`normal_modes`: the undamped normal modes ``K φ = ω² M φ``, mass-normalized
  (``φᵀ M φ = 1``), on the DOFs in the model at time ``t``;
* :func:`fe_modes`: the modes as a :class:`~podbench.core.modeshapes.ModeSet` at the
  sensors: with a damping matrix the complex modes (the eigenvalues ``s`` of the first-order
  form ``[[0, I], [−M⁻¹K, −M⁻¹C]]`` with ``Im s > 0``; an overdamped pair has no frequency
  and is left out, said in a note), without one the normal modes (``ζ = 0``);
  ``kind="normal"`` gives the normal modes with the classical modal damping ratio
  ``ζ = φᵀCφ / (2ω)`` (exact for proportional damping). ``dt`` gives the modes as podbench's
  average-acceleration Newmark samples them (below); ``band_hz`` keeps the modes whose
  frequency lies in the band the records excite;
* :func:`pom_normal_mac`: the MAC between proper orthogonal modes and the mass-normalized
  normal modes at the sensors (dissertation §2.1: "If the system is linear and lightly damped
  with a mass matrix proportional to the identity matrix then the POMs will be equal to the
  linear normal modes"; where ``M`` is not, this MAC measures how far they are apart — the
  dissertation's own explanation of the diagonalization error, §3.6).

**Time-varying and nonlinear structures**: the linear part at ``t`` (default 0): ``M(t)``,
``K(t)``, the DOFs still in the model, and for nonlinear elements the linear twin
(:meth:`~podbench.structures.Structure.linear_twin`: a cubic spring has no linear part, a
one-sided spring leaves its linear stiffness); the mode set says so in its notes.

**Sampling by Newmark** (``dt``): the average-acceleration rule is the trapezoidal rule on
the first-order form, so a record simulated at ``Δt`` holds the poles
``z = (1 + sΔt/2)/(1 − sΔt/2)`` (same shapes) and an exact identification from it finds
``s' = ln z / Δt``, whose frequency is lower by about ``(π f Δt)²/3`` (period elongation:
4.4 % at 23.5 Hz and 200 Hz, 0.1 % at ``f Δt = 0.0175``). ``fe_modes(..., dt=Δt)`` returns
these ``s'``: the modes of the records, against which an identification method is judged;
without ``dt`` the continuous modes of the model.

Units: frequencies Hz (poles rad/s), shapes in the sensors' units (in or rad), any scale.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
import scipy.linalg

from podbench.core.modeshapes import ModeSet, mac
from podbench.errors import InputError
from podbench.structures.structure import Structure

__all__ = ["normal_modes", "fe_modes", "pom_normal_mac", "newmark_poles",
           "DENSE_MODES_MAX_DOFS"]

DENSE_MODES_MAX_DOFS = 4000
"""Largest model (DOFs in the model) whose modes are computed by a dense eigensolver."""

_KINDS = ("auto", "complex", "normal")


def _linear_part(structure: Structure, t: float):
    """``(M, K, C, keep, notes)``: dense matrices of the linear part at ``t`` on the DOFs
    still in the model (``keep``)."""
    if not isinstance(structure, Structure):
        raise InputError(f"Parameter `structure`: expected a podbench Structure, got "
                         f"{type(structure).__name__}")
    notes = []
    lin = structure
    if not structure.is_linear:
        lin = structure.linear_twin()
        notes.append("nonlinear structure: the modes of its linear part (linear twin: the "
                     "nonlinear elements' linear stiffness only)")
    if not structure.is_time_invariant:
        notes.append(f"time-varying structure: the modes of M(t), K(t) at t = {t:g} s")
    keep = np.setdiff1d(np.arange(lin.n_dofs), lin.removed_dofs(t))
    if keep.size > DENSE_MODES_MAX_DOFS:
        raise InputError(f"{structure.name}: {keep.size} DOFs, the dense modal solution "
                         f"handles at most {DENSE_MODES_MAX_DOFS}")
    ix = np.ix_(keep, keep)
    M = lin.mass(t).toarray()[ix]
    K = lin.stiffness(t).toarray()[ix]
    C = None if lin.C is None else lin.C.toarray()[ix]
    return M, K, C, keep, notes


def normal_modes(structure: Structure, *, t: float = 0.0):
    """Undamped normal modes of the linear part at ``t``.

    Returns
    -------
    omega : (n,) ndarray
        Natural circular frequencies (rad/s), ascending (rigid-body modes: 0).
    Phi : (n_dofs, n) ndarray
        Mass-normalized mode shapes (``φᵀ M φ = 1``) on all DOFs (zero on DOFs removed at
        ``t``).
    """
    M, K, _, keep, _ = _linear_part(structure, t)
    w2, V = scipy.linalg.eigh(K, M)
    Phi = np.zeros((structure.n_dofs, keep.size))
    Phi[keep] = V
    return np.sqrt(np.clip(w2, 0.0, None)), Phi


def newmark_poles(poles, dt: float) -> np.ndarray:
    """The continuous-time poles ``s' = ln z / Δt`` that records of podbench's
    average-acceleration Newmark at ``dt`` hold for the poles ``s`` (rad/s):
    ``z = (1 + sΔt/2)/(1 − sΔt/2)`` (module docstring)."""
    s = np.asarray(poles, dtype=complex)
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"Parameter `dt`: expected a positive interval (s), got {dt!r}")
    z = (1.0 + 0.5 * dt * s) / (1.0 - 0.5 * dt * s)
    return np.log(z) / dt


def _complex_modes(M, K, C):
    """Poles with ``Im s > 0`` and their displacement shapes (DOFs × modes) of
    ``M q'' + C q' + K q = 0``; the number of overdamped (real) poles."""
    n = M.shape[0]
    Minv_K = np.linalg.solve(M, K)
    Minv_C = np.linalg.solve(M, C)
    Ac = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv_K, -Minv_C]])
    lam, V = scipy.linalg.eig(Ac)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    up = lam.imag > 1e-12 * scale
    real = int(np.sum(np.abs(lam.imag) <= 1e-12 * scale))
    return lam[up], V[:n, up], real


def _channels(structure: Structure, channels) -> tuple[str, ...]:
    if channels is not None:
        names = tuple(str(c) for c in channels)
        if len(names) != structure.n_sensors:
            raise InputError(f"Parameter `channels`: {len(names)} names for "
                             f"{structure.n_sensors} sensors")
        return names
    return tuple(str(i) for i in range(structure.n_sensors))


def fe_modes(structure: Structure, *, t: float = 0.0, kind: str = "auto",
             band_hz: tuple[float, float] | None = None, dt: float | None = None,
             channels: Sequence[str] | None = None) -> ModeSet:
    """The finite-element modes at the sensors (module docstring).

    Parameters
    ----------
    structure : Structure
    t : float
        Time (s) of the linear part (time-varying and nonlinear structures).
    kind : {"auto", "complex", "normal"}
        ``"complex"``: the damped modes of ``M, C, K`` (``C`` zero if the structure has
        none); ``"normal"``: the undamped normal modes with the modal damping ratio
        ``φᵀCφ/(2ω)``; ``"auto"`` (default): complex with a damping matrix, else normal.
    band_hz : (low, high), optional
        Keep the modes whose frequency lies in ``[low, high]`` Hz.
    dt : float, optional
        The modes as records of podbench's Newmark at ``dt`` (s) hold them
        (:func:`newmark_poles`).
    channels : sequence of str, optional
        Channel names of the sensors (default ``"0"``, ``"1"``, …, the names of
        :class:`~podbench.core.records.Record`).

    Returns
    -------
    ModeSet
        Sorted by frequency; rigid-body modes (zero frequency) are left out.
    """
    if kind not in _KINDS:
        raise InputError(f"Parameter `kind`: expected one of {', '.join(_KINDS)}, got {kind!r}")
    M, K, C, keep, notes = _linear_part(structure, t)
    S = structure.sensor_matrix().toarray()[:, keep]
    if kind == "complex" or (kind == "auto" and C is not None):
        lam, V, n_real = _complex_modes(M, K, C if C is not None else np.zeros_like(M))
        source = "finite-element model, complex modes (M, C, K)"
        if n_real:
            notes.append(f"{n_real} real (overdamped or rigid-body) poles have no frequency "
                         "and are left out")
    else:
        w2, V = scipy.linalg.eigh(K, M)
        w = np.sqrt(np.clip(w2, 0.0, None))
        zeta = np.zeros_like(w)
        if C is not None:
            zeta = np.einsum("ij,ik,kj->j", V, C, V) / np.where(w > 0, 2.0 * w, 1.0)
        lam = -zeta * w + 1j * w * np.sqrt(np.clip(1.0 - zeta**2, 0.0, None))
        source = ("finite-element model, normal modes" +
                  (" with modal damping φᵀCφ/(2ω)" if C is not None else " (undamped)"))
        keep_w = w > 0
        lam, V = lam[keep_w], V[:, keep_w]
    if dt is not None:
        lam = newmark_poles(lam, dt)
        notes.append(f"as records of podbench's average-acceleration Newmark at dt = {dt:g} s "
                     "hold them (s' = ln z / dt, z = (1 + s dt/2)/(1 − s dt/2))")
    modes = ModeSet(lam, S @ V, _channels(structure, channels), source, tuple(notes))
    if band_hz is not None:
        lo, hi = (float(b) for b in band_hz)
        f = modes.frequency_hz
        modes = modes.subset((f >= lo) & (f <= hi)).with_notes(
            f"modes in the band {lo:g}-{hi:g} Hz")
    return modes


def pom_normal_mac(structure: Structure, poms, *, t: float = 0.0) -> pd.DataFrame:
    """The MAC between proper orthogonal modes and the mass-normalized normal modes at the
    sensors (module docstring): one row per POM, ``pom`` (1, 2, …), ``mode`` (the normal
    mode of highest MAC, 1 = lowest frequency), ``frequency_hz`` (its natural frequency) and
    ``mac``. The POMs coincide with normal modes (MAC 1) when ``M ∝ I`` and the damping is
    light; their distance from 1 is the basis' share of the diagonalization error.

    Parameters
    ----------
    structure : Structure
    poms : (n_sensors, k) array_like
        POMs at the sensors (e.g. a fitted method's ``modes_``).
    """
    U = np.asarray(poms, dtype=float)
    if U.ndim != 2 or U.shape[0] != structure.n_sensors:
        raise InputError(f"Parameter `poms`: expected shape ({structure.n_sensors}, k) (one "
                         f"row per sensor), got {U.shape}")
    omega, Phi = normal_modes(structure, t=t)
    flexible = omega > 0
    at_sensors = structure.observe(Phi[:, flexible])
    m = mac(U, at_sensors)
    best = np.argmax(m, axis=1)
    freq = omega[flexible] / (2.0 * np.pi)
    return pd.DataFrame({"pom": np.arange(1, U.shape[1] + 1), "mode": best + 1,
                         "frequency_hz": freq[best], "mac": m[np.arange(U.shape[1]), best]})
