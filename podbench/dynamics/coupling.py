"""A finite-element parent coupled with components known only by discrete kernels (Chapter 6).

Allison (2007), Chapter 6: "it may be profitable to define certain components
experimentally and incorporate them into the finite element model". A component attached
at parent DOFs ``B`` (n_dofs × p, unit columns) is known by its kernel from the interface
force ``g`` (applied *to the component*; the parent feels ``−B g``) to its interface
response::

    y_c[n] = Σ_{k=0}^{L−1} H[k] g[n−k]          (LTI, H (L, p, p))
    y_c[n] = Σ_{k=0}^{L−1} H[n, k] g[n−k]       (time-varying, H (n_t, L, p, p))

``y_c`` the interface acceleration (``quantity="acceleration"``, ``H[0] ≠ 0``: direct
feedthrough), velocity (``"velocity"``) or displacement (``"displacement"``). No ``Δt``
factor (a kernel of :mod:`podbench.sysid.deconvolution` is ``H/Δt``). Convention: the
component is at rest at ``t_0`` and ``g_0 = 0`` (podbench's ``f_0 = 0``; the interface
must be at rest at ``t_0``).

The parent is integrated with average-acceleration Newmark (β = 1/4, γ = 1/2) as
:mod:`podbench.dynamics.newmark`: ``S a_{n+1} = f_{n+1} − K q̃ − C ṽ − B g_{n+1}``, so
``a_{n+1} = a* − S⁻¹B g_{n+1}``. Schemes:

``"implicit"`` (default)
    compatibility at the current step, ``Bᵀa_{n+1} = H[0] g_{n+1} + r_{n+1}`` (``r`` the
    history part of the convolution), gives
    ``g_{n+1} = (BᵀS⁻¹B + H[0])⁻¹ (Bᵀa* − r_{n+1})`` (velocity kernels:
    ``(γ h BᵀS⁻¹B + H_v[0])⁻¹ (Bᵀ(ṽ + γ h a*) − r)``; displacement kernels:
    ``(β h² BᵀS⁻¹B + H_d[0])⁻¹ (Bᵀ(q̃ + β h² a*) − r)``). With the exact Newmark-discrete
    kernel of a component (:func:`newmark_kernel`) this is Newmark on the assembled system
    (to round-off): impulse-based substructuring (Rixen; van der Valk & Rixen) in the time
    domain. Its growth factor is the assembled Newmark's (1 on an undamped structure).
``"two-step"``
    the dissertation's explicit reading: "simulating the response of the finite element
    portion of the model, translating it into inputs for the experimental component, and
    using the predicted outputs as inputs for the finite element model at the following
    time step": the parent steps with the previous force ``g_n``, then the component's
    force follows from compatibility, ``g_{n+1} = H[0]⁻¹ (Bᵀa_{n+1} − r_{n+1})``. For a
    massive component the error per step is multiplied by about ``−BᵀS⁻¹B H[0]⁻¹``: the
    scheme is stable only while the component's interface mass ``1/H[0]`` stays below the
    parent's ``1/(BᵀS⁻¹B)`` (which grows as Δt shrinks). :func:`couple` computes the
    growth factor first and refuses (:class:`UnstableCouplingError`, one line) where it
    exceeds 1.

Growth factor: the spectral radius of the coupled step's linear map on the state (parent
``q, v, a`` and the kernel memory ``g_n … g_{n−L+2}``), unforced; for a time-varying
kernel, the largest over frozen times (:func:`growth_factor`).

Units: inch, lbf, second.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from podbench.dynamics.newmark import BETA, GAMMA
from podbench.errors import DimensionError, InputError
from podbench.structures.structure import Structure

__all__ = ["Component", "CoupledResult", "UnstableCouplingError", "couple", "growth_factor",
           "newmark_kernel", "newmark_realization", "point_mass_kernel", "SCHEMES", "GROWTH_TOL"]

SCHEMES = ("implicit", "two-step")
"""The coupling schemes: implicit interface solve (default), the dissertation's two-step."""
QUANTITIES = ("acceleration", "velocity", "displacement")
GROWTH_TOL = 1e-6
"""A growth factor up to ``1 + GROWTH_TOL`` counts as stable (round-off of the eigenvalues of
an undamped structure, which lie on the unit circle)."""
FROZEN_TIMES = 8
"""Frozen times at which the growth factor of a time-varying kernel is evaluated."""


