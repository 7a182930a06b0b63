"""Passivity of a component's identified interface kernel, and its enforcement (Chapter 6).

A component coupled to a finite-element parent by the implicit interface solve of
:mod:`podbench.dynamics.coupling` exchanges energy with the parent through the interface.
Average-acceleration Newmark is the trapezoidal rule, under which the parent's energy
``E = ½vᵀMv + ½qᵀKq`` changes per step by exactly ``h v̄ᵀ f̄`` (``v̄, f̄`` the means over
the step's two ends). The component receives ``h Σ v̄ᵀ ḡ`` from the parent. If the
component is **passive** in this discrete sense (it can never give back more energy than it
received from rest) the coupled energy cannot grow, and the coupled step is stable by
construction (growth factor ≤ 1), over any horizon. A real, passive component's exact
Newmark kernel is passive; a kernel identified from noisy records need not be, and coupled
to an undamped parent a non-passive kernel grows slowly (growth factor 1.0005–1.02 per step
on the heavy chain of the substructuring study).

The condition in the frequency domain (``z = e^{jω}``, ``ω`` in radians per sample, ``H(z)``
the kernel's z-transform ``Σ_k H[k] z^{−k}``, ``Ψ(X) = (X − Xᴴ)/(2j)`` the Hermitian
"imaginary part"): the discrete mobility from ``ḡ`` to ``v̄`` is

* acceleration kernels: ``Y(z) = (h/2)(z+1)/(z−1) H(z)``, positive real iff
  ``Ψ(H(e^{jω})) ⪰ 0`` on ``0 < ω < π`` and ``H(1) + H(1)ᵀ ⪰ 0`` (its pole at ``z = 1``:
  a free mass's ``1/m``; a grounded component has ``H(1) = 0``);
* velocity kernels: ``Y(z) = H(z)`` (the trapezoidal means of force and velocity carry the
  same factor ``(1 + z⁻¹)/2``), positive real iff ``Φ(H(e^{jω})) ⪰ 0`` on ``0 ≤ ω ≤ π``,
  ``Φ(X) = (X + Xᴴ)/2`` the Hermitian "real part" (checked on the grid and at ``z = 1``);
* displacement kernels: ``Y(z) = (2/h)(z−1)/(z+1) H(z)``, positive real iff
  ``Ψ(H(e^{jω})) ⪯ 0`` on ``0 < ω < π`` and ``H(−1) + H(−1)ᵀ ⪰ 0`` (its pole at
  ``z = −1``).

These are the continuous conditions ``Im A(jΩ) ≥ 0`` (accelerance), ``Re V(jΩ) ≥ 0``
(mobility) and ``Im X(jΩ) ≤ 0`` (receptance) carried through the bilinear (trapezoidal)
map, which preserves positive realness; ``Δt`` does not appear (``ω`` is per sample), nor
do the units of force or response (the conditions are homogeneous).

**Enforcement** (:func:`enforce_passivity`) of a state-space kernel ``(A, B, C, D)``
(``H[0] = D``, ``H[k] = C A^{k−1} B``) by residue perturbation with the poles fixed
(Grivet-Talocia 2004; Grivet-Talocia & Ubolli 2006, "passivity enforcement with relative
error control"): the conditions are linear in ``C``, so the passive ``C`` closest to the
identified kernel over its ``L`` lags, ``min Σ_{k<L} ‖ΔC A^{k−1} B‖²``, is a least-distance
quadratic program, solved exactly by nonnegative least squares (Lawson & Hanson 1974,
LDP) on a frequency grid that is refined where the check finds a violation (the pole
frequencies, with points spaced by each pole's bandwidth). Poles on or outside the unit
circle are first moved to the radius ``ρ`` at which the kernel changes by at most
:data:`POLE_LOSS` over its ``L`` lags, ``ρ^L = 1 − POLE_LOSS`` (a pole on the circle carries
no measured damping; a lossless pole would need its residue exactly right); ``C`` is
refitted to the identified kernel by least squares before the program. ``D`` is refitted
with ``C`` (it enters the acceleration and displacement conditions only at ``z = ±1``, the
velocity condition at every frequency).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy  # scipy.signal, scipy.optimize: loaded on first use (SciPy's lazy submodules)

from podbench.errors import DimensionError, InputError

__all__ = ["PassivityResult", "passivity_margin", "enforce_passivity", "realization_kernel",
           "QUANTITIES", "POLE_LOSS"]

QUANTITIES = ("acceleration", "velocity", "displacement")
POLE_LOSS = 0.01
"""A pole on or outside the unit circle is moved inside to the radius at which the kernel
changes by this fraction over its lags (``ρ^L = 1 − POLE_LOSS``)."""
GRID = 2048
"""Uniform frequency points on (0, π) of the constraint grid (more near every pole)."""
CHECK = 16
"""The check grid is this many times finer than the constraint grid."""
ITERATIONS = 30
"""Refinements of the constraint grid at most."""
ON_CIRCLE = 1e-9
"""A pole within this of the unit circle counts as on it (an identified pole pulled onto the
circle lands at ``|λ| = 1 ± 1e-16``, on either side depending on round-off)."""
TOL = 1e-10
"""A violation below ``TOL ×`` the kernel's peak frequency response counts as none."""


