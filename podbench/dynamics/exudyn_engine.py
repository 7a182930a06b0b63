"""An independent cross-check: the same equations of motion solved by exudyn.

exudyn (https://github.com/jgerstmayr/EXUDYN) is a multibody code with its own implicit
integrator, Newton solver and linear algebra. podbench hands it the structure's matrices as one
``ObjectGenericODE2`` and asks for plain Newmark (β = 1/4, γ = 1/2) at fixed steps, so that its
result must agree with :func:`podbench.dynamics.newmark.newmark` to round-off / Newton
tolerance. Agreement tests the podbench integrator's bookkeeping (force timing, initial
acceleration, events, variable mass, Newton) against code written by someone else.

Mapping:

* ``NodeGenericODE2`` carries all DOFs; ``ObjectGenericODE2`` carries ``M``, ``K(0)``, ``C``
  (sparse ``MatrixContainer`` and the Eigen sparse solver above ``DENSE_MAX_DOFS``).
* Loads: ``forceUserFunction(t)`` (exudyn evaluates it at the end time of the step) returns
  ``f[:, round(t/dt)]``. A cubic spring's ``−g(q, q')`` is added there too, with the analytic
  ``jacobianUserFunction`` ``fODE2·∂g/∂q + fODE2_t·∂g/∂q'``.
* Variable mass: ``massMatrixUserFunction(t)`` returns ``M + m(t) e eᵀ``.
* Stiffness events: a pre-step user function (it receives the end time of the step about to be
  solved) sets the stiffness (and the mass, for an element that disappears) of sample
  ``round(t/dt)`` following the :class:`~podbench.fem.StiffnessEvent` convention, so the
  switch happens at exactly the same sample as in the podbench integrator (exudyn accumulates
  time, hence the rounding). DOFs an event removes are decoupled there (placeholder mass, no
  stiffness: :meth:`~podbench.fem.Structure.matrices_at`) and drift freely inside exudyn;
  they cannot act on the remaining DOFs, and their histories are set to zero from the event's
  sample on, as podbench's integrator holds them.
* Newton: a Jacobian is always supplied (zero for linear structures: exudyn adds K and C
  analytically), full Newton, no adaptive step. Nonlinear structures converge when the Newton
  increment is below 1e-12 (relative and absolute, exudyn's ``residualMode = 1``): a residual
  relative to the step's initial one stagnates above 1e-12 at round-off on a stiff beam at
  large deflection. Linear ones use the residual relative to each step's initial residual,
  1e-10, which the first iteration solves exactly anyway (a tighter goal iterates on
  round-off and fails on the truss).

Tested with exudyn 1.13.6.
Nothing is written to disk (no ``./solution/`` directory).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from podbench.dynamics.newmark import DENSE_MAX_DOFS
from podbench.errors import ConvergenceError, InputError
from podbench.structures.structure import Structure, VariableMass

__all__ = ["simulate_exudyn"]


def _import_exudyn():
    try:
        import exudyn
        import exudyn.itemInterface as items
    except ImportError as exc:  # pragma: no cover - exudyn is a declared dependency
        raise InputError(
            "engine='exudyn' requires the exudyn package (pip install exudyn); "
            f"importing it failed: {exc}"
        ) from exc
    return exudyn, items


def _matrix(exu, A: sp.csr_matrix, sparse: bool):
    """A sparse ``MatrixContainer`` or a dense ndarray (the Jacobian must use the same kind)."""
    if not sparse:
        return A.toarray()
    mc = exu.MatrixContainer()
    mc.SetWithSparseMatrix(sp.csr_matrix(A))
    return mc


def simulate_exudyn(
    structure: Structure,
    q0: np.ndarray,
    v0: np.ndarray,
    f: np.ndarray,
    dt: float,
    *,
    newton_rtol: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray]:
    """Integrate the structure with exudyn's Newmark (β = 1/4, γ = 1/2), fixed step ``dt``.

    Parameters
    ----------
    structure : Structure
    q0, v0 : (n_dofs,) ndarray
        Initial displacement (in) and velocity (in/s).
    f : (n_dofs, n_samples) ndarray
        DOF loads (lbf) at ``t_j = j·dt``.
    dt : float
        Time step (s).
    newton_rtol : float
        exudyn's Newton tolerance for nonlinear structures (on the Newton increment,
        relative and absolute in the DOF units; linear structures use 1e-10 or looser on the
        residual).

    Returns
    -------
    q, qd : (n_dofs, n_samples) ndarray
        Displacement (in) and velocity (in/s) histories.
    """
    exu, items = _import_exudyn()
    s = structure
    n_dofs, n = f.shape
    h = float(dt)
    sparse = n_dofs > DENSE_MAX_DOFS
    state0 = tuple(i for i, ev in enumerate(s.events) if ev.first_sample(h) <= 0)
    K0, M, _ = s.matrices_at(state0)
    mass_events = any(ev.delta_M is not None or ev.removed_dofs for ev in s.events)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    node = mbs.AddNode(
        items.NodeGenericODE2(
            referenceCoordinates=[0.0] * n_dofs,
            initialCoordinates=list(map(float, q0)),
            initialCoordinates_t=list(map(float, v0)),
            numberOfODE2Coordinates=n_dofs,
        )
    )
    kwargs = {}
    if s.variable_mass is not None:
        kwargs["massMatrixUserFunction"] = _mass_user_function(s.variable_mass, M, n, h)
    obj = mbs.AddObject(
        items.ObjectGenericODE2(
            nodeNumbers=[node],
            massMatrix=_matrix(exu, M, sparse),
            stiffnessMatrix=_matrix(exu, K0, sparse),
            dampingMatrix=_matrix(exu, s.damping_matrix(), sparse),
            forceUserFunction=_force_user_function(s, f, h),
            jacobianUserFunction=_jacobian_user_function(s, n_dofs, sparse),
            visualization=items.VObjectGenericODE2(show=False),
            **kwargs,
        )
    )
    if s.events:
        mbs.SetPreStepUserFunction(_event_pre_step(exu, s, obj, n, h, sparse, mass_events))

    OT = exu.OutputVariableType
    sensors = [
        mbs.AddSensor(
            items.SensorNode(
                nodeNumber=node, outputVariableType=ot, storeInternal=True, writeToFile=False
            )
        )
        for ot in (OT.Coordinates, OT.Coordinates_t)
    ]
    mbs.Assemble()
    sim = _simulation_settings(exu, n, h, sparse=sparse,
                               newton_rtol=newton_rtol if s.nonlinear else max(newton_rtol, 1e-10),
                               constant_mass=s.variable_mass is None and not mass_events,
                               nonlinear=bool(s.nonlinear))
    try:
        mbs.SolveDynamic(sim)
    except Exception as exc:  # exudyn raises its own SolverError / ModelError types
        raise ConvergenceError(f"exudyn failed to integrate {s.name!r}: {exc}") from exc
    q, qd = (_sensor_history(mbs, sensor, s, n) for sensor in sensors)
    for ev in s.events:  # removed DOFs: zero from the event's sample on (see the module doc)
        if ev.removed_dofs:
            rows = np.asarray(ev.removed_dofs)
            for hist in (q, qd):
                hist[rows, ev.first_sample(h):] = 0.0
    return q, qd


def _sample_index(t: float, h: float, n: int) -> int:
    """The sample ``round(t/h)`` (clipped to the record) at exudyn's accumulated time ``t``."""
    return min(max(int(round(t / h)), 0), n - 1)