class UnstableCouplingError(InputError):
    """A coupling scheme whose step amplifies the state (growth factor > 1)."""


@dataclass(frozen=True)
class Component:
    """A component at parent DOFs ``dofs`` known by its kernel (see the module docstring).

    ``kernel``: (L, p, p) time-invariant or (n_t, L, p, p) time-varying (row ``n`` the
    kernel at ``t_n``; beyond ``n_t`` the last row); ``quantity``: the response the kernel
    gives (``"acceleration"``, ``"velocity"`` or ``"displacement"``); ``realization``: optionally
    ``(A, B, C, D)`` of a time-invariant kernel (``x[n+1] = A x[n] + B g[n]``,
    ``y[n] = C x[n] + D g[n]``: ``H[0] = D``, ``H[k] = C A^{k−1} B``), the component's memory
    beyond the kernel's L lags: when every component has one, the coupling keeps ``x``
    instead of the last L forces (exact over any horizon, and cheaper).
    """

    dofs: tuple
    kernel: np.ndarray
    quantity: str = "acceleration"
    name: str = "component"
    realization: tuple | None = None

    def __post_init__(self):
        dofs = tuple(int(d) for d in np.ravel(self.dofs))
        H = np.asarray(self.kernel, dtype=float)
        p = len(dofs)
        if H.ndim == 3:
            H = H[None]
        if H.ndim != 4 or H.shape[2:] != (p, p) or H.shape[1] == 0 or H.shape[0] == 0:
            raise DimensionError(f"Component {self.name!r}: kernel must be (L, {p}, {p}) or "
                                 f"(n_t, L, {p}, {p}), got {np.shape(self.kernel)}")
        if not np.all(np.isfinite(H)):
            raise InputError(f"Component {self.name!r}: kernel contains NaN or Inf")
        if self.quantity not in QUANTITIES:
            raise InputError(f"Component {self.name!r}: quantity must be one of {QUANTITIES}, "
                             f"got {self.quantity!r}")
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "kernel", H)
        if self.realization is not None:
            A, Bm, Cm, Dm = (np.atleast_2d(np.asarray(x, dtype=float)) for x in self.realization)
            nx = A.shape[0] if A.size else 0
            A, Bm, Cm = A.reshape(nx, nx), Bm.reshape(nx, p), Cm.reshape(p, nx)
            if H.shape[0] > 1 or Dm.shape != (p, p):
                raise DimensionError(f"Component {self.name!r}: a realization needs a "
                                     f"time-invariant kernel and D of shape ({p}, {p})")
            object.__setattr__(self, "realization", (A, Bm, Cm, Dm))

    @property
    def p(self) -> int:
        return len(self.dofs)

    @property
    def lags(self) -> int:
        return self.kernel.shape[1]

    @property
    def time_varying(self) -> bool:
        return self.kernel.shape[0] > 1

    def at(self, n: int) -> np.ndarray:
        """The kernel (L, p, p) at sample ``n``."""
        return self.kernel[min(n, self.kernel.shape[0] - 1)]