@dataclass
class PassivityResult:
    """The passive realization ``(A, B, C, D)`` and ``info``: ``margin_before`` and
    ``margin_after`` (the smallest eigenvalue of the condition's Hermitian matrix over the
    check grid, relative to the kernel's peak response: negative = a violation),
    ``kernel_change`` (‖ΔH‖/‖H‖ over the lags; 0 below ``TOL``, round-off), ``poles_moved``,
    ``iterations``."""

    realization: tuple
    info: dict = field(default_factory=dict)


def _check(realization, quantity: str):
    if quantity not in QUANTITIES:
        raise InputError(f"passivity: quantity must be one of {QUANTITIES}, got {quantity!r}")
    A, B, C, D = (np.atleast_2d(np.asarray(x, dtype=float)) for x in realization)
    nx = A.shape[0] if A.size else 0
    p = D.shape[0]
    A, B, C = A.reshape(nx, nx), B.reshape(nx, p), C.reshape(p, nx)
    if D.shape != (p, p):
        raise DimensionError(f"passivity: D must be square, got {D.shape}")
    return A, B, C, D


class _Modal:
    """``C (zI − A)⁻¹ B`` as ``Σ_i (C V)_{:,i} (V⁻¹B)_{i,:} / (z − λ_i)``."""

    def __init__(self, A, B):
        self.lam, self.V = np.linalg.eig(A)
        self.Bt = np.linalg.solve(self.V, B)                       # (n, p)

    def K(self, z):
        """(len z, n, p): ``V diag(1/(z − λ)) V⁻¹ B`` per point."""
        w = 1.0 / (z[:, None] - self.lam[None, :])                # (m, n)
        return np.einsum("ij,mj,jp->mip", self.V, w, self.Bt)

    def response(self, C, D, z):
        return D[None] + np.einsum("rn,mnp->mrp", C, self.K(z))


def _grid(lam, n: int) -> np.ndarray:
    """Uniform points on (0, π) plus, near every pole, points spaced by its bandwidth."""
    pts = [np.linspace(0.0, np.pi, n + 2)[1:-1]]
    steps = np.array([0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0])
    for lm in lam:
        th, bw = abs(np.angle(lm)), max(1.0 - abs(lm), 1e-9)
        pts += [th - steps * bw, th + steps * bw]
    w = np.concatenate(pts)
    return np.unique(w[(w > 0) & (w < np.pi)])


def _psi(G, quantity: str):
    """The condition's Hermitian matrices for a stack (m, p, p) of complex responses:
    ``Ψ(G)`` (acceleration), ``Φ(G)`` (velocity), ``−Ψ(G)`` (displacement)."""
    Gh = np.conj(np.transpose(G, (0, 2, 1)))
    if quantity == "velocity":
        return (G + Gh) / 2
    return _sign(quantity) * (G - Gh) / 2j


