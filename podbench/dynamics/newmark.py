"""Newmark average-acceleration integration (β = 1/4, γ = 1/2) of a :class:`Structure`.

The dissertation (§4.1, "The Newmark method [61] was applied to simulate the exact response")
does not state the Newmark parameters; podbench uses the unconditionally stable, energy
conserving average-acceleration rule (the trapezoidal rule).

Equation solved at every sample ``t_j = j·dt``::

    M(t_j) a_j + C v_j + K(t_j) q_j + g(q_j, v_j) = f_j

with the Newmark relations between two samples::

    q_{j+1} = q_j + dt v_j + dt²/4 (a_j + a_{j+1})
    v_{j+1} = v_j + dt/2 (a_j + a_{j+1})

The unknown of each step is the acceleration ``a_{j+1}``. With the predictors
``q̃ = q_j + dt v_j + dt²/4 a_j`` and ``ṽ = v_j + dt/2 a_j`` the equilibrium at ``t_{j+1}``
reads ``S_{j+1} a_{j+1} = f_{j+1} − C ṽ − K(t_{j+1}) q̃ − g(…)`` with the effective matrix
``S = M(t) + dt/2 C + dt²/4 K(t)``.

Conventions
-----------
* Force samples: ``f_j`` (the load at ``t_j``) enters the equilibrium at ``t_j``. The first
  sample ``f_0`` enters only through the initial acceleration
  ``a_0 = M(0)⁻¹ (f_0 − C v_0 − K(0) q_0 − g(q_0, v_0))``.
* Stiffness events (element fracture) follow :class:`podbench.fem.StiffnessEvent`: the event is
  in effect from sample ``j = event.first_sample(dt)`` on, i.e. the equilibrium at that sample
  already uses the changed stiffness (and mass, when the element disappears). ``q`` and ``v``
  of the remaining DOFs are continuous across the event; the DOFs the event removes are set
  to zero at that sample and held there (their decoupled placeholder mass, see
  :meth:`podbench.fem.Structure.matrices_at`, keeps the effective matrix regular). One
  factorization is made per distinct set of events in effect (cached), not per step.
* Variable mass ``M(t) = M + m(t) e eᵀ``: the effective matrix is the base one (built with the
  constant ``M``) plus the rank-1 term ``m(t_{j+1}) e eᵀ``; it is solved with the
  Sherman–Morrison formula on the base factorization (no refactorization per step).
* Memory: the structure's matrices and factorizations are sparse above ``DENSE_MAX_DOFS``
  (O(nnz)); the loads can be given at a few points with a sparse map to the DOFs
  (``force_map``) and the histories recorded through an output matrix (``record``, e.g. the
  sensor matrix), so that nothing of size n_dofs × n_samples is allocated: memory is
  O(nnz + n_samples · (n_loads + n_outputs)) plus blocks of at most 8 MiB (:data:`CHUNK`).
* Nonlinear elements: Newton iterations on the residual
  ``r(a) = f − M a − C v(a) − K q(a) − g(q(a), v(a))`` with the tangent
  ``S + dt²/4 K_g + dt/2 C_g`` (``K_g``, ``C_g`` the elements' stiffness and damping). The
  elements act on a few DOFs, so the tangent is the base effective matrix plus a small
  low-rank term, again solved on the base factorization (Woodbury identity).

Units: inch, lbf, second (masses lbf·s²/in, rotations rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg
from scipy.linalg.lapack import dpotrs as _potrs

from podbench.errors import ConvergenceError, DimensionError, IllConditionedError, InputError
from podbench.structures.structure import Structure

__all__ = ["NewmarkResult", "newmark", "newmark_batch", "BETA", "GAMMA", "DENSE_MAX_DOFS"]

BETA = 0.25
"""Newmark β (average acceleration)."""
GAMMA = 0.5
"""Newmark γ (average acceleration)."""
DENSE_MAX_DOFS = 200
"""Effective matrices up to this size are factorized densely (Cholesky, LU fallback);
larger ones with a sparse LU (``scipy.sparse.linalg.splu``)."""


@dataclass(frozen=True)
class NewmarkResult:
    """Histories, each (n_dofs, n_samples) — or (p, n_samples) with ``record=R``
    (p × n_dofs), then ``R q``, ``R v``, ``R a`` —: displacement (in), velocity (in/s),
    acceleration (in/s²); ``newton_iterations`` (n_samples,) per step (0 for linear steps)."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    newton_iterations: np.ndarray


class _Factorization:
    """A factorization of one square matrix, dense (small) or sparse (large)."""

    def __init__(self, A: sp.spmatrix, what: str):
        try:
            if A.shape[0] <= DENSE_MAX_DOFS:
                self._kind, self._f = self._dense(A.toarray())
            else:
                self._kind, self._f = "splu", scipy.sparse.linalg.splu(sp.csc_matrix(A))
        except (np.linalg.LinAlgError, RuntimeError) as exc:
            raise IllConditionedError(
                f"{what} is singular and cannot be factorized ({exc})"
            ) from None

    @staticmethod
    def _dense(A: np.ndarray):
        try:
            return "cho", scipy.linalg.cho_factor(A, check_finite=False)
        except np.linalg.LinAlgError:  # not symmetric positive definite: LU
            pass
        lu = scipy.linalg.lu_factor(A, check_finite=False)
        if np.any(np.diag(lu[0]) == 0.0):
            raise np.linalg.LinAlgError("zero pivot")
        return "lu", lu

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self._kind == "cho":  # LAPACK directly: cho_solve's checks dominate small solves
            x, _ = _potrs(self._f[0], b, lower=self._f[1])
            return x
        if self._kind == "lu":
            return scipy.linalg.lu_solve(self._f, b, check_finite=False)
        return self._f.solve(b)