@dataclass(frozen=True)
class CoupledResult:
    """Parent histories (n_dofs or p rows × n_samples; NaN after a divergence), interface
    forces ``g`` (P × n_samples, the force on the components), ``diverged_at_step``
    (``-1``: never), the scheme and the growth factor (NaN if not computed)."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    g: np.ndarray
    diverged_at_step: int
    scheme: str
    growth: float


class _Coupler:
    """The parent's Newmark step with the components' interface forces (dense parent)."""

    def __init__(self, s: Structure, components: Sequence[Component], dt: float):
        if not (s.is_linear and s.is_time_invariant):
            raise InputError(f"couple: the parent {s.name!r} must be linear and time-invariant "
                             "(time variation and nonlinearity belong to the components)")
        self.h = h = float(dt)
        self.bh2, self.gh = BETA * h * h, GAMMA * h
        self.M = s.M.toarray()
        self.K = s.K.toarray()
        self.C = s.damping_matrix().toarray()
        self.damped = bool(np.any(self.C))
        N = self.M.shape[0]
        S = self.M + self.gh * self.C + self.bh2 * self.K
        self.S = scipy.linalg.cho_factor(S)
        self.comps = list(components)
        cols, start = [], 0
        for c in self.comps:
            if max(c.dofs) >= N or min(c.dofs) < 0:
                raise InputError(f"couple: component {c.name!r} DOFs {list(c.dofs)} outside "
                                 f"the parent's 0..{N - 1}")
            cols.append(np.arange(start, start + c.p))
            start += c.p
        self.cols = cols
        self.P = start
        all_dofs = [d for c in self.comps for d in c.dofs]
        if len(set(all_dofs)) != len(all_dofs):
            raise InputError("couple: two components share a parent DOF")
        self.B = np.zeros((N, self.P))
        self.B[all_dofs, np.arange(self.P)] = 1.0
        self.SB = scipy.linalg.cho_solve(self.S, self.B)
        self.BSB = self.B.T @ self.SB
        # rows of the compatibility: accelerations as they are, velocities scaled by γh,
        # displacements by βh² (the weight of a_{n+1} in v_{n+1}, q_{n+1})
        weight = {"acceleration": 1.0, "velocity": self.gh, "displacement": self.bh2}
        self.scale = np.concatenate([np.full(c.p, weight[c.quantity]) for c in self.comps]
                                    + [[]])
        self.disp = np.concatenate([np.full(c.p, c.quantity == "displacement")
                                    for c in self.comps] + [np.zeros(0, bool)])
        self.vel = np.concatenate([np.full(c.p, c.quantity == "velocity")
                                   for c in self.comps] + [np.zeros(0, bool)])
        self._cache: dict = {}
        self.time_varying = any(c.time_varying for c in self.comps)
        self.ss = bool(self.comps) and all(c.realization is not None for c in self.comps)
        self.nx = 0
        if self.ss:  # block-diagonal realization of all components
            reals = [c.realization for c in self.comps if c.realization is not None]
            self.Ax = scipy.linalg.block_diag(*[r[0] for r in reals])
            self.Bx = scipy.linalg.block_diag(*[r[1] for r in reals])
            self.Cx = scipy.linalg.block_diag(*[r[2] for r in reals])
            self.nx = self.Ax.shape[0]

    def h0(self, n: int) -> np.ndarray:
        """Block diagonal of the components' lag-0 kernels at sample ``n``."""
        D = np.zeros((self.P, self.P))
        for c, cc in zip(self.comps, self.cols, strict=True):
            D[np.ix_(cc, cc)] = c.at(n)[0]
        return D

    def matrices(self, n: int, scheme: str):
        """The per-step solve of the scheme at sample ``n`` (cached when time-invariant)."""
        key = (0 if not self.time_varying else n, scheme)
        if key not in self._cache:
            H0 = self.h0(n)
            A = H0 + self.scale[:, None] * self.BSB if scheme == "implicit" else H0
            try:
                Ainv = np.linalg.inv(A)
            except np.linalg.LinAlgError:
                raise InputError(f"couple: the {scheme} interface matrix is singular at sample "
                                 f"{n} (a kernel with H[0] = 0 cannot be coupled this way)"
                                 ) from None
            if not self.time_varying:
                self._cache.clear()
            self._cache[key] = Ainv
        return self._cache[key]

    def history(self, n: int, past, memory: int | None = None) -> np.ndarray:
        """``r`` at sample ``n``: Σ_{k≥1} H[n, k] g[n−k]; ``past(k)`` gives ``g[n−k]`` rows
        (P, …) for k = 1 … kmax as an array (kmax, P, …); ``memory`` overrides the number
        of past samples available (default ``n``)."""
        r = np.zeros((0,) + past(0).shape[2:])
        for c, cc in zip(self.comps, self.cols, strict=True):
            Hn = c.at(n)
            m = min(c.lags - 1, n if memory is None else memory)
            if m <= 0:
                rc = np.zeros((c.p,) + past(0).shape[2:])
            else:
                gp = past(m)[:, cc]                       # (m, p, …)
                rc = np.tensordot(Hn[1:m + 1], gp, axes=([0, 2], [0, 1])) if gp.ndim == 3 \
                    else np.einsum("kij,kj->i", Hn[1:m + 1], gp)
            r = np.concatenate([r, rc])
        return r

    def step(self, q, v, a, f, r, g_prev, n: int, scheme: str):
        """One step to sample ``n`` (columns of several states at once are allowed)."""
        qp = q + self.h * v + self.bh2 * a
        vp = v + self.gh * a
        rhs = -(self.K @ qp)
        if f is not None:
            rhs = rhs + (f if rhs.ndim == 1 else f[:, None])
        if self.damped:
            rhs -= self.C @ vp
        astar = scipy.linalg.cho_solve(self.S, rhs)
        if self.P == 0:  # no component: the parent's own Newmark step
            g0 = np.zeros((0,) + rhs.shape[1:])
            return qp + self.bh2 * astar, vp + self.gh * astar, astar, g0
        Ainv = self.matrices(n, scheme)
        sc = self.scale if astar.ndim == 1 else self.scale[:, None]
        dsp = self.disp if astar.ndim == 1 else self.disp[:, None]
        vel = self.vel if astar.ndim == 1 else self.vel[:, None]
        if scheme == "implicit":
            y = sc * (self.B.T @ astar) + np.where(dsp, self.B.T @ qp, 0.0) \
                + np.where(vel, self.B.T @ vp, 0.0)
            g = Ainv @ (y - r)
            a = astar - self.SB @ g
        else:
            a = astar - self.SB @ g_prev
            qn, vn = qp + self.bh2 * a, vp + self.gh * a
            y = np.where(dsp, self.B.T @ qn, np.where(vel, self.B.T @ vn, self.B.T @ a))
            g = Ainv @ (y - r)
        q = qp + self.bh2 * a
        v = vp + self.gh * a
        return q, v, a, g