def _sign(quantity: str) -> float:
    return -1.0 if quantity == "displacement" else 1.0


def _pole_points(quantity: str):
    return np.array([-1.0 + 0j]) if quantity == "displacement" else np.array([1.0 + 0j])


def _eig_parts(modal, C, D, w, quantity):
    """Smallest eigenvalues and eigenvectors of the condition's matrices on ``w`` and at
    the pole point (the last row)."""
    G = modal.response(C, D, np.exp(1j * w))
    Pm = _psi(G, quantity)
    G0 = modal.response(C, D, _pole_points(quantity)).real
    P0 = (G0 + np.transpose(G0, (0, 2, 1))) / 2
    lam_w, U_w = np.linalg.eigh(Pm)
    lam_0, U_0 = np.linalg.eigh(P0)
    return lam_w[:, 0], U_w[:, :, 0], lam_0[:, 0], U_0[:, :, 0]


def passivity_margin(realization, quantity: str = "acceleration", *, n_grid: int = GRID * CHECK
                     ) -> tuple[float, float]:
    """The smallest eigenvalue of the passivity condition over a fine grid (module
    docstring), relative to the kernel's peak frequency response, and the ``ω``
    (rad/sample) where it occurs (``0`` or ``π`` for the pole condition). Negative: not
    passive; ``−inf``: a pole on (within :data:`ON_CIRCLE`) or outside the unit circle,
    where the condition cannot be evaluated; within ``±TOL`` it is reported as 0 (the
    round-off of a lossless or exactly passive kernel, which would otherwise print
    differently with another CPU's round-off)."""
    A, B, C, D = _check(realization, quantity)
    if A.shape[0] and np.max(np.abs(np.linalg.eigvals(A))) >= 1.0 - ON_CIRCLE:
        return -np.inf, float("nan")
    modal = _Modal(A, B)
    w = _grid(modal.lam, n_grid)
    lw, _, l0, _ = _eig_parts(modal, C, D, w, quantity)
    scale = _peak(modal, C, D, w)
    i = int(np.argmin(lw))
    if l0[0] < lw[i]:
        m, at = float(l0[0] / scale), float(np.pi) if quantity == "displacement" else 0.0
    else:
        m, at = float(lw[i] / scale), float(w[i])
    return (0.0 if abs(m) < TOL else m), at  # within ±TOL: round-off of a passive kernel


def _peak(modal, C, D, w) -> float:
    G = modal.response(C, D, np.exp(1j * w))
    return float(np.max(np.abs(G))) or 1.0


def _constraint_rows(modal, C, D, w, quantity, tol):
    """Linear constraints ``a · vec(C) ≥ b`` at the violating points of ``w`` (and the
    pole point), from the eigenvector of the smallest eigenvalue there."""
    lw, Uw, l0, U0 = _eig_parts(modal, C, D, w, quantity)
    rows, rhs = [], []
    bad = np.flatnonzero(lw < tol)
    if bad.size:
        K = modal.K(np.exp(1j * w[bad]))                          # (m, n, p)
        u = Uw[bad]                                               # (m, p)
        Ku = np.einsum("mnp,mp->mn", K, u)                        # (m, n)
        # uᴴ (C K + D) u = Σ_{r,n} conj(u_r) C_{rn} (K u)_n + Σ_{r,c} conj(u_r) D_{rc} u_c:
        # its imaginary part (× sign; D real: none) or, velocity, its real part
        cu = np.einsum("mr,mn->mrn", np.conj(u), Ku)
        if quantity == "velocity":
            coef = np.concatenate([cu.real, np.einsum("mr,mc->mrc", np.conj(u), u).real],
                                  axis=2)
        else:
            coef = np.concatenate([_sign(quantity) * cu.imag,
                                   np.zeros((bad.size, C.shape[0], C.shape[0]))], axis=2)
        rows.append(coef.reshape(bad.size, -1))
        rhs.append(np.zeros(bad.size))
    if l0[0] < tol:
        K0 = modal.K(_pole_points(quantity)).real[0]              # (n, p)
        u0 = U0[0]
        coef = np.hstack([np.outer(u0, K0 @ u0), np.outer(u0, u0)])   # uᵀ (C K + D) u
        rows.append(coef.reshape(1, -1))
        rhs.append(np.zeros(1))
    if not rows:
        return np.zeros((0, C.size + D.size)), np.zeros(0)
    return np.vstack(rows), np.concatenate(rhs)


