"""The :class:`Structure`: linear matrices plus what makes a structure time-varying or nonlinear.

A structure is everything the integrators need and nothing about identification methods:

``M(t) q'' + C q' + K(t) q + g(q, q') = T f(t)``,

with

* ``M(t) = M + m(t) e eᵀ`` when a :class:`VariableMass` is present (a point mass on one DOF
  that moves with that DOF, so no ``ṁ q'`` term: see ``structures/ltv_beam.toml``);
* ``K(t) = K + Σ ΔK_i`` and ``M(t) = M + Σ ΔM_i`` over the :class:`StiffnessEvent` s whose
  time has been reached (element fracture removes the element's stiffness and, when the
  element disappears, its mass; coordinates that only the element connected leave the
  model, see :meth:`Structure.matrices_at`);
* ``g`` the sum of the :class:`NonlinearElement` s' restoring forces (cubic springs, the
  one-sided rubber band of §5.2);
* ``T`` the sensor-to-DOF injection: forces are sampled at the sensors (the dissertation's
  force matrix ``F`` of Eq. 3.37 lives on the same points as the snapshot matrix ``W``).

Units are inch, lbf, second throughout: masses in lbf·s²/in, stiffnesses in lbf/in, rotational
DOFs in radians (so rotational mass and stiffness terms carry in² factors).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from podbench.errors import DimensionError, InputError

__all__ = [
    "Structure",
    "VariableMass",
    "StiffnessEvent",
    "NonlinearElement",
    "CubicSpring",
    "OneSidedSpring",
    "TWIN_RULES",
]


@dataclass(frozen=True)
class VariableMass:
    """A point mass ``m(t)`` (lbf·s²/in) on DOF ``dof`` that moves with that DOF.

    ``law`` maps an array of times (s) to masses; ``description`` states it in words.
    """

    dof: int
    law: Callable[[np.ndarray], np.ndarray]
    description: str = ""

    def __call__(self, t) -> np.ndarray:
        return np.asarray(self.law(np.asarray(t, dtype=float)), dtype=float)


@dataclass(frozen=True)
class StiffnessEvent:
    """From time ``time`` (s) on, the matrices are ``K + delta_K`` and ``M + delta_M``.

    An element breaks: ``delta_K`` removes its stiffness; ``delta_M`` (optional) its mass,
    when the element disappears; ``removed_dofs`` (optional) are the DOFs that only the
    element connected. They leave the model at the event: from then on their displacement,
    velocity and acceleration are zero, their sensors read 0, and they carry no stiffness or
    mass coupling (the integrators give each a decoupled placeholder mass, its mass before the
    event, so that the matrices they factorize stay regular; see
    :meth:`Structure.matrices_at`).

    Timing convention (shared by every engine): the event takes effect at the first sample
    ``t_j = j·dt`` with ``t_j >= time - dt/2``; the equilibrium at that sample already uses
    the changed matrices. Displacements and velocities of the remaining DOFs are continuous
    across the event (the broken element takes its own momentum with it).
    """

    time: float
    delta_K: sp.csr_matrix
    description: str = ""
    delta_M: sp.csr_matrix | None = None
    removed_dofs: tuple[int, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "removed_dofs",
                           tuple(sorted({int(d) for d in self.removed_dofs})))

    def first_sample(self, dt: float) -> int:
        """Index ``j`` of the first sample at which the event is in effect."""
        return max(0, int(np.ceil(self.time / dt - 0.5)))


@runtime_checkable
class NonlinearElement(Protocol):
    """A restoring force ``g(q, q')`` acting on a few DOFs (``dofs``, global indices).

    ``force`` returns the internal force on those DOFs (it is added to ``K q`` on the left
    side of the equation of motion), ``stiffness`` and ``damping`` its derivatives with
    respect to the local displacements and velocities (square, ``len(dofs)``).
    """

    dofs: np.ndarray

    def force(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...

    def stiffness(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...

    def damping(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class CubicSpring:
    """A grounded cubic spring on one DOF: ``g = k3 q³`` (k3 in lbf/in³)."""

    dof: int
    k3: float

    @property
    def dofs(self) -> np.ndarray:
        return np.array([self.dof])

    def force(self, q, v):
        return self.k3 * np.asarray(q) ** 3

    def stiffness(self, q, v):
        return np.array([[3.0 * self.k3 * float(q[0]) ** 2]])

    def damping(self, q, v):
        return np.zeros((1, 1))


TWIN_RULES = ("tangent", "free", "two_sided")
"""How :meth:`Structure.linear_twin` linearizes a :class:`OneSidedSpring` (see there)."""


@dataclass(frozen=True)
class OneSidedSpring:
    """A grounded spring on one DOF that pulls only when stretched: the rubber band of §5.2.

    §5.2: "a rubber band with stiffness of 0.12 lb/in was attached to the tip of the linear
    beam ... it provides linear stiffness when the beam tip deflects away from where the rubber
    band is attached ... but then provides zero stiffness when the beam tip deflects toward the
    rubber band attachment point (the rubber band buckles)". With ``q`` the DOF's
    displacement (in) from the static equilibrium, ``s = side`` (+1: the band is stretched
    when ``q`` grows, i.e. it is attached on the negative side; −1 the reverse) and
    ``δ = slack − prestretch`` (in), the band's stretch beyond its free length is
    ``s q − δ`` and the restoring force is

        ``g(q) = s k [ (s q − δ)₊ − (−δ)₊ ]``      (lbf; ``(x)₊ = max(x, 0)``)

    * ``slack = prestretch = 0`` (the text's words, the default): ``g = s k (s q)₊``, a
      bilinear spring that is *positively homogeneous*: ``g(λq) = λ g(q)`` for ``λ > 0``,
      so scaling a load from rest scales the whole response exactly.
    * ``slack > 0``: the band is loose by ``slack`` (in) at rest and engages only once
      ``s q > slack`` — linear (no band) at small amplitude, stiffer at large amplitude.
    * ``prestretch > 0``: the band is pre-stretched by ``prestretch`` (in) at rest (tension
      ``k·prestretch`` lbf, balanced by a static deflection of the beam that is not part of
      ``q``: ``q`` is measured from the preloaded equilibrium, so ``g(0) = 0``). It acts as
      a two-sided spring ``k`` while ``s q > −prestretch`` and goes slack beyond —
      stiffer at small amplitude, softer at large.

    ``twin`` chooses the linear twin's spring (:meth:`linear_stiffness`): ``"tangent"`` (the
    default) the tangent at rest, ``k·[δ < 0]`` (no band for slack ≥ 0, a two-sided ``k`` with
    pre-stretch); ``"free"`` never a band; ``"two_sided"`` always ``k``.

    The tangent at the kink (stretch exactly 0) is taken as 0 (the slack branch); Newton's
    method on this convex (``s = +1``) or concave (``s = −1``) piecewise-linear force
    converges in a finite number of steps (tested against the closed-form bilinear period).
    """

    dof: int
    k: float
    side: int = 1
    slack: float = 0.0
    prestretch: float = 0.0
    twin: str = "tangent"

    def __post_init__(self):
        if self.side not in (1, -1):
            raise InputError(f"Parameter `side`: expected +1 or -1, got {self.side!r}")
        for name in ("k", "slack", "prestretch"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise InputError(f"Parameter `{name}`: expected a finite number >= 0, got {v!r}")
        if self.slack > 0 and self.prestretch > 0:
            raise InputError("Parameters `slack` and `prestretch`: at most one may be non-zero "
                             f"(got slack = {self.slack!r}, prestretch = {self.prestretch!r})")
        if self.twin not in TWIN_RULES:
            raise InputError(f"Parameter `twin`: expected one of {', '.join(TWIN_RULES)}, "
                             f"got {self.twin!r}")

    @property
    def dofs(self) -> np.ndarray:
        return np.array([self.dof])

    @property
    def offset(self) -> float:
        """``δ = slack − prestretch`` (in): the stretch-free position of ``s q``."""
        return float(self.slack) - float(self.prestretch)

    def force(self, q, v):
        s, d = self.side, self.offset
        x = s * np.asarray(q, dtype=float) - d
        return s * self.k * (np.maximum(x, 0.0) - max(-d, 0.0))

    def stiffness(self, q, v):
        x = self.side * float(q[0]) - self.offset
        return np.array([[self.k if x > 0.0 else 0.0]])

    def damping(self, q, v):
        return np.zeros((1, 1))

    @cached_property
    def _constants(self) -> tuple[int, float, float, float]:
        """``(side, k, δ, (−δ)₊)`` of :meth:`scalar_terms`, evaluated once (not a field: repr,
        equality and ``dataclasses.replace`` see only the parameters)."""
        return self.side, self.k, self.offset, max(-self.offset, 0.0)

    def scalar_terms(self, q: float, v: float) -> tuple[float, float, float]:
        """``(g, dg/dq, dg/dv)`` at the floats ``q``, ``v``: the numbers of :meth:`force`,
        :meth:`stiffness`, :meth:`damping` without arrays (Newmark's one-DOF Newton loop)."""
        s, k, d, c = self._constants
        x = s * q - d
        g = s * k * (max(x, 0.0) - c)
        return g, (k if x > 0.0 else 0.0), 0.0

    def linear_stiffness(self) -> np.ndarray:
        """The (1, 1) stiffness (lbf/in) the linear twin puts on ``dof`` (see ``twin``)."""
        if self.twin == "two_sided" or (self.twin == "tangent" and self.offset < 0.0):
            return np.array([[float(self.k)]])
        return np.zeros((1, 1))


def _as_csr(A, name: str, n: int | None = None) -> sp.csr_matrix:
    A = sp.csr_matrix(A, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise DimensionError(f"Parameter `{name}`: must be square, got shape {A.shape}")
    if n is not None and A.shape != (n, n):
        raise DimensionError(f"Parameter `{name}`: expected shape {(n, n)}, got {A.shape}")
    if A.nnz and not np.all(np.isfinite(A.data)):
        raise InputError(f"Parameter `{name}`: contains NaN or Inf")
    return A


@dataclass(frozen=True, eq=False)
class Structure:
    """A discretized structure and its sensors (inch, lbf, second).

    Parameters
    ----------
    name : str
        Short name (the structure file's stem).
    M, K : (n_dofs, n_dofs) sparse or dense
        Constant mass (lbf·s²/in) and initial stiffness (lbf/in) matrices, boundary
        conditions already applied.
    C : (n_dofs, n_dofs) sparse or dense, optional
        Linear viscous damping (lbf·s/in); ``None`` for an undamped structure.
    sensor_dofs : (n_sensors,) int array
        DOF measured by each sensor; ``-1`` for a sensor on a constrained point (reads 0,
        e.g. the clamped root of the beams).
    variable_mass, events, nonlinear
        See the module docstring.
    sensor_positions : (n_sensors,) array, optional
        Position of each sensor along a 1-D structure (inches from the root).
    sensor_labels, dof_labels : tuple of str, optional
        Human-readable names.
    description : str
        One paragraph stating the model and its sources.
    source : str
        Path of the file the structure was built from ("" if built in code).
    metadata : dict
        Builder-specific extras (e.g. the linear tip stiffness of a beam).
    """

    name: str
    M: sp.csr_matrix
    K: sp.csr_matrix
    sensor_dofs: np.ndarray
    C: sp.csr_matrix | None = None
    variable_mass: VariableMass | None = None
    events: tuple[StiffnessEvent, ...] = ()
    nonlinear: tuple = ()
    sensor_positions: np.ndarray | None = None
    sensor_labels: tuple[str, ...] = ()
    dof_labels: tuple[str, ...] = ()
    description: str = ""
    source: str = ""
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        M = _as_csr(self.M, "M")
        n = M.shape[0]
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "K", _as_csr(self.K, "K", n))
        if self.C is not None:
            object.__setattr__(self, "C", _as_csr(self.C, "C", n))
        sd = np.asarray(self.sensor_dofs)
        if sd.ndim != 1 or sd.size == 0 or not np.issubdtype(sd.dtype, np.integer):
            raise DimensionError(
                f"Parameter `sensor_dofs`: expected a non-empty 1-D integer array, got {sd!r}"
            )
        if sd.min() < -1 or sd.max() >= n:
            raise DimensionError(
                f"Parameter `sensor_dofs`: indices must lie in [-1, {n - 1}], "
                f"got range [{sd.min()}, {sd.max()}]"
            )
        object.__setattr__(self, "sensor_dofs", sd.astype(np.int64))
        if self.sensor_positions is not None:
            sp_ = np.asarray(self.sensor_positions, dtype=float)
            if sp_.shape != sd.shape:
                raise DimensionError(
                    f"Parameter `sensor_positions`: expected shape {sd.shape}, got {sp_.shape}"
                )
            object.__setattr__(self, "sensor_positions", sp_)
        for ev in self.events:
            if ev.delta_K.shape != (n, n):
                raise DimensionError(
                    f"Stiffness event at t={ev.time}: delta_K has shape {ev.delta_K.shape}, "
                    f"expected {(n, n)}"
                )
            if ev.delta_M is not None and ev.delta_M.shape != (n, n):
                raise DimensionError(
                    f"Stiffness event at t={ev.time}: delta_M has shape {ev.delta_M.shape}, "
                    f"expected {(n, n)}"
                )
            if ev.removed_dofs and not 0 <= min(ev.removed_dofs) <= max(ev.removed_dofs) < n:
                raise DimensionError(
                    f"Stiffness event at t={ev.time}: removed_dofs must lie in [0, {n - 1}], "
                    f"got {list(ev.removed_dofs)}"
                )
        if self.variable_mass is not None and not 0 <= self.variable_mass.dof < n:
            raise DimensionError(f"Variable mass DOF {self.variable_mass.dof} outside [0, {n})")
        object.__setattr__(self, "events", tuple(sorted(self.events, key=lambda e: e.time)))
        object.__setattr__(self, "nonlinear", tuple(self.nonlinear))

    # ------------------------------------------------------------------ sizes and maps
    @property
    def n_dofs(self) -> int:
        return self.M.shape[0]

    @property
    def n_sensors(self) -> int:
        return self.sensor_dofs.size

    @property
    def is_linear(self) -> bool:
        return not self.nonlinear

    @property
    def is_time_invariant(self) -> bool:
        return self.variable_mass is None and not self.events

    def sensor_matrix(self) -> sp.csr_matrix:
        """``S`` (n_sensors × n_dofs) with ``W = S q``; a row of zeros for a constrained sensor."""
        rows = np.flatnonzero(self.sensor_dofs >= 0)
        cols = self.sensor_dofs[rows]
        return sp.csr_matrix(
            (np.ones(rows.size), (rows, cols)), shape=(self.n_sensors, self.n_dofs)
        )

    def observe(self, q: np.ndarray) -> np.ndarray:
        """Sensor readings ``S q`` of DOF vectors or histories (first axis = DOFs)."""
        q = np.asarray(q, dtype=float)
        out = np.zeros((self.n_sensors,) + q.shape[1:])
        ok = self.sensor_dofs >= 0
        out[ok] = q[self.sensor_dofs[ok]]
        return out

    def to_dofs(self, f: np.ndarray) -> np.ndarray:
        """DOF loads ``Sᵀ f`` from loads sampled at the sensors (first axis = sensors).

        A load on a constrained sensor (e.g. the clamped root) is taken by the support.
        """
        f = np.asarray(f, dtype=float)
        if f.shape[0] != self.n_sensors:
            raise DimensionError(
                f"Force: expected {self.n_sensors} rows (one per sensor), got shape {f.shape}"
            )
        out = np.zeros((self.n_dofs,) + f.shape[1:])
        ok = self.sensor_dofs >= 0
        np.add.at(out, self.sensor_dofs[ok], f[ok])
        return out

    # ------------------------------------------------------------------ time-dependent matrices
    def events_in_effect(self, t: float, dt: float | None = None) -> tuple[int, ...]:
        """Indices (into ``events``) of the events in effect at ``t``.

        With ``dt`` the timing convention of :class:`StiffnessEvent` is used (in effect from
        ``time - dt/2``), otherwise from ``time`` exactly.
        """
        return tuple(i for i, ev in enumerate(self.events)
                     if t >= ev.time - (0.5 * dt if dt else 0.0))

    def matrices_at(self, state: tuple[int, ...]) -> tuple[sp.csr_matrix, sp.csr_matrix,
                                                            np.ndarray]:
        """``(K, M, removed)`` with the events ``state`` (indices into ``events``) in effect.

        ``K = K0 + Σ ΔK``, ``M = M0 + Σ ΔM`` (the variable point mass is not included), and
        ``removed`` the sorted DOFs that have left the model. Their rows and columns of ``K``
        and ``M`` are zero except a placeholder ``M[d, d]`` equal to ``M0[d, d]`` (a decoupled
        coordinate the integrators hold at zero; it keeps ``M`` and the Newmark effective
        matrix regular without touching the remaining DOFs).
        """
        K, M = self.K, self.M
        removed: set[int] = set()
        for i in state:
            ev = self.events[i]
            K = K + ev.delta_K
            if ev.delta_M is not None:
                M = M + ev.delta_M
            removed.update(ev.removed_dofs)
        rem = np.array(sorted(removed), dtype=np.int64)
        if rem.size:
            keep = np.ones(self.n_dofs)
            keep[rem] = 0.0
            D = sp.diags(keep)
            placeholder = np.zeros(self.n_dofs)
            placeholder[rem] = self.M.diagonal()[rem]
            K = D @ K @ D
            M = D @ M @ D + sp.diags(placeholder)
        return sp.csr_matrix(K), sp.csr_matrix(M), rem

    def removed_dofs(self, t: float, dt: float | None = None) -> np.ndarray:
        """DOFs that have left the model at ``t`` (see :meth:`matrices_at`)."""
        return self.matrices_at(self.events_in_effect(t, dt))[2]

    def mass(self, t: float = 0.0, dt: float | None = None) -> sp.csr_matrix:
        """``M(t)``: the initial mass plus every event in effect at ``t`` (removed DOFs carry
        their placeholder mass, see :meth:`matrices_at`) plus the variable point mass."""
        M = self.matrices_at(self.events_in_effect(t, dt))[1] if self.events else self.M
        if self.variable_mass is None:
            return M
        d = self.variable_mass.dof
        m = float(self.variable_mass(np.array([t]))[0])
        return (M + sp.csr_matrix(([m], ([d], [d])), shape=self.M.shape)).tocsr()

    def stiffness(self, t: float = 0.0, dt: float | None = None) -> sp.csr_matrix:
        """``K(t)``: the initial stiffness plus every event already in effect at ``t``.

        With ``dt`` the event timing convention of :class:`StiffnessEvent` is used
        (in effect from ``time - dt/2``), otherwise from ``time`` exactly. Rows and columns
        of removed DOFs are zero.
        """
        if not self.events:
            return self.K
        return self.matrices_at(self.events_in_effect(t, dt))[0]

    def damping_matrix(self) -> sp.csr_matrix:
        """``C`` (a zero sparse matrix if the structure is undamped)."""
        return self.C if self.C is not None else sp.csr_matrix(self.M.shape)

    # ------------------------------------------------------------------ analysis
    def natural_frequencies(self, k: int = 5, t: float = 0.0) -> np.ndarray:
        """The ``k`` lowest undamped natural frequencies (Hz) of the linear part at time ``t``.

        Solves ``K(t) φ = ω² M(t) φ`` on the DOFs still in the model at ``t`` (removed DOFs,
        see :meth:`matrices_at`, are left out); nonlinear elements and damping are ignored.
        Rigid-body modes (after a fracture) appear as zero frequencies.
        """
        keep = np.setdiff1d(np.arange(self.n_dofs), self.removed_dofs(t))
        n = keep.size
        if not 1 <= k <= n:
            raise InputError(f"Parameter `k`: must lie in [1, {n}], got {k}")
        Kt = self.stiffness(t).toarray()[np.ix_(keep, keep)]
        Mt = self.mass(t).toarray()[np.ix_(keep, keep)]
        w2 = scipy.linalg.eigh(Kt, Mt, eigvals_only=True, subset_by_index=[0, k - 1])
        return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)

    def linear_twin(self) -> Structure:
        """The same structure with every nonlinear element removed (dampers kept).

        An element with a ``linear_stiffness()`` method (e.g. :class:`OneSidedSpring`) leaves
        that linear part in ``K`` (a cubic spring has none: its tangent at rest is zero).
        """
        if self.is_linear:
            return self
        K = self.K
        for el in self.nonlinear:
            lin = getattr(el, "linear_stiffness", None)
            if lin is None:
                continue
            kl = np.asarray(lin(), dtype=float)
            if np.any(kl):
                d = np.asarray(el.dofs, dtype=np.int64)
                r, c = np.meshgrid(d, d, indexing="ij")
                K = K + sp.csr_matrix((kl.ravel(), (r.ravel(), c.ravel())), shape=K.shape)
        return replace(self, name=f"{self.name}[linear twin]", nonlinear=(), K=K)

    def __repr__(self) -> str:
        traits = []
        if not self.is_time_invariant:
            traits.append("time-varying")
        if not self.is_linear:
            traits.append("nonlinear")
        kind = ", ".join(traits) or "linear time-invariant"
        return (
            f"Structure({self.name!r}: {self.n_dofs} DOFs, {self.n_sensors} sensors, {kind})"
        )