class _FastStep:
    """The coupled step of one state vector with the operators premultiplied by ``S⁻¹``
    (``S⁻¹K``, ``S⁻¹C``, the loads ``S⁻¹f`` of every sample in one solve): the same
    arithmetic as :meth:`_Coupler.step` in a few dense products per step."""

    def __init__(self, cp: _Coupler, f: np.ndarray, scheme: str):
        self.cp, self.scheme = cp, scheme
        self.SK = scipy.linalg.cho_solve(cp.S, cp.K)
        self.SC = scipy.linalg.cho_solve(cp.S, cp.C) if cp.damped else None
        self.Sf = scipy.linalg.cho_solve(cp.S, f)
        self.idx = np.array([d for c in cp.comps for d in c.dofs], dtype=np.int64)
        self.any_offset = bool(np.any(cp.disp) or np.any(cp.vel))
        self.unit = bool(np.all(cp.scale == 1.0))
        self.Ainv = None if cp.time_varying or not cp.P else cp.matrices(0, scheme)

    def __call__(self, q, v, a, r, g_prev, n: int):
        cp = self.cp
        qp = q + cp.h * v + cp.bh2 * a
        vp = v + cp.gh * a
        astar = self.Sf[:, n] - self.SK @ qp
        if self.SC is not None:
            astar -= self.SC @ vp
        if not cp.P:
            return qp + cp.bh2 * astar, vp + cp.gh * astar, astar, g_prev
        Ainv = self.Ainv if self.Ainv is not None else cp.matrices(n, self.scheme)
        idx = self.idx
        if self.scheme == "implicit":
            y = astar[idx] if self.unit else cp.scale * astar[idx]
            if self.any_offset:
                y = y + np.where(cp.disp, qp[idx], 0.0) + np.where(cp.vel, vp[idx], 0.0)
            g = Ainv @ (y - r)
            a = astar - cp.SB @ g
        else:
            a = astar - cp.SB @ g_prev
            y = np.where(cp.disp, qp[idx] + cp.bh2 * a[idx],
                         np.where(cp.vel, vp[idx] + cp.gh * a[idx], a[idx])) \
                if self.any_offset else a[idx]
            g = Ainv @ (y - r)
        return qp + cp.bh2 * a, vp + cp.gh * a, a, g


def _check_scheme(scheme: str) -> str:
    if scheme not in SCHEMES:
        raise InputError(f"couple: scheme must be one of {SCHEMES}, got {scheme!r}")
    return scheme