class _LowRankUpdatedSolver:
    """Solves ``(A + E B Eᵀ) x = r`` from a factorization of ``A``.

    ``E`` holds the unit vectors of a few DOFs (``dofs``), ``B`` is small (k × k). With
    ``Z = A⁻¹ E`` (computed once) and ``y = A⁻¹ r``::

        x = y − Z B (I + Z_d B)⁻¹ y_d,      Z_d = Eᵀ Z,  y_d = Eᵀ y

    (Woodbury; for k = 1 this is the Sherman–Morrison formula). ``B`` may be singular.
    """

    def __init__(self, A: sp.spmatrix, dofs: np.ndarray, what: str):
        self.factorization = _Factorization(A, what)
        self.dofs = dofs
        if dofs.size:
            E = np.zeros((A.shape[0], dofs.size))
            E[dofs, np.arange(dofs.size)] = 1.0
            self.Z = self.factorization.solve(E)
            self.Zd = self.Z[dofs, :]
            self._eye = np.eye(dofs.size)

    def solve(self, r: np.ndarray, B: np.ndarray | None = None) -> np.ndarray:
        y = self.factorization.solve(r)
        if B is None or not np.any(B):
            return y
        G = self._eye + self.Zd @ B
        try:
            xd = np.linalg.solve(G, y[self.dofs])
        except np.linalg.LinAlgError as exc:
            raise IllConditionedError(
                f"Low-rank update of the effective matrix is singular ({exc})"
            ) from None
        return y - self.Z @ (B @ xd)


def _operator(A: sp.spmatrix, dense: bool):
    """``A`` as a dense ndarray (small systems: faster products) or a CSR matrix."""
    return A.toarray() if dense else sp.csr_matrix(A)