def _force_user_function(s: Structure, f: np.ndarray, h: float):
    """``forceUserFunction``: the DOF load ``f[:, round(t/h)]`` minus the restoring forces
    ``g(q, q')`` of the nonlinear elements."""
    n = f.shape[1]
    nonlinear = s.nonlinear
    el_dofs = [np.asarray(el.dofs, dtype=np.int64) for el in nonlinear]

    def force_uf(mbs_, t, item, q, q_t):
        out = f[:, _sample_index(t, h, n)].copy()
        if nonlinear:
            q = np.asarray(q)
            q_t = np.asarray(q_t)
            for el, d in zip(nonlinear, el_dofs, strict=True):
                out[d] -= el.force(q[d], q_t[d])
        return out

    return force_uf


def _jacobian_user_function(s: Structure, n_dofs: int, sparse: bool):
    """``jacobianUserFunction``: ``fODE2·∂g/∂q + fODE2_t·∂g/∂q'`` of the nonlinear elements
    (zero for a linear structure: exudyn adds K and C itself)."""
    nonlinear = s.nonlinear
    if not nonlinear:
        zero_jac = sp.csr_matrix((n_dofs, n_dofs)) if sparse else np.zeros((n_dofs, n_dofs))

        def zero_jacobian_uf(mbs_, t, item, q, q_t, fODE2, fODE2_t):
            return zero_jac

        return zero_jacobian_uf
    el_dofs = [np.asarray(el.dofs, dtype=np.int64) for el in nonlinear]

    def jacobian_uf(mbs_, t, item, q, q_t, fODE2, fODE2_t):
        q = np.asarray(q)
        q_t = np.asarray(q_t)
        J = np.zeros((n_dofs, n_dofs))
        for el, d in zip(nonlinear, el_dofs, strict=True):
            ix = np.ix_(d, d)
            J[ix] += fODE2 * np.asarray(el.stiffness(q[d], q_t[d]))
            J[ix] += fODE2_t * np.asarray(el.damping(q[d], q_t[d]))
        return sp.csr_matrix(J) if sparse else J

    return jacobian_uf