def growth_factor(structure: Structure, components: Sequence[Component], dt: float,
                  scheme: str = "implicit", *, times: Sequence[int] | None = None) -> float:
    """Spectral radius of the unforced coupled step on (q, v, a, kernel memory).

    A time-varying kernel is frozen at ``times`` (default :data:`FROZEN_TIMES` samples
    spread over its rows) and the largest radius is returned.
    """
    _check_scheme(scheme)
    cp = _Coupler(structure, components, dt)
    return _growth(cp, scheme, times)


def _growth_ss(cp: _Coupler, scheme: str) -> float:
    N, P, nx = cp.M.shape[0], cp.P, cp.nx
    D = 3 * N + nx + P
    Z = np.eye(D)
    q, v, a = Z[:N], Z[N:2 * N], Z[2 * N:3 * N]
    x, g = Z[3 * N:3 * N + nx], Z[3 * N + nx:]
    x1 = cp.Ax @ x + cp.Bx @ g
    q1, v1, a1, g1 = cp.step(q, v, a, None, cp.Cx @ x1, g, 1, scheme)
    T = np.vstack([q1, v1, a1, x1, g1])
    return float(np.max(np.abs(np.linalg.eigvals(T))))


def _growth(cp: _Coupler, scheme: str, times) -> float:
    if cp.ss:
        return _growth_ss(cp, scheme)
    N, P = cp.M.shape[0], cp.P
    L = max(c.lags for c in cp.comps)
    mem = max(L - 1, 1)  # g_n … g_{n−mem+1}
    D = 3 * N + P * mem
    if times is None:
        nt = max(c.kernel.shape[0] for c in cp.comps)
        times = sorted({int(t) for t in np.linspace(0, nt - 1, min(nt, FROZEN_TIMES))})
    rho = 0.0
    Z = np.eye(D)
    for t in times:
        n = int(t)  # the kernel frozen at row n, its whole memory in use
        q, v, a = Z[:N], Z[N:2 * N], Z[2 * N:3 * N]
        Gh = Z[3 * N:].reshape(mem, P, D)  # Gh[j] = g_{n−1−j}

        def past(m, Gh=Gh):
            return Gh[:m] if m > 0 else np.zeros((1, P, D))

        r = cp.history(n, past, memory=mem)
        q1, v1, a1, g1 = cp.step(q, v, a, None, r, Gh[0], n, scheme)
        T = np.vstack([q1, v1, a1, g1, Gh[:mem - 1].reshape((mem - 1) * P, D)])
        rho = max(rho, float(np.max(np.abs(np.linalg.eigvals(T)))))
    return rho


def _checked_growth(cp, scheme: str, dt: float) -> float:
    """The growth factor of the coupled step; :class:`UnstableCouplingError` above
    ``1 + GROWTH_TOL`` (the run would diverge)."""
    growth = _growth(cp, scheme, None)
    if growth > 1.0 + GROWTH_TOL:
        mp = 1.0 / np.diag(cp.BSB)
        # the interface mass a lag-0 kernel shows: weight / H[0] (1, γh or βh², as the rows)
        h0 = np.abs(np.diag(cp.h0(0)))
        mc = cp.scale / np.where(h0 > 0, h0, np.inf)
        raise UnstableCouplingError(
            f"couple: the {scheme} scheme diverges here (growth factor {growth:.4g} > 1 at "
            f"dt = {dt:g} s; component interface mass {max(mc):.3g} vs the parent's "
            f"{min(mp):.3g} lbf·s²/in): use scheme='implicit'")
    return growth


def _initial_state(cp, q0, v0, f: np.ndarray):
    """``(q0, v0, a0)`` of the parent (``M a0 = f0 − K q0 − C v0``); the interface must be at
    rest (podbench's f_0 = 0 convention)."""
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    rhs0 = f[:, 0] - cp.K @ q - (cp.C @ v if cp.damped else 0.0)
    a = scipy.linalg.solve(cp.M, rhs0, assume_a="pos")
    Bt = cp.B.T
    if np.any(Bt @ q) or np.any(Bt @ v) or np.any(np.abs(Bt @ a) > 1e-12 * (np.abs(a).max()
                                                                          + 1e-300)):
        raise InputError("couple: the interface must be at rest at t_0 (q, v and the initial "
                         "acceleration zero at the interface DOFs: podbench's f_0 = 0)")
    return q, v, a