def _ldp(E: np.ndarray, f: np.ndarray) -> np.ndarray | None:
    """``min ‖y‖`` subject to ``E y ≥ f`` (Lawson & Hanson's LDP by NNLS); None if
    infeasible."""
    nrm = np.linalg.norm(E, axis=1)
    nrm[nrm == 0] = 1.0
    E, f = E / nrm[:, None], f / nrm
    n = E.shape[1]
    Mt = np.vstack([E.T, f[None, :]])
    d = np.zeros(n + 1)
    d[-1] = 1.0
    u, _ = scipy.optimize.nnls(Mt, d, maxiter=50 * Mt.shape[1])
    r = Mt @ u - d
    if abs(r[-1]) < 1e-14:
        return None
    return -r[:n] / r[-1]


def _moved(A, n_lags: int):
    """``A`` with its poles at ``|λ| > ρ`` moved to ``ρ`` (``ρ^L = 1 − POLE_LOSS``)."""
    rho = (1.0 - POLE_LOSS) ** (1.0 / max(n_lags, 1))
    lam, V = np.linalg.eig(A)
    big = np.abs(lam) > rho
    if not np.any(big):
        return A, 0
    lam = np.where(big, lam * rho / np.abs(lam), lam)
    return np.real(V @ np.diag(lam) @ np.linalg.inv(V)), int(np.sum(big))


def _kernel_normal(A, B, C, D, A2, n_lags: int):
    """Normal equations of ``Σ_{k<L} ‖H[k] − H_θ[k]‖²`` in ``θ = [C D]`` (rows), ``H`` the
    original kernel, ``H_θ`` the kernel of ``(A2, B, C_θ, D_θ)``: regressors ``[A2^{k−1}B; 0]``
    (k ≥ 1) and ``[0; I]`` (k = 0)."""
    n, p = B.shape
    m = max(n_lags - 1, 1)
    Z = np.zeros((m + 1, n + p, p))
    Hk = np.empty((m + 1, p, p))
    Z[0, n:] = np.eye(p)
    Hk[0] = D
    x2, x1 = B.copy(), B.copy()
    for k in range(1, m + 1):
        Z[k, :n], Hk[k] = x2, C @ x1
        x2, x1 = A2 @ x2, A @ x1
    W = np.einsum("kip,kjp->ij", Z, Z)
    R = np.einsum("krp,kjp->rj", Hk, Z)                      # Σ H[k] Zᵀ  (p, n+p)
    return W, R, Hk, Z


def _record_normal(A2, B, forces, responses):
    """Normal equations of the records' misfit ``Σ ‖y[n] − C x[n] − D g[n]‖²`` with
    ``x[n+1] = A2 x[n] + B g[n]`` from rest (the measured forces drive the fixed poles)."""
    n, p = B.shape
    W = np.zeros((n + p, n + p))
    R = np.zeros((p, n + p))
    for g, y in zip(forces, responses, strict=True):
        g, y = np.atleast_2d(g), np.atleast_2d(y)
        X = np.zeros((n, g.shape[1]))
        for t in range(g.shape[1] - 1):
            X[:, t + 1] = A2 @ X[:, t] + B @ g[:, t]
        Zr = np.vstack([X, g])
        W += Zr @ Zr.T
        R += y @ Zr.T
    return W, R