class _Model:
    """The structure's terms as the integrator needs them, for one time step ``h``.

    * ``stiffness(j)``: ``K(t_j)`` (events per :class:`StiffnessEvent`), ``|K(t_j)|`` and the
      solver of the base effective matrix ``S = M(t_j) + h/2 C + h²/4 K(t_j)`` (cached per
      set of events in effect); ``removed(j)`` the DOFs removed by those events;
    * ``mass_times(j, a)``: ``M(t_j) a`` (``|M(t_j)| |a|`` with ``absolute=True``);
    * ``restoring(q, v)``: ``g(q, v)`` of the nonlinear elements;
    * ``update(j, q, v)``: the small matrix ``B`` with tangent ``S + E B Eᵀ``:
      ``m(t_j)`` on the variable-mass DOF plus ``h²/4 K_g + h/2 C_g`` of the elements.
    """

    def __init__(self, s: Structure, n: int, h: float):
        self.s = s
        self.h = h
        self.bh2, self.gh = BETA * h * h, GAMMA * h
        self.dense = s.n_dofs <= DENSE_MAX_DOFS
        self.C_sparse = s.damping_matrix()
        self.has_damping = self.C_sparse.nnz > 0
        self.C = _operator(self.C_sparse, self.dense)
        self.absC = abs(self.C)
        self.nonlinear = s.nonlinear
        self.el_dofs = [np.asarray(el.dofs, dtype=np.int64) for el in self.nonlinear]

        self.vm = s.variable_mass
        self.m_t = np.zeros(n)  # m(t_j) of the variable mass; without one zeros, never read
        if self.vm is not None:
            self.m_t = self.vm(np.arange(n) * h)
            if self.m_t.shape != (n,) or not np.all(np.isfinite(self.m_t)):
                raise InputError(
                    f"Variable mass of {s.name!r}: the law must return {n} finite masses for "
                    f"{n} times, got shape {self.m_t.shape}"
                )

        # DOFs of the low-rank terms: the variable-mass DOF and the elements' DOFs
        dofs = {int(d) for ed in self.el_dofs for d in ed}
        if self.vm is not None:
            dofs.add(self.vm.dof)
        self.upd = np.array(sorted(dofs), dtype=np.int64)
        pos = {d: i for i, d in enumerate(self.upd)}
        self.vm_pos = pos[self.vm.dof] if self.vm is not None else None
        self.el_pos = [np.array([pos[int(d)] for d in ed]) for ed in self.el_dofs]

        self.first = [ev.first_sample(h) for ev in s.events]
        # elements on one DOF that evaluate themselves on floats (``scalar_terms(q, v)`` ->
        # ``(g, dg/dq, dg/dv)``, the numbers of force/stiffness/damping): all or none
        terms = [getattr(el, "scalar_terms", None) for el in self.nonlinear]
        self.scalar_terms: list | None = (
            terms if terms and all(t is not None for t in terms) else None)
        self._cache: dict[tuple[int, ...], dict] = {}

    def _state(self, j: int) -> dict:
        state = tuple(i for i, fj in enumerate(self.first) if j >= fj)
        if state not in self._cache:
            K, M, removed = self.s.matrices_at(state)
            S = M + self.gh * self.C_sparse + self.bh2 * K
            what = f"The Newmark effective matrix (stiffness events in effect: {list(state)})"
            K = _operator(K, self.dense)
            Mo = _operator(M, self.dense)
            self._cache[state] = {
                "K": K, "absK": abs(K), "M_sparse": M, "M": Mo, "absM": abs(Mo),
                "removed": removed, "solver": _LowRankUpdatedSolver(S, self.upd, what)}
        return self._cache[state]

    def stiffness(self, j: int):
        """``(K, |K|, solver)`` at sample ``j``."""
        st = self._state(j)
        return st["K"], st["absK"], st["solver"]

    def removed(self, j: int) -> np.ndarray:
        """DOFs removed from the model at sample ``j`` (held at zero)."""
        return self._state(j)["removed"]

    def mass_times(self, j: int, a: np.ndarray, absolute: bool = False) -> np.ndarray:
        if absolute:
            a = np.abs(a)
        st = self._state(j)
        Ma = (st["absM"] if absolute else st["M"]) @ a
        if self.vm is not None:
            m = abs(self.m_t[j]) if absolute else self.m_t[j]
            Ma[self.vm.dof] += m * a[self.vm.dof]
        return Ma

    def mass_matrix(self, j: int) -> sp.spmatrix:
        M = self._state(j)["M_sparse"]
        if self.vm is not None:
            d = self.vm.dof
            M = M + sp.csr_matrix(([self.m_t[j]], ([d], [d])), shape=M.shape)
        return M

    def restoring(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        g = np.zeros(q.shape[0])
        for el, d in zip(self.nonlinear, self.el_dofs, strict=True):
            g[d] += el.force(q[d], v[d])
        return g

    def update(self, j: int, q: np.ndarray, v: np.ndarray) -> np.ndarray | None:
        if self.upd.size == 0:
            return None
        B = np.zeros((self.upd.size, self.upd.size))
        if self.vm_pos is not None:
            B[self.vm_pos, self.vm_pos] += self.m_t[j]
        for el, d, p in zip(self.nonlinear, self.el_dofs, self.el_pos, strict=True):
            Kg = np.asarray(el.stiffness(q[d], v[d]), dtype=float)
            Cg = np.asarray(el.damping(q[d], v[d]), dtype=float)
            B[np.ix_(p, p)] += self.bh2 * Kg + self.gh * Cg
        return B


def _as_map(A, name: str, rows: int | None, cols: int):
    """``A`` as a CSR matrix (sparse input) or a float ndarray of shape (rows, cols);
    ``rows=None`` accepts any number of rows."""
    if sp.issparse(A):
        A = sp.csr_matrix(A, dtype=float)
        data = A.data
    else:
        try:
            A = np.asarray(A, dtype=float)
        except (TypeError, ValueError):
            raise InputError(
                f"Parameter `{name}`: expected a numeric matrix, got {type(A).__name__}"
            ) from None
        data = A
    expected = f"({'p' if rows is None else rows}, {cols})"
    if A.ndim != 2 or A.shape[1] != cols or (rows is not None and A.shape[0] != rows):
        raise DimensionError(f"Parameter `{name}`: expected shape {expected}, got {A.shape}")
    if not np.all(np.isfinite(data)):
        raise InputError(f"Parameter `{name}`: contains NaN or Inf")
    return A


CHUNK = 256
"""Samples per block of the sparse load and output maps: ``T f`` and ``R q`` are formed for
up to ``CHUNK`` samples at once (one sparse product per block instead of one per sample),
fewer on large structures so that a block holds at most :data:`BLOCK_FLOATS` numbers per
history. A CSR product sums each output element over its row's entries in the same order
whatever the number of columns, so the numbers are those of the per-sample products."""

BLOCK_FLOATS = 2**20
"""Largest block (floats, 8 MiB) of one buffered history (n_dofs × block samples)."""


def _chunk(n_dofs: int) -> int:
    """Samples per block for ``n_dofs`` DOFs (:data:`CHUNK`, :data:`BLOCK_FLOATS`)."""
    return max(1, min(CHUNK, BLOCK_FLOATS // max(n_dofs, 1)))


class _Loads:
    """``f_j`` of every DOF: ``f[:, j]``, or ``T f[:, j]`` with a load map ``T`` (sparse:
    formed by blocks of :data:`CHUNK` samples)."""

    def __init__(self, f: np.ndarray, T):
        self.f, self.T = f, T
        self.sparse = T is not None and sp.issparse(T)
        self.size = _chunk(T.shape[0]) if self.sparse else 1
        self.start = -self.size
        self.block = np.empty((0, 0))

    def __call__(self, j: int) -> np.ndarray:
        if self.T is None:
            return self.f[:, j]
        if not self.sparse:
            return self.T @ self.f[:, j]
        if not 0 <= j - self.start < self.size:
            self.start = j
            self.block = self.T @ self.f[:, j:j + self.size]
        return self.block[:, j - self.start]


class _Recorder:
    """Stores the state of every sample: the full vectors, or ``R x`` for an output matrix R
    (sparse ``R``: the states are buffered and mapped by blocks of :data:`CHUNK` samples;
    call :meth:`flush` after the last sample)."""

    def __init__(self, record, n_dofs: int, n: int):
        self.R = None if record is None else _as_map(record, "record", None, n_dofs)
        rows = n_dofs if self.R is None else self.R.shape[0]
        self.q = np.empty((rows, n))
        self.v = np.empty((rows, n))
        self.a = np.empty((rows, n))
        self.buffered = self.R is not None and sp.issparse(self.R)
        if self.buffered:
            self.size = _chunk(n_dofs)
            self.buf = np.empty((3, n_dofs, self.size))
            self.start, self.count = 0, 0

    def __call__(self, j: int, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> None:
        R = self.R
        if R is None:
            self.q[:, j], self.v[:, j], self.a[:, j] = q, v, a
        elif self.buffered:
            if self.count == self.size:
                self.flush()
            if self.count == 0:
                self.start = j
            c = self.count
            self.buf[0, :, c], self.buf[1, :, c], self.buf[2, :, c] = q, v, a
            self.count += 1
        else:
            self.q[:, j], self.v[:, j], self.a[:, j] = R @ q, R @ v, R @ a

    def flush(self) -> None:
        """Map the buffered states (sparse ``R``); a no-op otherwise."""
        if not self.buffered or self.count == 0:
            return
        j0, c, R = self.start, self.count, self.R
        assert R is not None
        for hist, block in zip((self.q, self.v, self.a), self.buf, strict=True):
            hist[:, j0:j0 + c] = R @ block[:, :c]
        self.count = 0


def newmark(
    structure: Structure,
    q0: np.ndarray,
    v0: np.ndarray,
    f: np.ndarray,
    dt: float,
    *,
    force_map=None,
    record=None,
    rtol: float = 1e-12,
    max_iter: int = 30,
    propagator: bool = False,
) -> NewmarkResult:
    """Integrate ``M(t) q'' + C q' + K(t) q + g(q, q') = f(t)`` with average-acceleration Newmark.

    Parameters
    ----------
    structure : Structure
        Matrices, variable mass, stiffness events and nonlinear elements.
    q0, v0 : (n_dofs,) ndarray
        Initial displacement (in) and velocity (in/s) of every DOF.
    f : (n_dofs, n_samples) ndarray, or (n_loads, n_samples) with ``force_map``
        Load at every sample ``t_j = j·dt`` (lbf). ``f[:, 0]`` enters only the initial
        acceleration; ``f[:, j]`` the equilibrium at ``t_j``.
    dt : float
        Time step (s).
    force_map : (n_dofs, n_loads) sparse or dense matrix, optional
        The DOF load at sample ``j`` is ``force_map @ f[:, j]``, formed one sample at a time
        (e.g. ``structure.sensor_matrix().T`` for loads sampled at the sensors, the
        ``Sᵀ f`` of :meth:`Structure.to_dofs`); no (n_dofs, n_samples) load array is
        built. ``None``: ``f`` already holds the DOF loads.
    record : (p, n_dofs) sparse or dense matrix, optional
        Output matrix ``R``: only ``R q_j``, ``R v_j``, ``R a_j`` are stored at every sample
        (e.g. ``structure.sensor_matrix()`` for the sensor readings ``W = S q``), so the
        histories take 3·p·n_samples floats instead of 3·n_dofs·n_samples. ``None`` (the
        default): the full DOF histories.
    rtol : float
        Newton tolerance (nonlinear structures): the residual must be below ``rtol`` times
        the force scale ``‖ |f| + |M||a| + |C||v| + |K||q| + |g| ‖`` (the size of the terms
        whose sum is the residual, hence the round-off level of its evaluation) and the
        displacement increment of the last iteration, ``dt²/4 ‖Δa‖``, below ``rtol·‖q‖``.
        (The increment is measured on the displacement, not the acceleration: on stiff FE
        models the high-mode accelerations are large and their round-off noise would keep a
        relative acceleration increment above 1e-12 forever.)
    max_iter : int
        Maximum Newton iterations per step; more raises :class:`ConvergenceError`.
    propagator : bool
        Step the linear part by its one-step transition matrix (:func:`_steps_propagator`):
        one product with a dense 3n × 3n matrix per step instead of the predictors, two
        matrix products and a triangular solve — about 4× faster per step on a small
        structure whose nonlinear elements act on one DOF (the rubber-band beam: 40 DOFs).
        The same scheme and the same Newton iteration; the histories differ from the default
        path's in round-off only (a different order of the same operations: 2e-13 relative
        over 22 000 steps of the rubber-band beam). Applies to dense structures (at most
        ``DENSE_MAX_DOFS`` DOFs) without stiffness events or variable mass whose nonlinear
        elements act on one DOF; ignored elsewhere (the default path runs).

    Returns
    -------
    NewmarkResult
        ``q``, ``v``, ``a`` of shape (n_dofs, n_samples) — (p, n_samples) with ``record`` —,
        column 0 the initial state.

    Raises
    ------
    DimensionError
        ``force_map`` or ``record`` of the wrong shape.
    InputError
        NaN or Inf in ``force_map`` or ``record``.

    Notes
    -----
    Input validation of the structure, initial state and loads is done by
    :func:`podbench.dynamics.simulate`; this function trusts those arguments (shapes,
    finiteness).
    """
    n_dofs = structure.n_dofs
    n = f.shape[1]
    h = float(dt)
    if force_map is None:
        T = None
    else:
        T = _as_map(force_map, "force_map", n_dofs, f.shape[0])

    load = _Loads(f, T)
    out = _Recorder(record, n_dofs, n)
    model = _Model(structure, n, h)
    iters = np.zeros(n, dtype=np.int64)

    q, v, a = _initial_state(model, q0, v0, load(0))
    out(0, q, v, a)
    if propagator and _propagator_applies(model):
        _steps_propagator(model, f, T, out, q, v, a, iters, rtol, max_iter)
    elif model.first or model.removed(0).size:
        _steps_general(model, load, out, q, v, a, iters, rtol, max_iter)
    else:
        _steps_fixed(model, load, out, q, v, a, iters, rtol, max_iter)
    out.flush()
    return NewmarkResult(q=out.q, v=out.v, a=out.a, newton_iterations=iters)


def newmark_batch(structure: Structure, f: np.ndarray, dt: float, *, force_map=None,
                  record=None, rtol: float = 1e-12, max_iter: int = 30) -> np.ndarray:
    """Displacements of several independent :func:`newmark` integrations from rest, stepped
    together: ``f`` (k, n_loads, n_samples) holds the loads of the k runs (lbf; ``force_map``
    and ``record`` as in :func:`newmark`); returns the recorded displacements (k, p,
    n_samples) (in), run c those of ``newmark(structure, 0, 0, f[c], dt, ...,
    propagator=True).q``.

    Where ``propagator=True`` applies (:func:`_steps_propagator`) the k states are the rows
    of one (k, 3n) array, advanced by one product with the transition matrix per step for
    all of them (:func:`_steps_propagator_batch`), each run's one-DOF Newton iteration
    unchanged: every history equals the single run's up to the round-off of a matrix-matrix
    instead of a matrix-vector product. Elsewhere the runs are integrated one by one.
    """
    f = np.asarray(f, dtype=float)
    if f.ndim != 3:
        raise DimensionError(f"Parameter `f`: expected (runs, loads, samples), got {f.shape}")
    k, _, n = f.shape
    n_dofs = structure.n_dofs
    zero = np.zeros(n_dofs)
    T = None if force_map is None else _as_map(force_map, "force_map", n_dofs, f.shape[1])
    model = _Model(structure, n, float(dt))
    if not _propagator_applies(model):
        return np.stack([newmark(structure, zero, zero, f[c], dt, force_map=force_map,
                                 record=record, rtol=rtol, max_iter=max_iter,
                                 propagator=True).q for c in range(k)])
    R = None if record is None else _as_map(record, "record", None, n_dofs)
    S0 = np.empty((k, 3 * n_dofs))
    for c in range(k):
        q, v, a = _initial_state(model, zero, zero, _Loads(f[c], T)(0))
        S0[c] = np.concatenate([q, v, a])
    Q = _steps_propagator_batch(model, f, T, S0, rtol, max_iter)  # (n_samples, k, n_dofs)
    if R is None:
        return np.ascontiguousarray(Q.transpose(1, 2, 0))
    return np.stack([np.asarray(R @ Q[:, c, :].T) for c in range(k)])


def _steps_propagator_batch(model: _Model, f, T, S, rtol, max_iter) -> np.ndarray:
    """:func:`_steps_propagator` for the k runs whose states are the rows of ``S`` (k, 3n):
    per step ``S_lin = S Φᵀ`` (plus each loaded run's ``L f_{j+1}``), each run's scalar
    Newton iteration, then ``S = S_lin − g wᵀ``. Returns the displacements of every sample,
    (n_samples, k, n)."""
    n = model.s.n_dofs
    h, bh2, gh = model.h, model.bh2, model.gh
    Phi, L, w = _transition(model, T)
    PhiT = np.ascontiguousarray(Phi.T)
    d = int(model.stiffness(0)[2].dofs[0])
    iv, ia = n + d, 2 * n + d
    z = float(w[ia])
    k, n_samples = f.shape[0], f.shape[2]
    loaded = np.any(f != 0.0, axis=1)  # (k, n_samples)
    any_loaded = loaded.any(axis=0)
    starts, blocks = [-CHUNK] * k, [np.empty((0, 0))] * k
    Q = np.empty((n_samples, k, n))
    Q[0] = S[:, :n]
    G = np.zeros((k, 1))
    for j in range(1, n_samples):
        SL = S @ PhiT
        if any_loaded[j]:
            for c in np.flatnonzero(loaded[:, j]):
                if not 0 <= j - starts[c] < CHUNK:
                    starts[c], blocks[c] = j, (L @ f[c][:, j:j + CHUNK]).T
                SL[c] += blocks[c][j - starts[c]]
        qd, vd, ad, yd = S[:, d].tolist(), S[:, iv].tolist(), S[:, ia].tolist(), \
            SL[:, ia].tolist()
        engaged = False
        for c in range(k):
            g, _ = _scalar_newton(
                model, j, ad[c], qd[c] + h * vd[c] + bh2 * ad[c], vd[c] + gh * ad[c], yd[c], z,
                lambda x=SL[c, :n]: math.sqrt(x.dot(x)), rtol, max_iter)
            G[c, 0] = g
            engaged = engaged or g != 0.0
        S = SL - G * w if engaged else SL
        Q[j] = S[:, :n]
    return Q


def _steps_general(model: _Model, load, out, q, v, a, iters, rtol, max_iter) -> None:
    """Samples 1 … n−1 of :func:`newmark` (stiffness events: the matrices per sample)."""
    h, bh2, gh = model.h, model.bh2, model.gh
    for j in range(iters.size - 1):
        K, absK, solver = model.stiffness(j + 1)
        removed = model.removed(j + 1)
        if removed.size:  # DOFs that left the model (element fracture) are held at zero
            q[removed] = v[removed] = a[removed] = 0.0
        qp = q + h * v + bh2 * a  # predictors q̃, ṽ
        vp = v + gh * a
        fj = load(j + 1)
        if removed.size:
            fj = np.array(fj, dtype=float)
            fj[removed] = 0.0
        if model.nonlinear and model.vm is None:
            a, iters[j + 1] = _newton_condensed(
                model, j + 1, a, qp, vp, fj, K, solver, rtol, max_iter
            )
        elif model.nonlinear:
            a, iters[j + 1] = _newton(
                model, j + 1, a, qp, vp, fj, K, absK, solver, rtol, max_iter
            )
        else:  # S(t_{j+1}) a = f − C ṽ − K q̃, one solve
            rhs = fj - K @ qp
            if model.has_damping:
                rhs -= model.C @ vp
            a = solver.solve(rhs, model.update(j + 1, qp, vp))
        q = qp + bh2 * a
        v = vp + gh * a
        out(j + 1, q, v, a)


def _steps_fixed(model: _Model, load, out, q, v, a, iters, rtol, max_iter) -> None:
    """:func:`_steps_general` for a structure without stiffness events: the same
    arithmetic, with the matrices and the step's branch looked up once."""
    h, bh2, gh = model.h, model.bh2, model.gh
    K, absK, solver = model.stiffness(0)
    C = model.C if model.has_damping else None
    nonlinear, vm = bool(model.nonlinear), model.vm is not None
    scalar = nonlinear and not vm and solver.dofs.size == 1
    for j in range(iters.size - 1):
        qp = q + h * v + bh2 * a  # predictors q̃, ṽ
        vp = v + gh * a
        fj = load(j + 1)
        if scalar:  # _newton_condensed's one-DOF case, without its dispatch
            rhs = fj - K @ qp
            if C is not None:
                rhs -= C @ vp
            a, iters[j + 1] = _newton_scalar(model, j + 1, a, qp, vp,
                                             solver.factorization.solve(rhs), solver,
                                             rtol, max_iter)
        elif nonlinear and not vm:
            a, iters[j + 1] = _newton_condensed(
                model, j + 1, a, qp, vp, fj, K, solver, rtol, max_iter
            )
        elif nonlinear:
            a, iters[j + 1] = _newton(
                model, j + 1, a, qp, vp, fj, K, absK, solver, rtol, max_iter
            )
        else:  # S(t_{j+1}) a = f − C ṽ − K q̃, one solve
            rhs = fj - K @ qp
            if C is not None:
                rhs -= C @ vp
            a = solver.solve(rhs, model.update(j + 1, qp, vp) if vm else None)
        q = qp + bh2 * a
        v = vp + gh * a
        out(j + 1, q, v, a)


def _propagator_applies(model: _Model) -> bool:
    """Whether :func:`_steps_propagator` can run ``model``: dense, no stiffness events, no
    variable mass, nonlinear elements on one DOF."""
    return (model.dense and not model.first and not model.removed(0).size
            and bool(model.nonlinear) and model.vm is None
            and model.stiffness(0)[2].dofs.size == 1)


def _transition(model: _Model, T) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Φ, L, w)`` of one Newmark step on the state ``s = [q; v; a]`` (3n)::

        s_{j+1} = Φ s_j + L f_{j+1} − w g_{j+1}

    with ``y = S⁻¹ (f − C ṽ − K q̃) = −S⁻¹K q − S⁻¹(hK + C) v − S⁻¹(h²/4 K + h/2 C) a + S⁻¹f``
    the step's acceleration without the elements, ``q' = q̃ + h²/4 y``, ``v' = ṽ + h/2 y``,
    ``a' = y``; ``L = [h²/4; h/2; 1] ⊗ S⁻¹T`` (``T`` the load map, identity without one) and
    ``w = [h²/4; h/2; 1] ⊗ z``, ``z = S⁻¹ e_d`` the column of the elements' DOF ``d``
    (the step's ``a = y − z g`` of :func:`_newton_condensed`).

    The products with ``S⁻¹`` are refined (:func:`_refined_solve`) and Φ, L, w assembled in
    extended precision, then rounded once: with a plain double ``S⁻¹K`` the rubber-band
    beam's tip history drifted from an independent whole-system Newmark (a dense solve of
    the whole tangent per Newton iteration) by 3.5e-11 of its amplitude in 3000 steps;
    refined and assembled so, by 6.3e-13, as the default path (6.0e-13)."""
    n = model.s.n_dofs
    h, bh2, gh = model.h, model.bh2, model.gh
    st = model._state(0)
    K = np.asarray(st["K"], dtype=float)
    C = np.asarray(model.C, dtype=float) if model.has_damping else np.zeros((n, n))
    S = np.asarray(st["M"], dtype=float) + gh * C + bh2 * K  # the factorized matrix
    ext = np.longdouble
    Ke, Ce = K.astype(ext), C.astype(ext)
    solver = st["solver"]
    Y = -_refined_solve(solver.factorization, S,
                        np.hstack([Ke, h * Ke + Ce, bh2 * Ke + gh * Ce]))
    eye, zero = np.eye(n), np.zeros((n, n))
    P = np.block([[eye, h * eye, bh2 * eye], [zero, eye, gh * eye], [zero, zero, zero]])
    Phi = P.astype(ext) + np.vstack([bh2 * Y, gh * Y, Y])
    Tm = eye if T is None else (T.toarray() if sp.issparse(T) else np.asarray(T, dtype=float))
    G = _refined_solve(solver.factorization, S, Tm.astype(ext))
    z = _refined_solve(solver.factorization, S, eye[:, solver.dofs].astype(ext))[:, 0]
    return (np.asarray(Phi, dtype=float), np.asarray(np.vstack([bh2 * G, gh * G, G]),
                                                      dtype=float),
            np.asarray(np.concatenate([bh2 * z, gh * z, z]), dtype=float))


def _refined_solve(fac: _Factorization, S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``S⁻¹B`` (``B`` in ``np.longdouble``) by the double factorization ``fac`` of ``S``
    and two steps of iterative refinement with the residual ``B − S X`` in extended
    precision; returned in ``np.longdouble``."""
    Se = S.astype(np.longdouble)
    X = fac.solve(np.asarray(B, dtype=float)).astype(np.longdouble)
    for _ in range(2):
        X = X + fac.solve(np.asarray(B - Se @ X, dtype=float))
    return X


def _steps_propagator(model: _Model, f, T, out, q, v, a, iters, rtol, max_iter) -> None:
    """Samples 1 … n−1 of :func:`newmark` by the transition of :func:`_transition` (see
    ``propagator``): per step ``s_lin = Φ s + L f_{j+1}`` (one dense product; the load term
    only at samples with a load, formed by blocks of :data:`CHUNK` samples), the one-DOF
    Newton iteration of :func:`_scalar_newton` on the predictors and linear acceleration of
    the elements' DOF read from ``s`` and ``s_lin`` (``‖q̃ + h²/4 y‖ = ‖s_lin[:n]‖``), then
    ``s = s_lin − w g``."""
    n = model.s.n_dofs
    h, bh2, gh = model.h, model.bh2, model.gh
    Phi, L, w = _transition(model, T)
    solver = model.stiffness(0)[2]
    d = int(solver.dofs[0])
    iv, ia = n + d, 2 * n + d
    z = float(w[2 * n + d])
    loaded = np.any(f != 0.0, axis=0)
    start, block = -CHUNK, np.empty((0, 0))
    s = np.concatenate([q, v, a])
    for j in range(1, iters.size):
        sl = Phi @ s
        if loaded[j]:
            if not 0 <= j - start < CHUNK:
                start, block = j, L @ f[:, j:j + CHUNK]
            sl += block[:, j - start]
        qd, vd, ad = s.item(d), s.item(iv), s.item(ia)
        g, iters[j] = _scalar_newton(
            model, j, ad, qd + h * vd + bh2 * ad, vd + gh * ad, sl.item(ia), z,
            lambda x=sl[:n]: math.sqrt(x.dot(x)), rtol, max_iter)  # = np.linalg.norm(x)
        s = sl - w * g if g != 0.0 else sl
        out(j, s[:n], s[n:2 * n], s[2 * n:])


def _initial_state(model: _Model, q0: np.ndarray, v0: np.ndarray,
                   f0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q0, v0, a0)`` with the initial acceleration from the equilibrium at ``t = 0``:
    ``M(0) a0 = f0 − C v0 − K(0) q0 − g(q0, v0)``; DOFs removed at sample 0 are held at zero."""
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    K0 = model.stiffness(0)[0]
    removed = model.removed(0)
    q[removed] = v[removed] = 0.0
    rhs0 = f0 - K0 @ q - model.restoring(q, v)
    if model.has_damping:
        rhs0 -= model.C @ v
    rhs0[removed] = 0.0
    a = _Factorization(model.mass_matrix(0), "The mass matrix M(0)").solve(rhs0)
    return q, v, a


def _newton_condensed(model: _Model, j, a, qp, vp, f, K, solver, rtol, max_iter):
    """Newton iterations on the nonlinear elements' DOFs only (no variable mass).

    With ``S`` the base effective matrix, ``y = S⁻¹ (f − C ṽ − K q̃)`` and ``Z = S⁻¹ E`` (the
    columns of the elements' DOFs ``d``, factorized once), the step's equation
    ``S a + E g(q_d, v_d) = f − C ṽ − K q̃`` is ``a = y − Z g`` with, on ``d`` alone,
    ``φ(a_d) = a_d − y_d + Z_d g(q̃_d + h²/4 a_d, ṽ_d + h/2 a_d) = 0``: a Newton iteration on
    a few unknowns (one for the rubber band or the cubic tip spring) with the Jacobian
    ``I + Z_d B`` (``B = h²/4 K_g + h/2 C_g``, the Woodbury matrix of the full iteration),
    then ``a`` from one product. The same solution as :func:`_newton` (which iterates on the
    whole system) to its tolerance, without a whole-system residual per iteration.
    Converged when ``|φ|`` is below ``rtol`` times the size of its terms and the last
    displacement increment ``h²/4 |Δa_d|`` below ``rtol ‖q‖``; returns ``(a, iterations)``.
    """
    bh2, gh = model.bh2, model.gh
    rhs = f - K @ qp
    if model.has_damping:
        rhs -= model.C @ vp
    y = solver.factorization.solve(rhs)
    d, Z, Zd, eye = solver.dofs, solver.Z, solver.Zd, solver._eye
    if d.size == 1:
        return _newton_scalar(model, j, a, qp, vp, y, solver, rtol, max_iter)
    qd0, vd0, yd = qp[d], vp[d], y[d]
    ad = a[d].copy()
    k = d.size
    dq_norm = np.inf
    for it in range(max_iter + 1):
        qd = qd0 + bh2 * ad
        vd = vd0 + gh * ad
        g = np.zeros(k)
        B = np.zeros((k, k))
        for el, p in zip(model.nonlinear, model.el_pos, strict=True):
            g[p] += el.force(qd[p], vd[p])
            B[np.ix_(p, p)] += (bh2 * np.asarray(el.stiffness(qd[p], vd[p]), dtype=float)
                                + gh * np.asarray(el.damping(qd[p], vd[p]), dtype=float))
        Zg = Zd @ g
        phi = ad - yd + Zg
        phi_norm = float(np.linalg.norm(phi))
        scale = float(np.linalg.norm(np.abs(ad) + np.abs(yd) + np.abs(Zg)))
        if phi_norm == 0.0 or (phi_norm <= rtol * scale
                               and dq_norm <= rtol * np.linalg.norm(qp + bh2 * y)):
            return y - Z @ g, it
        if it == max_iter:
            break
        try:
            da = np.linalg.solve(eye + Zd @ B, -phi)
        except np.linalg.LinAlgError as exc:
            raise IllConditionedError(
                f"Low-rank update of the effective matrix is singular ({exc})") from None
        ad = ad + da
        dq_norm = bh2 * np.linalg.norm(da)
    raise ConvergenceError(
        f"Newton iterations did not converge at time step {j} (t = {j * model.h:.6g} s) "
        f"after {max_iter} iterations: residual {phi_norm:.3e} in/s² on the nonlinear "
        f"elements' DOFs, scale {scale:.3e} in/s², last displacement increment "
        f"{dq_norm:.3e} in (relative tolerance {rtol:g})"
    )


def _newton_scalar(model: _Model, j, a, qp, vp, y, solver, rtol, max_iter):
    """:func:`_newton_condensed` for elements on one DOF (the rubber band, a tip spring):
    the same iteration in scalars (:func:`_scalar_newton`)."""
    dof = int(solver.dofs[0])
    g, it = _scalar_newton(model, j, float(a[dof]), float(qp[dof]), float(vp[dof]),
                           float(y[dof]), float(solver.Zd[0, 0]),
                           lambda: float(np.linalg.norm(qp + model.bh2 * y)), rtol, max_iter)
    return y - solver.Z[:, 0] * g, it


def _scalar_newton(model: _Model, j, ad, qd0, vd0, yd, z, q_norm_of, rtol, max_iter):
    """The one-DOF Newton iteration of :func:`_newton_condensed` on floats: ``ad`` the
    starting acceleration of the DOF, ``qd0``, ``vd0`` its predictors, ``yd`` its linear
    acceleration, ``z = Z_d``, ``q_norm_of()`` the norm ‖q̃ + h²/4 y‖ of the step's
    displacement without the elements (called at most once, when the test needs it).
    Returns ``(g, iterations)``: the elements' force at the solution, so that
    ``a = y − Z g``."""
    bh2, gh = model.bh2, model.gh
    q_norm = None
    dq = np.inf
    terms = model.scalar_terms
    if terms is None:
        qbuf, vbuf = np.empty(1), np.empty(1)
    for it in range(max_iter + 1):
        g = 0.0
        b = 0.0
        if terms is not None:  # the elements' own float evaluation (the same numbers)
            qs, vs = qd0 + bh2 * ad, vd0 + gh * ad
            for term in terms:
                ge, ke, ce = term(qs, vs)
                g += ge
                b += bh2 * ke + gh * ce
        else:
            qbuf[0] = qd0 + bh2 * ad
            vbuf[0] = vd0 + gh * ad
            for el in model.nonlinear:
                g += float(np.sum(el.force(qbuf, vbuf)))
                b += (bh2 * float(np.asarray(el.stiffness(qbuf, vbuf)).reshape(-1)[0])
                      + gh * float(np.asarray(el.damping(qbuf, vbuf)).reshape(-1)[0]))
        zg = z * g
        phi = ad - yd + zg
        scale = abs(ad) + abs(yd) + abs(zg)
        if phi == 0.0:
            return g, it
        if abs(phi) <= rtol * scale and dq != np.inf:
            if q_norm is None:
                q_norm = q_norm_of()
            if dq <= rtol * q_norm:
                return g, it
        if it == max_iter:
            break
        jac = 1.0 + z * b
        if jac == 0.0:
            raise IllConditionedError(
                "Low-rank update of the effective matrix is singular (1 + z·b = 0)")
        da = -phi / jac
        ad = ad + da
        dq = bh2 * abs(da)
    raise ConvergenceError(
        f"Newton iterations did not converge at time step {j} (t = {j * model.h:.6g} s) "
        f"after {max_iter} iterations: residual {abs(phi):.3e} in/s² on the nonlinear "
        f"element's DOF, scale {scale:.3e} in/s², last displacement increment "
        f"{dq:.3e} in (relative tolerance {rtol:g})"
    )


def _newton(model: _Model, j, a, qp, vp, f, K, absK, solver, rtol, max_iter):
    """Newton iterations for the acceleration at sample ``j``, starting from ``a``.

    Residual ``r(a) = f − M(t_j) a − C v − K q − g(q, v)`` with ``q = q̃ + h²/4 a``,
    ``v = ṽ + h/2 a``; returns ``(a, number of linear solves)``.
    """
    bh2, gh = model.bh2, model.gh
    dq_norm = np.inf
    for it in range(max_iter + 1):
        q = qp + bh2 * a
        v = vp + gh * a
        g = model.restoring(q, v)
        r = f - model.mass_times(j, a) - K @ q - g
        scale = np.abs(f) + model.mass_times(j, a, absolute=True) + absK @ np.abs(q) + np.abs(g)
        if model.has_damping:
            r -= model.C @ v
            scale += model.absC @ np.abs(v)
        r_norm = np.linalg.norm(r)
        if r_norm == 0.0 or (
            r_norm <= rtol * np.linalg.norm(scale) and dq_norm <= rtol * np.linalg.norm(q)
        ):
            return a, it
        if it == max_iter:
            break
        da = solver.solve(r, model.update(j, q, v))
        a = a + da
        dq_norm = float(bh2 * np.linalg.norm(da))  # displacement increment of this iteration
    raise ConvergenceError(
        f"Newton iterations did not converge at time step {j} (t = {j * model.h:.6g} s) "
        f"after {max_iter} iterations: residual {r_norm:.3e} lbf, force scale "
        f"{np.linalg.norm(scale):.3e} lbf, last displacement increment {dq_norm:.3e} in "
        f"(relative tolerance {rtol:g})"
    )