def couple(structure: Structure, q0, v0, f, dt: float, components: Sequence[Component], *,
           scheme: str = "implicit", check: bool = True, limit: float | None = None,
           record=None) -> CoupledResult:
    """Integrate the parent with the components attached (see the module docstring).

    Parameters
    ----------
    structure : Structure
        The finite-element parent (linear, time-invariant).
    q0, v0 : (n_dofs,) array_like
        Initial state of the parent; the interface DOFs must be at rest.
    f : (n_dofs, n_samples) array_like
        Load on the parent (lbf), ``f[:, 0]`` entering the initial acceleration.
    dt : float
        Time step (s).
    components : sequence of Component
        The kernels at their interface DOFs.
    scheme : {"implicit", "two-step"}
        The interface solve (see the module docstring).
    check : bool
        Compute the growth factor of a two-step coupling first and refuse it if it
        exceeds ``1 + GROWTH_TOL`` (:class:`UnstableCouplingError`). ``False`` runs it anyway
        (to measure where it diverges).
    limit : float, optional
        The run stops (``diverged_at_step`` set, later samples NaN) at the first sample
        where a displacement exceeds ``limit`` in magnitude or is not finite.
    record : (p, n_dofs) array_like, optional
        Output matrix: only ``R q``, ``R v``, ``R a`` are stored.
    """
    scheme = _check_scheme(scheme)
    cp = _Coupler(structure, components, dt)
    f = np.asarray(f, dtype=float)
    N = cp.M.shape[0]
    if f.ndim != 2 or f.shape[0] != N:
        raise DimensionError(f"couple: f must be ({N}, n_samples), got {f.shape}")
    n = f.shape[1]
    growth = _checked_growth(cp, scheme, dt) if check and scheme == "two-step" and cp.P \
        else float("nan")
    if record is not None and hasattr(record, "toarray"):
        record = record.toarray()
    R = None if record is None else np.asarray(record, dtype=float)
    q, v, a = _initial_state(cp, q0, v0, f)
    rows = N if R is None else R.shape[0]
    Q, V, A = (np.full((rows, n), np.nan) for _ in range(3))
    G = np.zeros((cp.P, n))
    out = (lambda x: x) if R is None else (lambda x: R @ x)
    Q[:, 0], V[:, 0], A[:, 0] = out(q), out(v), out(a)
    diverged = -1

    def past(m):
        return G[:, j + 1 - m:j + 1].T[::-1] if m > 0 else np.zeros((1, cp.P))

    fast = _FastStep(cp, f, scheme)
    x = np.zeros(cp.nx) if cp.ss else None
    Rq = None if R is None else R
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(n - 1):
            if not cp.P:
                r = None
            elif cp.ss:
                x = cp.Ax @ x + cp.Bx @ G[:, j]
                r = cp.Cx @ x
            else:
                r = cp.history(j + 1, past)
            q, v, a, g = fast(q, v, a, r, G[:, j], j + 1)
            G[:, j + 1] = g
            if not np.all(np.isfinite(q)) or (limit is not None
                                               and np.max(np.abs(q)) > limit):
                diverged = j + 1
                G[:, j + 1:] = np.nan
                break
            if Rq is None:
                Q[:, j + 1], V[:, j + 1], A[:, j + 1] = q, v, a
            else:
                Q[:, j + 1], V[:, j + 1], A[:, j + 1] = Rq @ q, Rq @ v, Rq @ a
    return CoupledResult(q=Q, v=V, a=A, g=G, diverged_at_step=diverged, scheme=scheme,
                         growth=growth)