def enforce_passivity(realization, quantity: str = "acceleration", *, n_lags: int,
                      records: tuple | None = None, n_grid: int = GRID,
                      iterations: int = ITERATIONS) -> PassivityResult:
    """The passive realization closest to ``realization`` (module docstring): poles moved
    inside, then ``θ = [C D]`` by least-distance quadratic programming, closest in the
    kernel over ``n_lags`` lags, or (``records=(forces, responses)``, lists of (p, n)
    arrays from rest) in the records' misfit: passivity-constrained least squares with
    the poles fixed. :class:`InputError` if no ``θ`` makes it passive."""
    A, B, C, D = _check(realization, quantity)
    n, p = B.shape
    before = passivity_margin((A, B, C, D), quantity)[0] if n else 0.0
    A2, moved = _moved(A, n_lags) if n else (A, 0)
    W, R, Hk, Z = _kernel_normal(A, B, C, D, A2, n_lags)
    if records is not None:
        W, R = _record_normal(A2, B, *records)
    sval, U = np.linalg.eigh(W)
    sval = np.maximum(sval, 1e-14 * sval[-1])
    theta0 = (R @ U / sval[None, :]) @ U.T                    # unconstrained LS (p, n+p)
    Rinv_blk = np.kron(np.eye(p), U / np.sqrt(sval)[None, :])  # W^{-1/2} per row of θ
    modal = _Modal(A2, B)
    fine = _grid(modal.lam, n_grid * CHECK)
    rows, rhs = np.zeros((0, p * (n + p))), np.zeros(0)
    th, it = theta0, 0
    scale = _peak(modal, theta0[:, :n], theta0[:, n:], fine)
    for it in range(1, iterations + 1):
        Cn, Dn = th[:, :n], th[:, n:]
        if it == 1:  # every point of the constraint grid
            pts = _grid(modal.lam, n_grid)
        else:  # the worst points of the check grid, until none violates
            lw, _, l0, _ = _eig_parts(modal, Cn, Dn, fine, quantity)
            if min(lw.min(), l0[0]) >= -TOL * scale:
                break
            pts = fine[np.argsort(lw)[:64]]
        r, b = _constraint_rows(modal, Cn, Dn, pts, quantity, np.inf)
        rows, rhs = np.vstack([rows, r]), np.concatenate([rhs, b])
        # a · vec(θ0 + Δθ) ≥ b with vec(Δθ) = Rinv_blk y
        y = _ldp(rows @ Rinv_blk, rhs - rows @ theta0.ravel())
        if y is None:
            raise InputError("enforce_passivity: no perturbation of the residues makes this "
                             "kernel passive (its poles cannot carry a passive response)")
        th = theta0 + (Rinv_blk @ y).reshape(p, n + p)
    Cn, Dn = th[:, :n], th[:, n:]
    after = passivity_margin((A2, B, Cn, Dn), quantity)[0]
    Hn = np.einsum("rj,kjp->krp", th, Z)
    change = float(np.linalg.norm(Hn - Hk) / (np.linalg.norm(Hk) or 1.0))
    change = 0.0 if change < TOL else change  # round-off of an unchanged kernel
    return PassivityResult((A2, B, Cn, Dn), {"margin_before": before, "margin_after": after,
                                            "kernel_change": change, "poles_moved": moved,
                                            "iterations": it})


def realization_kernel(realization, n_lags: int) -> np.ndarray:
    """The kernel (n_lags, p, p) of ``(A, B, C, D)``: ``H[0] = D``, ``H[k] = C A^{k−1} B``."""
    A, B, C, D = (np.atleast_2d(np.asarray(x, dtype=float)) for x in realization)
    p = D.shape[0]
    nx = A.shape[0] if A.size else 0
    A, B, C = A.reshape(nx, nx), B.reshape(nx, p), C.reshape(p, nx)
    H = np.empty((n_lags, p, p))
    H[0] = D
    x = B.copy()
    for k in range(1, n_lags):
        H[k] = C @ x
        x = A @ x
    return H
