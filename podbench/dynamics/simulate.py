"""``simulate``: one entry point for every engine, returning a :class:`podbench.data.Response`."""

from __future__ import annotations

import numpy as np

from podbench.core.hints import did_you_mean
from podbench.core.response import Response
from podbench.core.validation import as_finite_array, check_positive
from podbench.dynamics.exudyn_engine import simulate_exudyn
from podbench.dynamics.newmark import newmark
from podbench.errors import DimensionError, InputError, UnknownNameError
from podbench.structures.structure import Structure

__all__ = ["simulate", "ENGINES", "DOF_HISTORY_LIMIT"]

ENGINES = ("newmark", "exudyn")
"""Names accepted by ``simulate(engine=...)``."""

DOF_HISTORY_LIMIT = 5_000_000
"""``simulate(dof_histories=None)`` keeps the full DOF histories ``q``, ``qd`` when
``n_dofs × n_samples`` is at most this (40 MB per history), otherwise only the sensor
readings (memory O(nnz + n_sensors · n_samples))."""


def _dof_vector(x, structure: Structure, name: str) -> np.ndarray:
    """An initial DOF vector from None (zeros), an array or an object with ``dof_vector``."""
    n = structure.n_dofs
    if x is None:
        return np.zeros(n)
    if hasattr(x, "dof_vector"):
        x = x.dof_vector(structure)
    arr = as_finite_array(x, name)
    if arr.shape != (n,):
        raise DimensionError(
            f"Parameter `{name}`: expected a full DOF vector of shape ({n},) for structure "
            f"{structure.name!r}, got shape {arr.shape}"
        )
    return arr


def _force_history(force, structure: Structure, n_samples: int, dt: float) -> np.ndarray:
    """The (n_sensors, n_samples) force matrix from None, an array or an excitation object."""
    shape = (structure.n_sensors, n_samples)
    if force is None:
        return np.zeros(shape)
    if hasattr(force, "sample"):
        force = force.sample(structure, n_samples, dt)
    F = as_finite_array(force, "force", ndim=2)
    if F.shape != shape:
        raise DimensionError(
            f"Parameter `force`: expected shape {shape} (n_sensors, n_samples), got {F.shape}"
        )
    return F