def newmark_kernel(M, C, K, dofs, n_lags: int, dt: float, *,
                   quantity: str = "acceleration") -> np.ndarray:
    """The exact Newmark-discrete kernel (n_lags, p, p) of a linear component (M, C, K its
    own matrices, ``dofs`` its interface DOFs): the interface response to a unit force at
    one sample, the component at rest before it (so ``H[0] = Eᵀ S⁻¹ E`` for accelerations,
    ``γh EᵀS⁻¹E`` for velocities, ``βh² EᵀS⁻¹E`` for displacements,
    ``S = M + h/2 C + h²/4 K``)."""
    M, K = (np.asarray(x.toarray() if hasattr(x, "toarray") else x, dtype=float) for x in (M, K))
    C = np.zeros_like(M) if C is None else np.asarray(
        C.toarray() if hasattr(C, "toarray") else C, dtype=float)
    if quantity not in QUANTITIES:
        raise InputError(f"newmark_kernel: quantity must be one of {QUANTITIES}")
    h = float(dt)
    bh2, gh = BETA * h * h, GAMMA * h
    dofs = list(np.ravel(dofs))
    p = len(dofs)
    E = np.zeros((M.shape[0], p))
    E[dofs, np.arange(p)] = 1.0
    Sf = scipy.linalg.cho_factor(M + gh * C + bh2 * K)
    a = scipy.linalg.cho_solve(Sf, E)
    q, v = bh2 * a, gh * a
    H = np.empty((n_lags, p, p))
    for k in range(n_lags):
        H[k] = {"acceleration": a, "velocity": v, "displacement": q}[quantity][dofs]
        qp, vp = q + h * v + bh2 * a, v + gh * a
        a = scipy.linalg.cho_solve(Sf, -(K @ qp) - C @ vp)
        q, v = qp + bh2 * a, vp + gh * a
    return H


def newmark_realization(M, C, K, dofs, dt: float, *, quantity: str = "acceleration"
                        ) -> tuple:
    """``(A, B, C, D)`` of a linear component's Newmark step (state: the component's
    ``q, v, a`` after the previous step), whose kernel is :func:`newmark_kernel`."""
    M, K = (np.asarray(x.toarray() if hasattr(x, "toarray") else x, dtype=float) for x in (M, K))
    Cd = np.zeros_like(M) if C is None else np.asarray(
        C.toarray() if hasattr(C, "toarray") else C, dtype=float)
    h = float(dt)
    bh2, gh = BETA * h * h, GAMMA * h
    m = M.shape[0]
    dofs = list(np.ravel(dofs))
    E = np.zeros((m, len(dofs)))
    E[dofs, np.arange(len(dofs))] = 1.0
    Sf = scipy.linalg.cho_factor(M + gh * Cd + bh2 * K)
    I, Z = np.eye(m), np.zeros((m, m))
    Pq = np.hstack([I, h * I, bh2 * I])
    Pv = np.hstack([Z, I, gh * I])
    Ma = -scipy.linalg.cho_solve(Sf, K @ Pq + Cd @ Pv)
    SE = scipy.linalg.cho_solve(Sf, E)
    A = np.vstack([Pq + bh2 * Ma, Pv + gh * Ma, Ma])
    B = np.vstack([bh2 * SE, gh * SE, SE])
    if quantity not in QUANTITIES:
        raise InputError(f"newmark_realization: quantity must be one of {QUANTITIES}")
    if quantity == "acceleration":
        return A, B, E.T @ Ma, E.T @ SE
    if quantity == "velocity":
        return A, B, E.T @ (Pv + gh * Ma), gh * (E.T @ SE)
    return A, B, E.T @ (Pq + bh2 * Ma), bh2 * (E.T @ SE)


def point_mass_kernel(m, *, quantity: str = "acceleration", dt: float | None = None
                      ) -> np.ndarray:
    """Exact kernel of a point mass ``m`` (a number, or (n,) masses ``m(t_n)``): acceleration
    ``g/m`` at lag 0 — (1, 1, 1) or (n, 1, 1, 1). Displacement kernels need ``dt`` and are
    only given for a constant mass (Newmark from rest: ``H[k] = (k + ¼) h²/m`` for k ≥ 1)."""
    m = np.asarray(m, dtype=float)
    if np.any(m <= 0) or not np.all(np.isfinite(m)):
        raise InputError("point_mass_kernel: masses must be positive and finite")
    if quantity == "acceleration":
        return (1.0 / m).reshape(-1, 1, 1, 1) if m.ndim else np.full((1, 1, 1), 1.0 / m)
    raise InputError("point_mass_kernel: only acceleration kernels are provided")