def _mass_user_function(vm: VariableMass, M: sp.csr_matrix, n: int, h: float):
    """``massMatrixUserFunction``: ``M + m(t_j) e eᵀ`` at sample ``j = round(t/h)``."""
    Md = M.toarray()
    m_t = vm(np.arange(n) * h)

    def mass_uf(mbs_, t, item, q, q_t):
        Mt = Md.copy()
        Mt[vm.dof, vm.dof] += m_t[_sample_index(t, h, n)]
        return Mt

    return mass_uf


def _event_pre_step(exu, s: Structure, obj, n: int, h: float, sparse: bool, mass_events: bool):
    """Pre-step user function: at the sample ``round(t/h)`` of the step about to be solved,
    set the stiffness (and mass) of the events reached so far, when they changed."""
    first = [ev.first_sample(h) for ev in s.events]
    current = {"state": tuple(i for i, fj in enumerate(first) if 0 >= fj)}

    def pre_step(mbs_, t):
        j = _sample_index(t, h, n)
        state = tuple(i for i, fj in enumerate(first) if j >= fj)
        if state != current["state"]:
            K, Mt, _ = s.matrices_at(state)
            mbs_.SetObjectParameter(obj, "stiffnessMatrix", _matrix(exu, K, sparse))
            if mass_events:
                mbs_.SetObjectParameter(obj, "massMatrix", _matrix(exu, Mt, sparse))
            current["state"] = state
        return True

    return pre_step


def _simulation_settings(exu, n: int, h: float, *, sparse: bool, newton_rtol: float,
                         constant_mass: bool, nonlinear: bool = False):
    """Plain Newmark (β = 1/4, γ = 1/2), ``n − 1`` fixed steps of ``h``, full Newton with
    relative tolerance ``newton_rtol`` (on the residual; on the Newton increment for a
    ``nonlinear`` structure), sensors stored in memory at every step."""
    sim = exu.SimulationSettings()
    ti = sim.timeIntegration
    ti.numberOfSteps = n - 1
    ti.endTime = (n - 1) * h
    ti.generalizedAlpha.useNewmark = True
    ti.generalizedAlpha.newmarkBeta = 0.25
    ti.generalizedAlpha.newmarkGamma = 0.5
    ti.adaptiveStep = False
    ti.verboseMode = 0
    ti.newton.useModifiedNewton = False
    # exudyn's tolerance is relative to each step's initial residual. A linear step is solved
    # exactly by the first Newton iteration (residual ~1e-13 relative); a tighter goal would
    # only iterate on round-off noise (and fail on the truss), so linear structures use 1e-10.
    ti.newton.relativeTolerance = newton_rtol
    if nonlinear:
        # A residual relative to the step's initial residual has a round-off floor of about
        # eps·‖K‖·‖q‖ / ‖r0‖, which exceeds 1e-12 on a stiff beam pushed to a large tip
        # deflection (the NL beam under a 1.5-ms half-sine stagnates at 2e-12 for 25
        # iterations). Judging convergence by the Newton increment instead (exudyn's
        # residualMode 1, relative and absolute tolerances equal, as exudyn asks) has no such
        # floor: full Newton with the analytic Jacobian makes the increment fall
        # quadratically to round-off.
        ti.newton.residualMode = 1
        ti.newton.absoluteTolerance = newton_rtol
    if not constant_mass:
        ti.reuseConstantMassMatrix = False
    sim.solution.file.write = False
    sim.solution.sensors.writePeriod = h
    sim.show.computationTime = False
    sim.show.statistics = False
    if sparse:
        sim.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return sim


def _sensor_history(mbs, sensor, s: Structure, n: int) -> np.ndarray:
    """A sensor's stored data as an (n_dofs, n) history (the time column dropped)."""
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    if data.shape[0] != n:
        raise ConvergenceError(
            f"exudyn returned {data.shape[0]} samples for {s.name!r}, expected {n}"
        )
    return np.ascontiguousarray(data[:, 1:].T)