def _run_engine(engine: str, structure: Structure, q0: np.ndarray, v0: np.ndarray,
                F: np.ndarray, dt: float, dof_histories: bool,
                ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``(W, q, qd)``: the sensor readings and, with ``dof_histories``, the DOF histories.

    ``"newmark"`` loads the sensors' DOFs through ``Sᵀ`` one sample at a time and, without
    DOF histories, records only ``W = S q``; ``"exudyn"`` takes the full DOF load array.
    """
    if engine == "newmark":
        S = structure.sensor_matrix()
        res = newmark(structure, q0, v0, F, dt, force_map=S.T,
                      record=None if dof_histories else S)
        if dof_histories:
            return structure.observe(res.q), res.q, res.v
        return res.q, None, None
    q, qd = simulate_exudyn(structure, q0, v0, structure.to_dofs(F), dt)
    W = structure.observe(q)
    if not dof_histories:
        return W, None, None
    return W, q, qd


def simulate(
    structure: Structure,
    n_samples: int = 500,
    dt: float = 1e-4,
    initial_displacement=None,
    initial_velocity=None,
    force=None,
    engine: str = "newmark",
    label: str = "",
    dof_histories: bool | None = None,
) -> Response:
    """Simulate the response of ``structure`` and sample it at its sensors.

    Solves ``M(t) q'' + C q' + K(t) q + g(q, q') = Sᵀ f(t)`` (see :mod:`podbench.fem.structure`)
    from ``q(0) = q0``, ``q'(0) = v0`` at ``t_j = j·dt``, ``j = 0 … n_samples − 1``, with
    average-acceleration Newmark (β = 1/4, γ = 1/2). Units: inch, lbf, second.

    Parameters
    ----------
    structure : Structure
        The structure to simulate.
    n_samples : int
        Number of samples ``n`` (≥ 2), including the initial state at ``t = 0``.
    dt : float
        Time step (s), > 0.
    initial_displacement, initial_velocity : (n_dofs,) array_like or None
        Full DOF vectors ``q0`` (in, rad) and ``v0`` (in/s, rad/s): the beams have
        unmeasured rotations, so sensor vectors are not enough. ``None`` means zeros. An
        object with a ``dof_vector(structure)`` method (see :mod:`podbench.excitations`) is
        also accepted.
    force : (n_sensors, n_samples) array_like, excitation object or None
        Load sampled at the sensors (lbf), acting on the sensors' DOFs (``structure.to_dofs``).
        An object with a ``sample(structure, n_samples, dt)`` method (e.g.
        :class:`podbench.excitations.Pulse`) is sampled first. ``F[:, j]`` acts in the
        equilibrium at ``t_j``; ``F[:, 0]`` only through the initial acceleration.
    engine : {"newmark", "exudyn"}
        ``"newmark"``: podbench's integrator (:func:`podbench.dynamics.newmark.newmark`).
        ``"exudyn"``: the same scheme solved by the exudyn multibody code, an independent
        cross-check (requires the ``exudyn`` package).
    label : str
        Stored in the response (e.g. the excitation's name).
    dof_histories : bool or None
        ``True``: the response also holds the full DOF histories ``q``, ``qd``
        (2 · n_dofs · n floats). ``False``: only the sensor readings are recorded while
        integrating (``W = S q`` at every step, see ``record`` of
        :func:`~podbench.dynamics.newmark.newmark`), ``q`` and ``qd`` are None, and memory
        is O(nnz + n_sensors · n) — for large structures (e.g. 100,000 DOFs × 2,000
        samples, where the DOF histories alone would take 3.2 GB). ``None`` (default):
        ``True`` when ``n_dofs · n ≤ DOF_HISTORY_LIMIT`` (5e6), else ``False``. ``W`` is the
        same either way. With ``engine="newmark"`` the force is applied one sample at a
        time through the sparse sensor-to-DOF map (no n_dofs × n load array); the exudyn
        engine (a cross-check for small structures) takes the full DOF load array.

    Returns
    -------
    Response
        ``t`` (n,), ``W = S q`` and ``F`` (n_sensors, n), ``w0 = S q0``, ``v0 = S v0``,
        ``q`` and ``qd`` (n_dofs, n) or None (see ``dof_histories``), the structure's name,
        the engine and the label.

    Raises
    ------
    InputError
        NaN/Inf, ``n_samples < 2``, ``dt <= 0``, a non-Structure.
    DimensionError
        Arrays of the wrong shape (the message gives the expected and received shapes).
    UnknownNameError
        An unknown engine.
    ConvergenceError
        Newton iterations failed (nonlinear structures).
    """
    if not isinstance(structure, Structure):
        raise InputError(
            f"Parameter `structure`: expected a podbench Structure, got {type(structure).__name__}"
        )
    if not isinstance(engine, str) or engine not in ENGINES:
        raise UnknownNameError(
            f"Parameter `engine`: unknown engine {engine!r}{did_you_mean(engine, ENGINES)} "
            f"(known engines: {', '.join(ENGINES)})"
        )
    n_samples = check_positive(n_samples, "n_samples", integer=True)
    if n_samples < 2:
        raise InputError(f"Parameter `n_samples`: must be at least 2, got {n_samples}")
    dt = check_positive(dt, "dt")
    if dof_histories is None:
        dof_histories = structure.n_dofs * n_samples <= DOF_HISTORY_LIMIT
    elif not isinstance(dof_histories, (bool, np.bool_)):
        raise InputError(
            f"Parameter `dof_histories`: expected True, False or None, got {dof_histories!r}"
        )
    q0 = _dof_vector(initial_displacement, structure, "initial_displacement")
    v0 = _dof_vector(initial_velocity, structure, "initial_velocity")
    F = _force_history(force, structure, n_samples, dt)

    W, q, qd = _run_engine(engine, structure, q0, v0, F, dt, bool(dof_histories))
    return Response(
        t=np.arange(n_samples) * dt,
        W=W,
        F=F,
        w0=structure.observe(q0),
        v0=structure.observe(v0),
        dt=dt,
        q=q,
        qd=qd,
        structure=structure.name,
        engine=engine,
        label=label,
    )
