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
  already uses the changed stiffness. One factorization is made per distinct set of events in
  effect (cached), not per step.
* Variable mass ``M(t) = M + m(t) e eᵀ``: the effective matrix is the base one (built with the
  constant ``M``) plus the rank-1 term ``m(t_{j+1}) e eᵀ``; it is solved with the
  Sherman–Morrison formula on the base factorization (no refactorization per step).
* Nonlinear elements: Newton iterations on the residual
  ``r(a) = f − M a − C v(a) − K q(a) − g(q(a), v(a))`` with the tangent
  ``S + dt²/4 K_g + dt/2 C_g`` (``K_g``, ``C_g`` the elements' stiffness and damping). The
  elements act on a few DOFs, so the tangent is the base effective matrix plus a small
  low-rank term, again solved on the base factorization (Woodbury identity).

Units: inch, lbf, second (masses lbf·s²/in, rotations rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

from ..errors import ConvergenceError, IllConditionedError
from ..fem.structure import Structure

__all__ = ["NewmarkResult", "newmark", "BETA", "GAMMA", "DENSE_MAX_DOFS"]

BETA = 0.25
"""Newmark β (average acceleration)."""
GAMMA = 0.5
"""Newmark γ (average acceleration)."""
DENSE_MAX_DOFS = 200
"""Effective matrices up to this size are factorized densely (Cholesky, LU fallback);
larger ones with a sparse LU (``scipy.sparse.linalg.splu``)."""


@dataclass(frozen=True)
class NewmarkResult:
    """DOF histories, each (n_dofs, n_samples): displacement (in), velocity (in/s),
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
        if self._kind == "cho":
            return scipy.linalg.cho_solve(self._f, b, check_finite=False)
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

    def solve(self, r: np.ndarray, B: np.ndarray | None = None) -> np.ndarray:
        y = self.factorization.solve(r)
        if B is None or not np.any(B):
            return y
        k = self.dofs.size
        G = np.eye(k) + self.Zd @ B
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


def newmark(
    structure: Structure,
    q0: np.ndarray,
    v0: np.ndarray,
    f: np.ndarray,
    dt: float,
    *,
    rtol: float = 1e-12,
    max_iter: int = 30,
) -> NewmarkResult:
    """Integrate ``M(t) q'' + C q' + K(t) q + g(q, q') = f(t)`` with average-acceleration Newmark.

    Parameters
    ----------
    structure : Structure
        Matrices, variable mass, stiffness events and nonlinear elements.
    q0, v0 : (n_dofs,) ndarray
        Initial displacement (in) and velocity (in/s) of every DOF.
    f : (n_dofs, n_samples) ndarray
        Load on every DOF at every sample ``t_j = j·dt`` (lbf). ``f[:, 0]`` enters only the
        initial acceleration; ``f[:, j]`` the equilibrium at ``t_j``.
    dt : float
        Time step (s).
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

    Returns
    -------
    NewmarkResult
        ``q``, ``v``, ``a`` of shape (n_dofs, n_samples), column 0 the initial state.

    Notes
    -----
    Input validation is done by :func:`podbench.dynamics.simulate`; this function trusts
    its arguments.
    """
    s = structure
    n_dofs, n = f.shape
    h = float(dt)
    bh2, gh = BETA * h * h, GAMMA * h
    dense = n_dofs <= DENSE_MAX_DOFS
    C_sparse = s.damping_matrix()
    has_damping = C_sparse.nnz > 0
    M = _operator(s.M, dense)
    C = _operator(C_sparse, dense)
    nonlinear = s.nonlinear

    # mass history: m(t_j) on one DOF (variable mass) -------------------------------------
    vm = s.variable_mass
    m_t = vm(np.arange(n) * h) if vm is not None else None
    if m_t is not None and m_t.shape != (n,):
        raise IllConditionedError(
            f"Variable mass law returned shape {m_t.shape} for {n} times, expected ({n},)"
        )

    # DOFs of the low-rank terms (variable mass DOF + nonlinear elements' DOFs) ----------
    el_dofs = [np.asarray(el.dofs, dtype=np.int64) for el in nonlinear]
    upd_set = {int(d) for ed in el_dofs for d in ed}
    if vm is not None:
        upd_set.add(vm.dof)
    upd = np.array(sorted(upd_set), dtype=np.int64)
    pos = {d: i for i, d in enumerate(upd)}
    vm_pos = pos[vm.dof] if vm is not None else None
    el_pos = [np.array([pos[int(d)] for d in ed], dtype=np.int64) for ed in el_dofs]

    # stiffness states and their factorizations (one per distinct set of active events) --
    first = [ev.first_sample(h) for ev in s.events]
    cache: dict[tuple[int, ...], tuple] = {}

    def state_at(j: int) -> tuple[int, ...]:
        return tuple(i for i, fj in enumerate(first) if j >= fj)

    def stiffness_and_solver(state):
        if state not in cache:
            K = s.K
            for i in state:
                K = K + s.events[i].delta_K
            S = s.M + gh * C_sparse + bh2 * K
            what = f"The Newmark effective matrix (events in effect: {list(state)})"
            K = _operator(K, dense)
            cache[state] = (K, abs(K), _LowRankUpdatedSolver(S, upd, what))
        return cache[state]

    def g_force(q, v):
        g = np.zeros(n_dofs)
        for el, d in zip(nonlinear, el_dofs, strict=True):
            g[d] += el.force(q[d], v[d])
        return g

    def update_matrix(j, q, v):
        """The small matrix B of the tangent ``S + E B Eᵀ`` at sample j (None if zero)."""
        if upd.size == 0:
            return None
        B = np.zeros((upd.size, upd.size))
        if vm_pos is not None:
            B[vm_pos, vm_pos] += m_t[j]
        for el, d, p in zip(nonlinear, el_dofs, el_pos, strict=True):
            Kg = np.asarray(el.stiffness(q[d], v[d]), dtype=float)
            Cg = np.asarray(el.damping(q[d], v[d]), dtype=float)
            B[np.ix_(p, p)] += bh2 * Kg + gh * Cg
        return B

    def mass_times(j, a):
        Ma = M @ a
        if vm is not None:
            Ma[vm.dof] += m_t[j] * a[vm.dof]
        return Ma

    q = np.empty((n_dofs, n))
    v = np.empty((n_dofs, n))
    a = np.empty((n_dofs, n))
    iters = np.zeros(n, dtype=np.int64)
    q[:, 0] = q0
    v[:, 0] = v0

    # initial acceleration: M(0) a0 = f0 − C v0 − K(0) q0 − g(q0, v0) ----------------------
    K0 = stiffness_and_solver(state_at(0))[0]
    rhs0 = f[:, 0] - K0 @ q0 - g_force(q0, v0)
    if has_damping:
        rhs0 -= C @ v0
    M0 = s.M.tolil()
    if vm is not None:
        M0[vm.dof, vm.dof] += m_t[0]
    a[:, 0] = _Factorization(M0, "The mass matrix M(0)").solve(rhs0)

    absM, absC = abs(M), abs(C)

    for j in range(n - 1):
        state = state_at(j + 1)
        K, absK, solver = stiffness_and_solver(state)
        qp = q[:, j] + h * v[:, j] + bh2 * a[:, j]  # predictors q̃, ṽ
        vp = v[:, j] + gh * a[:, j]
        rhs = f[:, j + 1] - K @ qp
        if has_damping:
            rhs -= C @ vp
        if not nonlinear:
            a1 = solver.solve(rhs, update_matrix(j + 1, qp, vp))
        else:
            a1, iters[j + 1] = _newton(
                j, h, a[:, j].copy(), qp, vp, f[:, j + 1], K, C if has_damping else None,
                solver, g_force, update_matrix, mass_times, absM, absC, absK, rtol, max_iter,
            )
        a[:, j + 1] = a1
        q[:, j + 1] = qp + bh2 * a1
        v[:, j + 1] = vp + gh * a1
    return NewmarkResult(q=q, v=v, a=a, newton_iterations=iters)


def _newton(j, h, a, qp, vp, f1, K, C, solver, g_force, update_matrix, mass_times,
            absM, absC, absK, rtol, max_iter):
    """Newton iterations for ``a_{j+1}``; returns (a, number of iterations)."""
    bh2, gh = BETA * h * h, GAMMA * h
    dq_norm = np.inf
    for it in range(max_iter + 1):
        q = qp + bh2 * a
        v = vp + gh * a
        g = g_force(q, v)
        Ma = mass_times(j + 1, a)
        r = f1 - Ma - K @ q - g
        scale_vec = np.abs(f1) + absM @ np.abs(a) + absK @ np.abs(q) + np.abs(g)
        if C is not None:
            r -= C @ v
            scale_vec += absC @ np.abs(v)
        r_norm = np.linalg.norm(r)
        if r_norm <= rtol * np.linalg.norm(scale_vec) and dq_norm <= rtol * np.linalg.norm(q):
            return a, it
        if r_norm == 0.0:  # exact solution (e.g. at rest)
            return a, it
        if it == max_iter:
            break
        da = solver.solve(r, update_matrix(j + 1, q, v))
        a = a + da
        dq_norm = bh2 * np.linalg.norm(da)  # displacement increment of this iteration
    raise ConvergenceError(
        f"Newton iterations did not converge at time step {j + 1} (t = {(j + 1) * h:.6g} s) "
        f"after {max_iter} iterations: residual {r_norm:.3e}, force scale "
        f"{np.linalg.norm(scale_vec):.3e}, last displacement increment {dq_norm:.3e} in "
        f"(relative tolerance {rtol:g})"
    )
